"""Nominal model of a recording (Eqs. 1-2, 9-15), its residuals, and the linear fit engine.

Per test-mass axis ``a`` in ``x1, x2, y1, y2`` (TM1 in frame a, TM2 in frame b), Eqs. 1-2
with the rotation terms dropped (Sec. 2.2) give, sample by sample,

    acc_a - f_a = k_a x_a + f_D,a - (P f_B)_a + noise            (per unit mass)

with ``f`` the commanded force, ``x`` the displacement readout, ``P`` (4x2) the projection
of the spacecraft acceleration ``f_B`` (in-plane, frame s) onto the four axes through
``W_sa`` and ``W_sb`` (Eqs. 5-7).  ``f_B`` is unknown at every sample; the left null space
of ``P`` is 2-D (:func:`null_basis`).  Its first vector is Eq. 11's ``K`` (normalised), so
the first combination *is* the paper's regression ``y = K.(r'' - f_e) = psi' theta``
(Eqs. 10-15); the second is the other f_B-free combination.  Fitting both (the
**equation** group) is the same as estimating ``f_B`` as a per-sample nuisance, and lets a
residual be traced to an axis through its 2-D direction.

The **kinematic** group checks the readouts against the accelerometer (not used by
Eqs. 9-16): for a zero-order-hold force, ``x_{n+1} - 2x_n + x_{n-1} = h^2 (a_n + a_{n-1})/2``
exactly (integrate ``r'' = a_n`` over two steps; the within-step change of ``k r`` is
~1e-16 m).  Its candidates are estimated with instrumental variables (the excitation
tones), because the loop feeds the readout noise back into the measured acceleration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import signal

from tmopt.physics.geometry import Geometry
from tmopt.physics.recording import AXES

__all__ = [
    "AXES",
    "Data",
    "Column",
    "FitResult",
    "data_from_recording",
    "data_from_result",
    "fb_projection",
    "null_basis",
    "equation_target",
    "nominal_equation_columns",
    "kinematic_target",
    "nominal_kinematic_columns",
    "solve",
    "solve_iv",
    "tone_instrument",
    "excitation_tones",
    "output_error",
]


@dataclass
class Data:
    """One recording as arrays (axis order :data:`AXES`): ``x``, ``acc``, ``force`` (4, N)."""

    time: np.ndarray
    fs: float
    x: np.ndarray
    acc: np.ndarray
    force: np.ndarray
    geometry: Geometry
    ref: np.ndarray | None = None
    omega: np.ndarray | None = None
    omega_dot: np.ndarray | None = None
    source: str = "<memory>"
    notes: list[str] = field(default_factory=list)

    @property
    def n(self) -> int:
        return int(self.time.size)

    @property
    def dt(self) -> float:
        return 1.0 / self.fs

    @property
    def centred_time(self) -> np.ndarray:
        return self.time - 0.5 * (self.time[0] + self.time[-1])

    def tones(self, axis: int) -> list[float]:
        """Excitation lines [Hz] of an axis: from the reference when recorded, else from
        the displacement readout itself (y axes: none unless they move)."""
        cache = self.__dict__.setdefault("_tones", {})
        if axis not in cache:
            src = self.ref[axis] if self.ref is not None and axis < 2 else self.x[axis]
            cache[axis] = excitation_tones(src, self.fs)
        return cache[axis]


def excitation_tones(x: np.ndarray, fs: float, max_tones: int = 6) -> list[float]:
    """Frequencies [Hz] of the strongest lines of a series (Hann-windowed periodogram peaks
    at least 1e4 x its median: deterministic excitation, not noise)."""
    m = x.size
    per = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(m))) ** 2
    f = np.fft.rfftfreq(m, 1 / fs)
    peaks, _ = signal.find_peaks(per, height=1e4 * np.median(per[1:]) + 1e-300)
    peaks = peaks[np.argsort(-per[peaks])][:max_tones]
    return sorted(_refine_tone(x, fs, float(f[k])) for k in peaks if k > 0)


def _refine_tone(x: np.ndarray, fs: float, f0: float) -> float:
    """Frequency within +-1 bin of ``f0`` maximising the least-squares sinusoid power (a
    tone between two bins would otherwise give a mismatched instrument)."""
    m = x.size
    t = np.arange(m) / fs
    grid = f0 + np.linspace(-1.0, 1.0, 81) * fs / m
    grid = grid[grid > 0]
    xc = x - x.mean()
    arg = 2 * math.pi * grid[:, None] * t[None]
    s, c = np.sin(arg), np.cos(arg)
    # least-squares sinusoid power via the 2x2 normal equations, all frequencies at once
    ss, cc, sc = np.sum(s * s, 1), np.sum(c * c, 1), np.sum(s * c, 1)
    bs, bc = s @ xc, c @ xc
    det = ss * cc - sc**2
    power = (cc * bs**2 - 2 * sc * bs * bc + ss * bc**2) / np.maximum(det, 1e-300)
    return float(grid[int(np.argmax(power))])


def _longest_valid(rec) -> tuple[slice, list[str]]:
    n = rec.n_samples
    if rec.valid is None or bool(np.all(rec.valid)):
        return slice(0, n), []
    segs = rec.segments(1)
    best = max(segs, key=lambda s: s.stop - s.start)
    note = (f"{n - int(np.sum(rec.valid))} masked samples in {len(rec.gaps)} gap(s): analysed "
            f"the longest valid segment, samples {best.start}..{best.stop - 1}")  # fmt: skip
    return best, [note]


def data_from_recording(rec) -> Data:
    """A validated :class:`~tmopt.physics.recording.Recording` -> :class:`Data`.

    Gaps (NaN samples) are not filled: the longest valid segment is analysed and a note
    says so (the kinematic check needs consecutive samples).
    """
    sl, notes = _longest_valid(rec)

    def stack(fmt: str) -> np.ndarray:
        return np.array([np.asarray(rec[fmt.format(a)], float)[sl] for a in AXES])

    rot = "sc_omega_x" in rec
    return Data(
        time=np.asarray(rec["time"], float)[sl],
        fs=float(rec.attrs["sample_rate"]),
        x=stack("{}"),
        acc=stack("acc_{}"),
        force=stack("force_{}"),
        geometry=Geometry(float(rec.attrs["phi1"]), float(rec.attrs["phi2"])),
        ref=np.array([rec["ref_x1"][sl], rec["ref_x2"][sl]]) if "ref_x1" in rec else None,
        omega=np.array([rec[f"sc_omega_{c}"][sl] for c in "xyz"]) if rot else None,
        omega_dot=np.array([rec[f"sc_omega_dot_{c}"][sl] for c in "xyz"]) if rot else None,
        source=str(getattr(rec, "source", "<memory>")),
        notes=notes,
    )


#: A whole-sample shift of the force channels is taken only if it divides the nominal
#: residual by at least this much (a sub-sample actuation delay makes any shift worse).
ALIGN_GAIN = 2.0


def _shifted(data: Data, lag: int) -> Data:
    """``data`` with ``force[n + lag]`` paired with the other channels' sample n (ends cut)."""
    if lag == 0:
        return data
    keep = slice(0, data.n - lag) if lag > 0 else slice(-lag, data.n)
    move = slice(lag, data.n) if lag > 0 else slice(0, data.n + lag)

    def cut(a):
        return None if a is None else a[..., keep]

    return replace(data, time=data.time[keep], x=data.x[:, keep], acc=data.acc[:, keep],
                   force=data.force[:, move], ref=cut(data.ref), omega=cut(data.omega),
                   omega_dot=cut(data.omega_dot), notes=list(data.notes))


