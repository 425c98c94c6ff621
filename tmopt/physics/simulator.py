"""Batched closed-loop simulation of both test masses with online stiffness identification.

One call simulates B designs (reference motions of TM1 and TM2) for N samples: dynamics of
Eqs. 1-2 with exact ZOH steps, Table 1 noises, FRBF-PID / PID control (Sec. 3.3) and
recursive least squares on the regression of Eqs. 10-16.  See docs/simulator.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numba
import numpy as np

from tmopt.physics import _closed_loop as cl
from tmopt.physics.control import (
    CONTROLLERS,
    PAPER_RATE,
    ControllerSettings,
    derivative_filter_pole,
)
from tmopt.physics.excitation import MultiSine, ramp_window, sample_times
from tmopt.physics.geometry import Geometry
from tmopt.physics.noise import noise_realisation, noise_sigmas
from tmopt.physics.objectives import PARAMETERS

__all__ = [
    "SimulationConfig",
    "SimulationResult",
    "Perturbations",
    "simulate",
    "CHANNEL_NAMES",
    "GAIN_NAMES",
    "REASONS",
    "RLS_COLUMN_SETS",
]

#: Recorded per-design channels, in the kernel's order.
CHANNEL_NAMES: tuple[str, ...] = (
    "x1_true", "x2_true", "y1_true", "y2_true",
    "x1", "x2", "y1", "y2",
    "acc_x1", "acc_x2", "acc_y1", "acc_y2",
    "force_x1", "force_x2", "force_y1", "force_y2",
)  # fmt: skip

#: Recorded gains of the two sensitive-axis controllers (FRBF-PID: adapted, PID: fixed).
GAIN_NAMES: tuple[str, ...] = ("Kp_x1", "Ki_x1", "Kd_x1", "Kp_x2", "Ki_x2", "Kd_x2")

#: Named sets of identified columns of theta (Eqs. 10-15); docs/decisions.md, "RLS columns".
RLS_COLUMN_SETS: dict[str, tuple[str, ...]] = {
    "all": PARAMETERS,
    "sensitive": ("k1xx", "k2xx", "R"),
}

#: Divergence reasons by status code.
REASONS: dict[int, str] = {
    cl.OUT_X1: "TM1 sensitive-axis displacement |x1| left the divergence bound",
    cl.OUT_X2: "TM2 sensitive-axis displacement |x2| left the divergence bound",
    cl.OUT_Y1: "TM1 non-sensitive displacement |y1| left the divergence bound",
    cl.OUT_Y2: "TM2 non-sensitive displacement |y2| left the divergence bound",
    cl.BAD_FORCE: "controller output became non-finite",
    cl.BAD_ESTIMATE: "RLS estimate became non-finite",
}


def _pair(name: str, value: tuple[float, float], allow_negative: bool = True) -> None:
    if len(value) != 2 or not all(math.isfinite(v) for v in value):
        raise ValueError(f"{name} must be 2 finite numbers; got {value!r}")
    if not allow_negative and min(value) < 0:
        raise ValueError(f"{name} must be >= 0; got {value!r}")


def _positive(name: str, value: float, hint: str = "(0, inf)") -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be finite and in {hint}; got {value!r}")


@dataclass(frozen=True)
class SimulationConfig:
    """Everything but the reference motion.  Defaults: Table 1 and Secs. 4.1-4.4.

    Stiffness and bias pairs are ``(sensitive x, non-sensitive y)`` per test mass, in its
    own frame.  ``fb_bias`` / ``fb_sigma`` model the spacecraft acceleration f_B in frame s
    (not in Table 1, so 0 by default; ``tmopt.physics.scenario.Y_AXES`` names the round-one
    setting).
    ``rls_scales`` = (x scale [m], y scale [m], output scale [m s^-2]) normalise the
    regression internally; ``rls_p0`` is the initial covariance in those scaled units.
    ``rls_columns`` are the entries of ``theta = [k1xx, k2xx, k1yy, k2yy, R]`` the RLS
    identifies (the others get NaN estimates; their terms stay in the equation error);
    a name of :data:`RLS_COLUMN_SETS` is accepted too.  ``ramp_in`` [s] starts every
    reference smoothly: it is multiplied by a raised-cosine ramp from 0 to 1 over the
    first ``ramp_in`` seconds (0: the reference as given).
    """

    sample_rate: float = PAPER_RATE
    #: Run length of the paper's simulation (Sec. 4.1) [s]: the one home of the default
    #: duration (the scenario, the stiffness problem and the study helpers refer to it).
    duration: float = 1200.0
    controller: str = "frbf_pid"
    stiffness_1: tuple[float, float] = (1e-7, 1e-7)
    stiffness_2: tuple[float, float] = (1e-7, 1e-7)
    bias_1: tuple[float, float] = (1e-10, 1e-10)
    bias_2: tuple[float, float] = (1e-10, 1e-10)
    sigma_m1: float = 1e-11
    sigma_m2: float = 1e-8
    sigma_acc: float = 1e-12
    sigma_ele: float = 1e-12
    fb_bias: tuple[float, float] = (0.0, 0.0)
    fb_sigma: float = 0.0
    geometry: Geometry = field(default_factory=Geometry)
    control: ControllerSettings = field(default_factory=ControllerSettings)
    f_max: float = 1e-7
    gap: float = 4e-3
    alpha1: float = 0.5
    alpha2: float = 0.1
    rls_lambda: float = 1.0
    rls_p0: float = 1e6
    rls_scales: tuple[float, float, float] = (1e-5, 1e-8, 1e-12)
    rls_columns: tuple[str, ...] = ("k1xx", "k2xx", "R")
    ramp_in: float = 90.0
    divergence_bound: float = 4e-3
    steady_after: float = 300.0
    record: Literal["full", "estimates"] = "full"

    def __post_init__(self) -> None:
        _positive("sample_rate", self.sample_rate, "(0, inf) Hz")
        _positive("duration", self.duration, f"[{1 / self.sample_rate:g}, inf) s")
        if self.duration * self.sample_rate < 1 - 1e-9:
            raise ValueError(
                f"duration must be in [{1 / self.sample_rate:g}, inf) s (at least one sample "
                f"at {self.sample_rate} Hz); got {self.duration!r}"
            )
        if self.controller not in CONTROLLERS:
            raise ValueError(f"controller must be one of {CONTROLLERS}; got {self.controller!r}")
        for name in ("stiffness_1", "stiffness_2", "bias_1", "bias_2", "fb_bias"):
            _pair(name, getattr(self, name))
        for name in ("sigma_m1", "sigma_m2", "sigma_acc", "sigma_ele", "fb_sigma"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be finite and in [0, inf); got {v!r}")
        for name in ("f_max", "gap", "alpha1", "alpha2", "rls_p0", "divergence_bound"):
            _positive(name, getattr(self, name))
        if not (math.isfinite(self.rls_lambda) and 0 < self.rls_lambda <= 1):
            raise ValueError(f"rls_lambda must be in (0, 1]; got {self.rls_lambda!r}")
        if len(self.rls_scales) != 3:
            raise ValueError(f"rls_scales must be 3 numbers > 0; got {self.rls_scales!r}")
        for v in self.rls_scales:
            _positive("rls_scales", v)
        columns = RLS_COLUMN_SETS.get(self.rls_columns, self.rls_columns) \
            if isinstance(self.rls_columns, str) else self.rls_columns
        columns = tuple(columns)
        if not columns or any(c not in PARAMETERS for c in columns) \
                or len(set(columns)) != len(columns):
            raise ValueError(f"rls_columns must be distinct names from {PARAMETERS} or one of "
                             f"{sorted(RLS_COLUMN_SETS)}; got {self.rls_columns!r}")
        object.__setattr__(self, "rls_columns", tuple(c for c in PARAMETERS if c in columns))
        if not (isinstance(self.ramp_in, (int, float)) and math.isfinite(self.ramp_in)
                and 0 <= self.ramp_in):
            raise ValueError(f"ramp_in must be finite and in [0, inf) s; got {self.ramp_in!r}")
        if not (math.isfinite(self.steady_after) and 0 <= self.steady_after):
            raise ValueError(f"steady_after must be in [0, inf) s; got {self.steady_after!r}")
        if self.record not in ("full", "estimates"):
            raise ValueError(f"record must be 'full' or 'estimates'; got {self.record!r}")
        if not isinstance(self.geometry, Geometry):
            raise ValueError("geometry must be a tmopt.physics.geometry.Geometry")
        if not isinstance(self.control, ControllerSettings):
            raise ValueError("control must be a tmopt.physics.control.ControllerSettings")

    @property
    def dt(self) -> float:
        return 1.0 / self.sample_rate

    @property
    def n_steps(self) -> int:
        return int(round(self.duration * self.sample_rate))

    @property
    def nyquist(self) -> float:
        """Nyquist angular frequency ``pi * sample_rate`` [rad/s]."""
        return math.pi * self.sample_rate

    @property
    def coefficients(self) -> np.ndarray:
        """K of Eq. 11 for this geometry."""
        return self.geometry.coefficients()

    @property
    def theta_true(self) -> np.ndarray:
        """True ``theta = [k1xx, k2xx, k1yy, k2yy, R]`` with ``R = K . f_D`` (Eqs. 13-15)."""
        fd = np.array([self.bias_1[0], self.bias_2[0], self.bias_1[1], self.bias_2[1]])
        k = [self.stiffness_1[0], self.stiffness_2[0], self.stiffness_1[1], self.stiffness_2[1]]
        return np.array(k + [float(self.coefficients @ fd)])

    @property
    def identified(self) -> np.ndarray:
        """Boolean mask (5,) of the theta columns the RLS identifies."""
        return np.array([p in self.rls_columns for p in PARAMETERS])

    def sigmas(self) -> np.ndarray:
        return noise_sigmas(
            self.sigma_m1, self.sigma_m2, self.sigma_acc, self.sigma_ele, self.fb_sigma
        )


_AXES = "[x1, x2, y1, y2]"


@dataclass(frozen=True, eq=False)
class Perturbations:
    """Deviations of the true instrument from the nominal model (every field default off).

    Instrument properties, common to all designs of a batch.  Axis order ``[x1, x2, y1,
    y2]`` (TM1 in frame a, TM2 in frame b); series have one column per sample, value
    held over ``[t_n, t_{n+1})``.  With every field ``None`` the simulation is
    bit-identical to ``perturbations=None``; neutral values (zeros, identity readout)
    change no bit either.

    * ``actuation_gain`` (4, N): applied force ``(1 + g) * command`` [1].
    * ``actuation_delay`` (4,): the applied force is the command delayed by ``tau`` [s]
      (>= 0); fractional delays are exact (the step is split, see ``_delay_setup``), and
      the acceleration channel then reports the force's average over the step (for a
      force held over the step, as without delay, the average is that force).
    * ``actuation_step`` (4,): quantisation step ``q`` [m s^-2] of the applied command,
      ``q * floor(u / q + 1/2)``; 0 = none.  Order: delay, quantise, gain.
    * ``stiffness_change`` (4, N): extra diagonal stiffness ``dk_n`` [s^-2], force
      ``dk_n r(t_n)`` (drift of k).
    * ``stiffness_coupling`` (4, 4): extra stiffness matrix ``C`` [s^-2], force
      ``sum_b C[a, b] r_b(t_n)`` (the cross-coupling terms Sec. 2.2 neglects).
    * ``cubic_stiffness`` (4,): force ``k3 r(t_n)^3`` [m^-2 s^-2].
    * ``force`` (4, N): extra force per unit mass [m s^-2] (glitches, coloured noise, bias
      drift); pass interval averages to keep impulses exact.
    * ``omega``, ``omega_dot`` (3, N): spacecraft rate [rad s^-1] and angular acceleration
      [rad s^-2] in frame s at t_n; adds Eq. 1's ``rho x w' + 2 rho' x w + w x (rho x w)``
      per TM with ``rho`` = lever arm (``Geometry.r01_s`` / ``r02_s``) + displacement.
    * ``readout`` (4, 4): readout matrix ``M``, measured ``= M r + N_m`` (identity =
      nominal; ``1 + s`` on the diagonal is a scale error, off-diagonal terms cross-talk).

    State-dependent forces are evaluated at t_n and held over the step (ZOH of the
    perturbation force); the error is that of a half-step delay of the perturbation
    (relative ~ omega h / 2 ~ 1e-3 for the slow motions here), see
    docs/mismatch-generator.md.
    """

    actuation_gain: np.ndarray | None = None
    actuation_delay: tuple[float, float, float, float] | None = None
    actuation_step: tuple[float, float, float, float] | None = None
    stiffness_change: np.ndarray | None = None
    stiffness_coupling: np.ndarray | None = None
    cubic_stiffness: tuple[float, float, float, float] | None = None
    force: np.ndarray | None = None
    omega: np.ndarray | None = None
    omega_dot: np.ndarray | None = None
    readout: np.ndarray | None = None

    def __post_init__(self) -> None:
        shapes = {"actuation_delay": (4,), "actuation_step": (4,), "cubic_stiffness": (4,),
                  "stiffness_coupling": (4, 4), "readout": (4, 4)}  # fmt: skip
        for name, shape in shapes.items():
            _perturbation_array(name, getattr(self, name), shape)
        for name in ("actuation_delay", "actuation_step"):
            v = getattr(self, name)
            if v is not None and min(v) < 0:
                raise ValueError(f"{name} must be in [0, inf) per axis {_AXES}; got {v!r}")
        if (self.omega is None) != (self.omega_dot is None):
            raise ValueError("omega and omega_dot come together (both (3, N) or both None)")

    @property
    def active(self) -> bool:
        return any(getattr(self, f) is not None for f in self.__dataclass_fields__)


def _perturbation_array(name: str, value: object, shape: tuple[int, ...]) -> np.ndarray | None:
    if value is None:
        return None
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != shape:
        raise ValueError(f"Perturbations.{name} must have shape {shape}; got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"Perturbations.{name} must be finite (no NaN/inf)")
    return arr


def _pack_perturbations(
    pert: Perturbations | None, cfg: SimulationConfig, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """Kernel vectors ``pp`` (flags, constants) and ``ps`` (series), layout in _closed_loop."""
    pp = np.zeros(cl.N_PP)
    if pert is not None and not isinstance(pert, Perturbations):
        raise ValueError("perturbations must be a tmopt.physics.simulator.Perturbations")
    if pert is None or not pert.active:
        return pp, np.zeros((cl.N_S, 1))
    pp[cl.PP_ON] = 1.0
    pp[cl.PP_M : cl.PP_M + 16] = np.eye(4).ravel()
    pp[cl.PP_R01 : cl.PP_R01 + 3] = cfg.geometry.r01_s
    pp[cl.PP_R02 : cl.PP_R02 + 3] = cfg.geometry.r02_s
    consts = [("actuation_delay", cl.PP_DELAY, cl.PP_TAU, (4,)),
              ("actuation_step", cl.PP_QUANT, cl.PP_Q, (4,)),
              ("stiffness_coupling", cl.PP_COUPLE, cl.PP_C, (4, 4)),
              ("cubic_stiffness", cl.PP_CUBIC, cl.PP_K3, (4,)),
              ("readout", cl.PP_READ, cl.PP_M, (4, 4))]  # fmt: skip
    for name, flag, at, shape in consts:
        arr = _perturbation_array(name, getattr(pert, name), shape)
        if arr is not None:
            pp[flag] = 1.0
            pp[at : at + arr.size] = arr.ravel()
    if pert.actuation_delay is not None and max(pert.actuation_delay) >= cfg.duration:
        raise ValueError(f"Perturbations.actuation_delay must be in [0, {cfg.duration:g}) s "
                         f"(the run's duration); got {pert.actuation_delay!r}")  # fmt: skip
    ps = np.zeros((cl.N_S, n))
    series = [("actuation_gain", cl.PP_GAIN, cl.S_GAIN, 4), ("stiffness_change", cl.PP_DK,
              cl.S_DK, 4), ("force", cl.PP_FORCE, cl.S_FORCE, 4),
              ("omega", cl.PP_ROT, cl.S_OMEGA, 3), ("omega_dot", cl.PP_ROT, cl.S_OMEGA_DOT, 3)]
    for name, flag, row, rows in series:  # fmt: skip
        arr = _perturbation_array(name, getattr(pert, name), (rows, n))
        if arr is not None:
            pp[flag] = 1.0
            ps[row : row + rows] = arr
    return pp, ps


@dataclass
class SimulationResult:
    """Output of :func:`simulate` for B designs and N samples.

    ``channels`` (16, B, N) in :data:`CHANNEL_NAMES` order (``None`` when
    ``config.record == "estimates"``); each is also an attribute, e.g. ``result.x1``
    (measured) and ``result.x1_true``.  ``theta_hat`` (B, N, 5) is the RLS estimate after
    sample n.  ``diverged`` (B,) flags designs whose loop left the bound or went
    non-finite; ``reason[i]`` says why ('' when fine) and ``diverged_at`` (B,) gives the
    time [s] (NaN-free: -1 when fine).  After divergence every channel holds its last
    value.  ``max_tracking_error`` / ``steady_tracking_error`` (B, 2) are ``max|r - x|``
    (true x) of TM1/TM2 over the whole run and over ``t >= config.steady_after``.
    ``max_abs_position`` (B, 4) is the realised ``max|r|`` of x1, x2, y1, y2 (true motion)
    and ``max_abs_command`` (B, 4) the largest commanded force (after the output limit)
    per axis: the quantities of Eq. 20 on the simulated run.  ``gains`` (6, B, N) holds the
    sensitive-axis gains in :data:`GAIN_NAMES` order (``None`` when only estimates are
    recorded).  ``theta_hat`` is NaN in the columns the RLS does not identify.
    ``perturbations`` is what the run was given (None: the nominal model).  ``seeds``
    (B,) is the noise seed of every design; ``seed`` the common one (-1 when the designs
    had seeds of their own).
    """

    time: np.ndarray
    ref_x1: np.ndarray
    ref_x2: np.ndarray
    theta_hat: np.ndarray
    channels: np.ndarray | None
    diverged: np.ndarray
    reason: list[str]
    diverged_at: np.ndarray
    max_tracking_error: np.ndarray
    steady_tracking_error: np.ndarray
    max_abs_position: np.ndarray
    max_abs_command: np.ndarray
    gains: np.ndarray | None
    config: SimulationConfig
    seed: int
    seeds: np.ndarray | None = None
    perturbations: Perturbations | None = None
    ref_y: np.ndarray | None = None  # (B, 2, N) y1, y2 set points; None: held at zero

    def __getattr__(self, name: str) -> np.ndarray:
        if name in CHANNEL_NAMES:
            if self.channels is None:
                raise AttributeError(f"{name} not recorded (config.record='estimates')")
            return self.channels[CHANNEL_NAMES.index(name)]
        raise AttributeError(name)

    @property
    def batch_size(self) -> int:
        return self.theta_hat.shape[0]

    @property
    def feasible(self) -> np.ndarray:
        """Closed loop stayed bounded and finite (B,)."""
        return ~self.diverged

    def design(self, i: int) -> dict[str, np.ndarray]:
        """Design ``i`` as 1-D channels: time, x1..y2 (measured), *_true, acc_*, force_*,
        the gains (:data:`GAIN_NAMES`), ref_x1, ref_x2, and theta_hat (N, 5)."""
        out = {"time": self.time, "ref_x1": self.ref_x1[i], "ref_x2": self.ref_x2[i]}
        if self.channels is not None:
            for k, name in enumerate(CHANNEL_NAMES):
                out[name] = self.channels[k, i]
        if self.gains is not None:
            for k, name in enumerate(GAIN_NAMES):
                out[name] = self.gains[k, i]
        out["theta_hat"] = self.theta_hat[i]
        return out


def _reference(name: str, ref: MultiSine | np.ndarray, t: np.ndarray, cfg: SimulationConfig):
    """The reference the loop tracks, (B, N): as given, times the start ramp if any."""
    if isinstance(ref, MultiSine):
        ref.check_nyquist(cfg.sample_rate)
        arr = ref.evaluate(t)
    else:
        arr = np.asarray(ref, dtype=np.float64)
        if arr.ndim == 1:
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[1] != t.size:
            raise ValueError(f"{name} must be a MultiSine or an array (B, {t.size}); "
                             f"got {arr.shape}")  # fmt: skip
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} must be finite (no NaN/inf)")
    if cfg.ramp_in > 0:
        arr = arr * ramp_window(t, cfg.ramp_in)[None, :]
    return np.ascontiguousarray(arr)


def _pack_parameters(cfg: SimulationConfig) -> np.ndarray:
    """Flatten the configuration into the kernel's parameter vector (layout in _closed_loop)."""
    par = np.zeros(cl.N_PAR)
    ctl = cfg.control
    par[cl.P_DT] = cfg.dt
    par[cl.P_K : cl.P_K + 4] = cfg.theta_true[:4]
    par[cl.P_FD : cl.P_FD + 4] = [cfg.bias_1[0], cfg.bias_2[0], cfg.bias_1[1], cfg.bias_2[1]]
    par[cl.P_FB : cl.P_FB + 2] = cfg.fb_bias
    par[cl.P_WSA : cl.P_WSA + 4] = cfg.geometry.w_sa[:2, :2].ravel()
    par[cl.P_WSB : cl.P_WSB + 4] = cfg.geometry.w_sb[:2, :2].ravel()
    par[cl.P_KC : cl.P_KC + 4] = cfg.coefficients
    par[cl.P_FMAX] = cfg.f_max
    par[cl.P_XGAIN : cl.P_XGAIN + 3] = ctl.base_gains
    par[cl.P_YGAIN : cl.P_YGAIN + 3] = ctl.y_gains
    par[cl.P_ESCALE] = ctl.error_scale
    par[cl.P_ECSCALE] = ctl.error_rate_scale
    par[cl.P_ETA] = ctl.learning_rate
    par[cl.P_MOM] = ctl.momentum
    par[cl.P_GLO], par[cl.P_GHI] = ctl.gain_bounds
    par[cl.P_BMIN] = ctl.width_min
    par[cl.P_LAM] = cfg.rls_lambda
    par[cl.P_P0] = cfg.rls_p0
    par[cl.P_SX], par[cl.P_SY], par[cl.P_SOUT] = cfg.rls_scales
    par[cl.P_BOUND] = cfg.divergence_bound
    par[cl.P_FRBF] = 1.0 if cfg.controller == "frbf_pid" else 0.0
    par[cl.P_STEADY] = math.ceil(cfg.steady_after * cfg.sample_rate - 1e-9)
    par[cl.P_YFILT] = derivative_filter_pole(ctl.y_derivative_filter, cfg.dt)
    par[cl.P_JAC] = 1.0 if ctl.jacobian == "online" else 0.0
    par[cl.P_MASK : cl.P_MASK + cl.N_THETA] = cfg.identified
    return par