def _nominal_rms(data: Data, basis: np.ndarray) -> float:
    fit = solve(equation_target(data, basis), nominal_equation_columns(data, basis),
                lambda v: v)
    return float(np.sqrt(np.mean(fit.residual**2)))


def align_force_timing(data: Data, max_lag: int = 2) -> Data:
    """Pair each acceleration sample with the force sample that acts on it.

    Simulators differ in how they stamp the commanded force: the force computed at step n
    and applied from t_n on (this package's convention), or the force that produced the
    acceleration measured at t_n (applied from t_(n-1)). Read with the wrong pairing, Eq.
    10 fails by the force's step-to-step change — far above the noise — and every later
    test goes astray. So, as part of the nominal model, the integer lag in
    ``[-max_lag, max_lag]`` that best fits Eq. 10 is chosen (taken only if it divides the
    residual by ``ALIGN_GAIN``), the channels are aligned and a note says so: physically
    the same data would be an actuation delay of that many samples.
    """
    basis = null_basis(data.geometry)
    rms = {lag: _nominal_rms(_shifted(data, lag), basis) for lag in range(-max_lag, max_lag + 1)
           if data.n - abs(lag) > 16}
    best = min(rms, key=rms.get)
    if best == 0 or rms[0] < ALIGN_GAIN * rms[best]:
        return data
    out = _shifted(data, best)
    side = "late" if best > 0 else "early"
    out.notes.append(
        f"the force channels are stamped {abs(best)} sample(s) {side} relative to the "
        f"accelerations (nominal residual {rms[0]:.3g} -> {rms[best]:.3g} m s^-2 when "
        f"aligned); they were aligned before the diagnosis. This is a timestamp convention "
        f"of the recording, or physically an actuation delay of {abs(best) / data.fs:g} s")
    return out