def _references_y(ref_y, t: np.ndarray, cfg: SimulationConfig, b: int) -> np.ndarray:
    """Non-sensitive-axis references (B, 2, N) of y1, y2, or (1, 2, 1) zeros (held at 0)."""
    if ref_y is None:
        return np.zeros((1, 2, 1))
    if len(ref_y) != 2:
        raise ValueError("ref_y must be a pair (ref_y1, ref_y2)")
    ry = [_reference(f"ref_y{k}", r, t, cfg) for k, r in enumerate(ref_y, start=1)]
    if any(r.shape[0] != b for r in ry):
        raise ValueError(f"ref_y must hold the {b} designs of ref1; got "
                         f"{[r.shape[0] for r in ry]}")  # fmt: skip
    return np.ascontiguousarray(np.stack(ry, axis=1))


def prepare(
    ref1: MultiSine | np.ndarray,
    ref2: MultiSine | np.ndarray,
    config: SimulationConfig,
    seed: int,
    perturbations: Perturbations | None = None,
    ref_y=None,
) -> dict:
    """Validated kernel inputs and zeroed outputs (shared by the batch and reference paths)."""
    if not isinstance(config, SimulationConfig):
        raise ValueError("config must be a SimulationConfig")
    t = sample_times(config.duration, config.sample_rate)
    r1, r2 = _reference("ref1", ref1, t, config), _reference("ref2", ref2, t, config)
    if r1.shape[0] != r2.shape[0]:
        raise ValueError(f"ref1 and ref2 must hold the same number of designs; "
                         f"got {r1.shape[0]} and {r2.shape[0]}")  # fmt: skip
    b, n = r1.shape
    ry = _references_y(ref_y, t, config, b)
    seeds = _seeds(seed, b)
    unique, noise_of = np.unique(seeds, return_inverse=True)
    record = config.record == "full"
    pp, ps = _pack_perturbations(perturbations, config, n)
    sigmas = config.sigmas()
    return {
        "time": t,
        "ref1": r1,
        "ref2": r2,
        "refy": ry,
        "seeds": seeds,
        "noise": np.stack([noise_realisation(int(s), n, sigmas) for s in unique]),
        "noise_of": np.ascontiguousarray(noise_of.reshape(-1), dtype=np.int64),
        "par": _pack_parameters(config),
        "c0": np.asarray(config.control.centres, dtype=np.float64),
        "b0": float(config.control.width),
        # every sample is written by the kernel (or held after divergence): no zero-fill
        "out_ch": np.empty((cl.N_CH, b, n) if record else (cl.N_CH, 1, 1)),
        "out_th": np.empty((b, n, cl.N_THETA)),
        "out_gain": np.empty((cl.N_GAIN, b, n) if record else (cl.N_GAIN, 1, 1)),
        "summary": np.zeros((b, cl.N_SUM)),
        "status": np.zeros((b, 2), dtype=np.int64),
        "record": record,
        "pp": pp,
        "ps": ps,
        # runs per lock-step group (the kernel's threads share the groups)
        "lanes": cl.group_lanes(b, numba.get_num_threads()),
        "perturbations": perturbations,
    }


def _seeds(seed, b: int) -> np.ndarray:
    """Noise seed of every design (B,) from one seed or one seed per design."""
    values = [seed] * b if np.ndim(seed) == 0 else list(np.asarray(seed).tolist())
    if np.ndim(seed) > 1 or len(values) != b or not all(
            isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))
            and 0 <= v < 2**63 for v in values):  # fmt: skip
        raise ValueError(f"seed must be an integer in [0, 2^63) or one such integer per "
                         f"design ({b}); got {seed!r}")
    return np.array(values, dtype=np.int64)


def _finish(io: dict, config: SimulationConfig, seed) -> SimulationResult:
    code, last = io["status"][:, 0], io["status"][:, 1]
    diverged = code != cl.OK
    bound = config.divergence_bound
    reasons = [
        f"{REASONS[int(c)]} (bound {bound:g} m) at t = {l / config.sample_rate:.1f} s"
        if c != cl.OK else ""
        for c, l in zip(code, last)
    ]  # fmt: skip
    return SimulationResult(
        time=io["time"],
        ref_x1=io["ref1"],
        ref_x2=io["ref2"],
        theta_hat=io["out_th"],
        channels=io["out_ch"] if io["record"] else None,
        diverged=diverged,
        reason=reasons,
        diverged_at=np.where(diverged, last / config.sample_rate, -1.0),
        max_tracking_error=io["summary"][:, :2].copy(),
        steady_tracking_error=io["summary"][:, 2:4].copy(),
        max_abs_position=io["summary"][:, cl.SUM_XMAX : cl.SUM_XMAX + 4].copy(),
        max_abs_command=io["summary"][:, cl.SUM_UMAX : cl.SUM_UMAX + 4].copy(),
        gains=io["out_gain"] if io["record"] else None,
        config=config,
        seed=int(seed) if np.ndim(seed) == 0 else -1,
        seeds=io["seeds"],
        perturbations=io["perturbations"],
        ref_y=io["refy"] if io["refy"].shape[2] == io["time"].size
        and io["refy"].shape[0] == io["ref1"].shape[0] else None,
    )