def data_from_result(result, i: int = 0) -> Data:
    """Design ``i`` of a :class:`~tmopt.physics.simulator.SimulationResult` (tests, studies)."""
    d = result.design(i)
    cfg = result.config
    return Data(
        time=np.asarray(d["time"], float),
        fs=float(cfg.sample_rate),
        x=np.array([d[a] for a in AXES]),
        acc=np.array([d[f"acc_{a}"] for a in AXES]),
        force=np.array([d[f"force_{a}"] for a in AXES]),
        geometry=cfg.geometry,
        ref=np.array([d["ref_x1"], d["ref_x2"]]),
        source="<simulation>",
    )


def fb_projection(geometry: Geometry) -> np.ndarray:
    """P (4, 2): in-plane f_B^s seen along x1, x2, y1, y2 (rows of W_sa, W_sb; Eqs. 6-7)."""
    wa, wb = geometry.w_sa[:2, :2], geometry.w_sb[:2, :2]
    return np.array([wa[0], wb[0], wa[1], wb[1]])


def fb_projection_dphi2(geometry: Geometry) -> np.ndarray:
    """dP/dphi2 (4, 2): only TM2's rows depend on phi2 (Eq. 7 differentiated)."""
    c, s = math.cos(geometry.phi2), math.sin(geometry.phi2)
    out = np.zeros((4, 2))
    out[1] = [-s, c]
    out[3] = [-c, -s]
    return out


def null_basis(geometry: Geometry) -> np.ndarray:
    """N (4, 2), orthonormal, ``N' P = 0``; column 0 is Eq. 11's K / |K|.

    Column 1 completes the null space of P' (the f_B-free combinations); its sign makes
    its largest-magnitude entry positive, so the basis is deterministic.
    """
    p = fb_projection(geometry)
    k = geometry.coefficients()
    k = k / np.linalg.norm(k)
    _, _, vt = np.linalg.svd(np.column_stack([p, k]).T)
    n2 = vt[-1]
    n2 = n2 * np.sign(n2[np.argmax(np.abs(n2))])
    return np.column_stack([k, n2])


@dataclass
class Column:
    """One regressor: ``values`` has the shape of its group's target, ``name`` its parameter.

    ``instrument`` (same shape), when given, is the instrumental variable used for this
    column in :func:`solve_iv` -- a version of the regressor free of the noise that the
    control loop feeds back into it.
    """

    name: str
    values: np.ndarray
    instrument: np.ndarray | None = None