_KERNEL_ARGS = ("ref1", "ref2", "refy", "noise", "noise_of", "par", "c0", "b0", "out_ch",
                "out_th", "out_gain", "summary", "status", "record", "pp", "ps",
                "lanes")  # fmt: skip


def simulate(
    ref1: MultiSine | np.ndarray,
    ref2: MultiSine | np.ndarray,
    config: SimulationConfig | None = None,
    seed: int | np.ndarray = 0,
    perturbations: Perturbations | None = None,
    ref_y=None,
) -> SimulationResult:
    """Closed-loop simulation + online identification of B designs at once (compiled).

    ``ref1`` / ``ref2``: sensitive-axis references of TM1 / TM2, each a :class:`MultiSine`
    with B designs or an array (B, N) sampled at ``config``'s grid.  ``seed`` selects the
    noise realisation: one integer, common to all designs (so design i's result does not
    depend on the batch it is in), or one integer per design (B,) -- designs x seeds in one
    kernel launch, e.g. a design repeated under K seeds; every row is bit-identical to that
    design run alone with its seed.  ``perturbations`` (default None: the nominal model)
    injects instrument deviations, see :class:`Perturbations`.  ``ref_y`` (default None:
    the non-sensitive axes held at zero, as in the paper) = ``(ref_y1, ref_y2)``, each
    like ``ref1``: set points the y loops track (a non-sensitive-axis excitation).
    """
    config = SimulationConfig() if config is None else config
    io = prepare(ref1, ref2, config, seed, perturbations, ref_y)
    cl.batch_kernel(*(io[k] for k in _KERNEL_ARGS))
    return _finish(io, config, seed)


def simulate_reference(
    ref1: MultiSine | np.ndarray,
    ref2: MultiSine | np.ndarray,
    config: SimulationConfig | None = None,
    seed: int | np.ndarray = 0,
    perturbations: Perturbations | None = None,
    ref_y=None,
) -> SimulationResult:
    """The same model run design by design in the plain Python interpreter (slow).

    Calls the very same step functions as :func:`simulate`, uncompiled (only the ZOH
    coefficients, computed once per design, come from the jitted
    :func:`~tmopt.physics.dynamics.zoh_coefficients`): the benchmark's reference and an
    independent check that compilation does not change the model.
    """
    config = SimulationConfig() if config is None else config
    io = prepare(ref1, ref2, config, seed, perturbations, ref_y)
    args = [io[k] for k in _KERNEL_ARGS if k != "lanes"]  # run_design: one run, no groups
    noise, noise_of = args[3], args[4]
    for i in range(io["ref1"].shape[0]):
        cl.run_design(i, *args[:3], noise[noise_of[i]], *args[5:])
    return _finish(io, config, seed)