def axis_column(basis: np.ndarray, axis: int, series: np.ndarray) -> np.ndarray:
    """Per-axis regressor ``series`` on axis ``axis`` seen in the f_B-free combinations."""
    return np.outer(basis[axis], series)


def equation_target(data: Data, basis: np.ndarray) -> np.ndarray:
    """Eq. 10's output for both combinations: ``N' (acc - f)`` (2, N)."""
    return basis.T @ (data.acc - data.force)


def nominal_equation_columns(data: Data, basis: np.ndarray) -> list[Column]:
    """Eqs. 12-15: stiffness ``k_a x_a`` per axis and the two bias combinations ``N' f_D``."""
    names = ("k1xx", "k2xx", "k1yy", "k2yy")
    cols = [Column(nm, axis_column(basis, a, data.x[a])) for a, nm in enumerate(names)]
    for j in range(basis.shape[1]):
        v = np.zeros((basis.shape[1], data.n))
        v[j] = 1.0
        cols.append(Column(f"R{j + 1}", v))
    return cols


def kinematic_target(data: Data) -> np.ndarray:
    """``x_{n+1} - 2x_n + x_{n-1} - h^2 (a_n + a_{n-1})/2`` (4, N - 2), ZOH kinematics."""
    h2 = data.dt**2
    d2x = data.x[:, 2:] - 2 * data.x[:, 1:-1] + data.x[:, :-2]
    return d2x - h2 * 0.5 * (data.acc[:, 1:-1] + data.acc[:, :-2])


def kinematic_series(data: Data, axis: int) -> np.ndarray:
    """``h^2 (a_n + a_{n-1})/2`` of one axis on the kinematic grid (N - 2,)."""
    return data.dt**2 * 0.5 * (data.acc[axis, 1:-1] + data.acc[axis, :-2])


def nominal_kinematic_columns(data: Data) -> list[Column]:
    """No free parameter: the nominal kinematics is the exact ZOH relation above.

    A 3-tap "sampling convention" nuisance was tried and dropped: the readout noise in the
    second difference (2.4e-11 m per sample, blue) determines its taps only to ~0.1, and
    that uncertainty re-enters the residual at the excitation lines (docs/mismatch.md).
    """
    return []


def tone_instrument(series: np.ndarray, time: np.ndarray, tones: list[float]) -> np.ndarray:
    """The part of ``series`` at the excitation tones (least-squares sines and cosines).

    The excitation is set by the external reference, not by the noise, so this part is a
    valid instrument against closed-loop bias (the reference as instrumental variable);
    without tones it is zero (the axis is not excited).
    """
    if not tones:
        return np.zeros_like(series)
    t = time - time[0]
    basis = np.column_stack([f(2 * math.pi * f0 * t) for f0 in tones for f in (np.sin, np.cos)])
    coef, *_ = np.linalg.lstsq(basis, series, rcond=None)
    return basis @ coef


@dataclass
class FitResult:
    """Weighted least squares on whitened data: coefficients, covariance, residuals."""

    names: list[str]
    coef: np.ndarray
    cov: np.ndarray
    residual: np.ndarray  # physical units, group shape
    rss_white: float
    n_obs: int

    def std(self) -> np.ndarray:
        return np.sqrt(np.maximum(np.diag(self.cov), 0.0))

    def value(self, name: str) -> float:
        return float(self.coef[self.names.index(name)])

    def sigma(self, name: str) -> float:
        return float(self.std()[self.names.index(name)])


def design(columns: list[Column], whiten) -> tuple[np.ndarray, np.ndarray]:
    """Whitened, column-normalised design matrix (n, p) and the normalisation (p,)."""
    cols = [whiten(c.values).ravel() for c in columns]
    x = np.column_stack(cols) if cols else np.zeros((0, 0))
    scale = np.sqrt(np.mean(x**2, axis=0)) if cols else np.zeros(0)
    scale[scale == 0] = 1.0
    return x / scale, scale


def solve(target: np.ndarray, columns: list[Column], whiten) -> FitResult:
    """Generalised least squares: ``whiten(target) ~ whiten(columns) coef``.

    The covariance is ``s^2 (X'X)^-1`` with ``s^2 = RSS/(n - p)`` in whitened units (the
    noise level is profiled, so a mis-scaled noise model does not distort it).
    """
    yw = whiten(target).ravel()
    if not columns:
        return FitResult([], np.zeros(0), np.zeros((0, 0)), target.copy(), float(yw @ yw),
                         yw.size)  # fmt: skip
    x, scale = design(columns, whiten)
    coef_s, *_ = np.linalg.lstsq(x, yw, rcond=None)
    rw = yw - x @ coef_s
    rss = float(rw @ rw)
    s2 = rss / max(yw.size - x.shape[1], 1)
    cov_s = s2 * np.linalg.pinv(x.T @ x)
    coef = coef_s / scale
    cov = cov_s / np.outer(scale, scale)
    fitted = sum(c * col.values for c, col in zip(coef, columns))
    return FitResult([c.name for c in columns], coef, cov, target - fitted, rss, yw.size)


def solve_iv(target: np.ndarray, columns: list[Column], whiten) -> FitResult:
    """Instrumental-variable estimate on whitened data (just identified).

    ``theta = (Z'X)^-1 Z'y``, covariance ``s^2 (Z'X)^-1 Z'Z (X'Z)^-1``; a column without an
    instrument is its own.  Whitening is linear, so a valid (noise-independent) instrument
    stays valid after it.
    """
    yw = whiten(target).ravel()
    if not columns:
        return FitResult([], np.zeros(0), np.zeros((0, 0)), target.copy(), float(yw @ yw),
                         yw.size)  # fmt: skip
    x, scale = design(columns, whiten)
    inst = [Column(c.name, c.values if c.instrument is None else c.instrument) for c in columns]
    z, zscale = design(inst, whiten)
    a = z.T @ x
    ainv = np.linalg.pinv(a)
    coef_s = ainv @ (z.T @ yw)
    rw = yw - x @ coef_s
    rss = float(rw @ rw)
    s2 = rss / max(yw.size - x.shape[1], 1)
    cov_s = s2 * ainv @ (z.T @ z) @ ainv.T
    coef = coef_s / scale
    cov = cov_s / np.outer(scale, scale)
    fitted = sum(c * col.values for c, col in zip(coef, columns))
    return FitResult([c.name for c in columns], coef, cov, target - fitted, rss, yw.size)


def output_error(data: Data, basis: np.ndarray, eq_fitted: np.ndarray) -> np.ndarray:
    """Open-loop replay of the f_B-free positions ``q = N' x`` (2, N): measured - replayed.

    The replay double-integrates (ZOH, exact for held forces) the *model* acceleration
    ``N' f + fitted(N' (acc - f))`` of the identified model, driven by the recorded
    commanded forces; initial position and velocity are fitted by least squares.  f_B
    cancels in these combinations, so no unknown input is needed.  Integrated actuation
    and accelerometer noise make this residual red (random walk): it is a diagnostic of
    the replay, not the statistic of the tests.
    """
    h = data.dt
    model_acc = basis.T @ data.force + eq_fitted
    q = basis.T @ data.x
    vel = np.concatenate([np.zeros((2, 1)), np.cumsum(model_acc[:, :-1] * h, axis=1)], axis=1)
    pos = np.concatenate([np.zeros((2, 1)),
                          np.cumsum(vel[:, :-1] * h + 0.5 * model_acc[:, :-1] * h * h, axis=1)],
                         axis=1)  # fmt: skip
    t = data.time - data.time[0]
    basis_ic = np.column_stack([np.ones_like(t), t])
    out = np.empty_like(q)
    for j in range(2):
        c, *_ = np.linalg.lstsq(basis_ic, q[j] - pos[j], rcond=None)
        out[j] = q[j] - pos[j] - basis_ic @ c
    return out
