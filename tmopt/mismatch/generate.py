"""Recordings with concealed effects, from the closed-loop simulator, plus a separate truth.

``python -m tmopt.mismatch.generate --effect NAME --magnitude M --channel x1 --seed S
--out DIR`` writes ``DIR/<name>.h5`` (a recording in the format of
``docs/recording-format.md``) and ``DIR/<name>.truth.json`` (what was concealed; format in
``docs/mismatch-generator.md``).  The recording carries nothing about its making: its
name is a hash, its description is the user's, and it has the same channels whether an
effect is present or not.  Python: :func:`generate_recording`.

Settings the diagnosis tool may not have seen (:class:`tmopt.physics.scenario.Settings`):
excitation (the paper's Fig. 6 motion, multi-sines, chirps, smoothed steps, none), noise
scale, duration, sample rate, controller, stiffness and bias values, and the simulator's
physics options; every recording carries spacecraft jitter (:data:`SPACECRAFT_ACCELERATION`).
Effect physics: one module per effect in :mod:`tmopt.mismatch.effects`.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import sys
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from tmopt.mismatch.effects import CATALOGUE, EFFECT_NAMES, Builder, Injection, effect
from tmopt.physics.geometry import Geometry
from tmopt.physics.recording import (
    AXES,
    ROTATION_CHANNELS,
    Recording,
    atomic_write,
    recording_from_simulation,
    validate,
    write_recording,
)
from tmopt.physics.scenario import Y_AXES, Settings, excitation_axes, simulation_config
from tmopt.physics.simulator import SimulationConfig, simulate

__all__ = ["GenerationError", "generate_recording", "write_generated", "MAGNITUDES",
           "SPACECRAFT_ACCELERATION",
           "calibrated_injection",
           "detectability", "calibration_table", "residual_families", "TRUTH_FORMAT",
           "main"]  # fmt: skip

TRUTH_FORMAT = "tmopt-truth"
TRUTH_VERSION = 1


#: Spacecraft acceleration f_B of every recording (``SimulationConfig`` fields at their
#: 10 Hz values; the scenario's rate rule scales ``fb_sigma`` with the rate and the noise
#: scale): the round-one level of ``Y_AXES["round1"]``, not in Table 1 and off in the
#: simulator's default, kept so recordings carry flight-like spacecraft jitter (and the
#: geometry-error effect, which acts through f_B, stays visible).
SPACECRAFT_ACCELERATION: dict[str, Any] = {k: Y_AXES["round1"][k] for k in ("fb_bias", "fb_sigma")}


class GenerationError(ValueError):
    """A recording could not be generated (e.g. the effect made the loop diverge)."""


def _injections(effects: Iterable[Any]) -> list[Injection]:
    out = []
    for e in effects:
        if isinstance(e, Injection):
            inj = e
        elif isinstance(e, dict):
            inj = Injection(**e)
        elif isinstance(e, (tuple, list)):
            inj = Injection(*e)
        else:
            raise ValueError(f"effects must be Injection, dict or (name, magnitude[, channel]); "
                             f"got {e!r}")  # fmt: skip
        effect(inj.name)  # a known effect, or ValueError naming the choices
        out.append(inj)
    keys = [(i.name, i.channel or effect(i.name).default_channel) for i in out]
    dup = sorted({k for k in keys if keys.count(k) > 1})
    if dup:
        raise ValueError(f"the same effect twice on one channel: {dup}")
    return out


def generate_recording(
    effects: Sequence[Any] = (), seed: int = 0, **settings: Any
) -> tuple[Recording, dict[str, Any]]:
    """Simulate one recording with the given concealed effects -> (recording, truth).

    ``effects``: :class:`Injection` objects, dicts of its fields, or (name, magnitude[,
    channel]) tuples; empty = a clean control.  ``settings``: fields of :class:`Settings`.
    The truth dict is the truth file's content (docs/mismatch-generator.md) without the
    file names.  Raises :class:`GenerationError` when the loop diverges.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an integer in [0, inf); got {seed!r}")
    st = Settings(**settings)
    injections = _injections(effects)
    nominal = Geometry()
    n = int(round(st.duration * st.sample_rate))
    builder = Builder(n, st.sample_rate, nominal, int(seed))
    truths = [_effect_truth(inj, effect(inj.name).inject(inj, builder)) for inj in injections]
    refs, exc = excitation_axes(st.excitation, st.duration, st.sample_rate)
    ref_y = (refs[2][None], refs[3][None]) if np.any(refs[2:]) else None
    cfg = simulation_config(st, builder.geometry, **SPACECRAFT_ACCELERATION)
    res = simulate(refs[0][None], refs[1][None], cfg, int(seed), builder.perturbations(),
                   ref_y=ref_y)
    if res.diverged[0]:
        raise GenerationError(f"the closed loop diverged ({res.reason[0]}) with effects "
                              f"{[(i.name, i.magnitude) for i in injections]}: reduce the "
                              "magnitude")  # fmt: skip
    rec = recording_from_simulation(res, 0, description=st.description, geometry=nominal)
    rec = _finish_channels(rec, builder, st)
    truth = _truth(st, int(seed), truths, exc, cfg, nominal, builder.geometry)
    truth["saturation"] = {a: float(np.mean(np.abs(rec[f"force_{a}"]) >= cfg.f_max))
                           for a in AXES}  # fmt: skip
    return rec, truth


def _finish_channels(rec: Recording, builder: Builder, st: Settings) -> Recording:
    """Sensor-side effects on recorded channels, then the always-present witnesses."""
    chans = dict(rec.channels)
    for step in builder.post:
        step(chans)
    if st.witnesses and ROTATION_CHANNELS[0] not in chans:
        chans.update({c: np.zeros(rec.n_samples) for c in ROTATION_CHANNELS})
    return validate(Recording(chans, dict(rec.attrs)))


def _effect_truth(inj: Injection, params: dict[str, Any]) -> dict[str, Any]:
    model = effect(inj.name)
    channel = inj.channel or model.default_channel
    return {
        "name": inj.name, "channel": channel,
        "tool_channel": params.pop("tool_channel", channel),
        "parameter": model.parameter, "magnitude": inj.magnitude, "unit": model.unit,
        "level": _level(inj.name, inj.magnitude), "parameters": params,
        "options": dict(inj.options),
    }  # fmt: skip


def _level(name: str, magnitude: float) -> str | None:
    """'near' / 'large' when the magnitude is the calibrated one (MAGNITUDES), else None."""
    cal = MAGNITUDES.get(name, {})
    for level in ("near", "large"):
        if cal.get(level) is not None and math.isclose(abs(magnitude), cal[level], rel_tol=1e-9):
            return level
    return None


def _truth(st: Settings, seed: int, effects: list[dict], exc: dict, cfg: SimulationConfig,
           nominal: Geometry, true_geo: Geometry) -> dict[str, Any]:  # fmt: skip
    k, fd = st.stiffness, st.bias
    coeff = nominal.coefficients()
    return {
        "format": TRUTH_FORMAT, "format_version": TRUTH_VERSION, "seed": seed,
        "clean": not effects, "effects": effects,
        "settings": {**asdict(st), "excitation": exc},
        "nominal": {
            "k1xx": k[0], "k2xx": k[1], "k1yy": k[2], "k2yy": k[3],
            "fD1x": fd[0], "fD2x": fd[1], "fD1y": fd[2], "fD2y": fd[3],
            "R": float(coeff @ np.asarray(fd)),
            "fb_bias_s": list(cfg.fb_bias), "fb_sigma": cfg.fb_sigma,
            "sigma_m1": cfg.sigma_m1, "sigma_m2": cfg.sigma_m2, "sigma_acc": cfg.sigma_acc,
            "sigma_ele": cfg.sigma_ele, "phi1": nominal.phi1, "phi2": nominal.phi2,
            "alpha": nominal.alpha, "separation": nominal.separation,
            "r12_s": nominal.r12_s.tolist(), "K": coeff.tolist(),
            "controller": cfg.controller, "base_gains": list(cfg.control.base_gains),
            "y_gains": list(cfg.control.y_gains), "f_max": cfg.f_max,
        },
        "true_geometry": {"phi1": true_geo.phi1, "phi2": true_geo.phi2,
                          "alpha": true_geo.alpha},
    }  # fmt: skip


def recording_name(truth: dict[str, Any]) -> str:
    """Opaque, deterministic name: a hash of seed, settings and effects (reveals nothing)."""
    key = json.dumps([truth["seed"], truth["settings"], truth["effects"]], sort_keys=True,
                     default=str)  # fmt: skip
    return "rec-" + hashlib.sha256(key.encode()).hexdigest()[:12]


def write_generated(rec: Recording, truth: dict[str, Any], out: str | Path,
                    name: str | None = None, fmt: str = "h5",
                    truth_dir: str | Path | None = None) -> tuple[Path, Path]:  # fmt: skip
    """Write ``<out>/<name>.<fmt>`` and ``<truth_dir or out>/<name>.truth.json``.

    The truth file names the recording and its SHA-256, so a benchmark can check that a
    truth belongs to the file it scores.
    """
    name = recording_name(truth) if name is None else name
    if not name or "/" in name or name.startswith("."):
        raise ValueError(f"name must be a plain file stem; got {name!r}")
    path = write_recording(rec, Path(out) / f"{name}.{fmt}", fmt=fmt)  # type: ignore[arg-type]
    full = {**truth, "recording": path.name,
            "recording_sha256": hashlib.sha256(path.read_bytes()).hexdigest()}  # fmt: skip
    tpath = Path(truth_dir if truth_dir is not None else out) / f"{name}.truth.json"
    tpath.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(full, indent=2, sort_keys=True, default=_json) + "\n"
    atomic_write(tpath, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
    return path, tpath


def _json(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON-serialisable: {value!r}")


# --------------------------------------------------------------------------- magnitudes

#: Calibrated magnitudes per effect (each effect's ``calibration``, see
#: :class:`tmopt.mismatch.effects.Calibration`): {name: {channel, options, near,
#: snr_near, large, snr_large, family}}.
MAGNITUDES: dict[str, dict[str, Any]] = {
    e.name: asdict(e.calibration) for e in CATALOGUE if e.calibration is not None}


def calibrated_injection(name: str, level: str, sign: float = 1.0) -> Injection:
    """The calibrated ``near``/``large`` injection of an effect (its channel and options)."""
    model = effect(name)
    if name not in MAGNITUDES:
        raise ValueError(f"{name}: no calibrated magnitudes")
    if level not in ("near", "large"):
        raise ValueError(f"level must be 'near' or 'large'; got {level!r}")
    cal = MAGNITUDES[name]
    signed = cal[level] * (1.0 if sign >= 0 or not model.signed else -1.0)
    return Injection(name, signed, cal["channel"], options=dict(cal["options"]))


# --------------------------------------------------------------------------- detectability
#
# How visible is an effect?  Three families of residuals a diagnosis can form from a
# recording alone (nominal model, no truth): the two f_B-free combinations of the four
# axes (Eq. 10 with K, and the orthogonal one that keeps the Euler term), each after a
# least-squares fit of the nominal stiffnesses and bias; and the per-axis kinematic
# residual  x_{n+1} - 2 x_n + x_{n-1} - h^2 (acc_n + acc_{n-1}) / 2  (exact for a ZOH
# force, no free parameter).  The effect's signature in a family is the residual of the
# effect recording minus that of the clean one with the same seed (same noise draws);
# the noise PSD comes from two clean recordings of different seeds.  SNR: the matched
# filter  rho^2 = 4 sum_k |X_k|^2 / (N fs S_k)  for deterministic signatures (Wainstein
# & Zubakov's optimal-filter SNR, discrete form), the expected excess power  max over
# octave bands of  sum_k E[w_k] / sqrt(n_k),  w_k = 2 |X_k|^2 / (N fs S_k)  (averaged over
# REALISATIONS seeds), for noise-like effects (radiometer equation).  Detectability = the
# largest over families.  Which statistic: each effect's ``noise_like``.


def residual_families(rec: Recording, force_lag: int = 0) -> dict[str, np.ndarray]:
    """The residual families above: ``eq`` (2, N - |force_lag|) and ``kin_<axis>``
    (1, N - 2).

    ``eq``: the two orthonormal f_B-free combinations (K of Eq. 11 and the one orthogonal
    to it), fitted *jointly* with the nominal model of Eqs. 10-15 -- one stiffness per
    axis shared by both, one intercept (f_D combination) each.  Their noises (N_acc +
    N_ele, iid over axes) are then independent with equal variance.  ``force_lag``: the
    force sample ``n + force_lag`` is paired with sample n (a recorder's timestamp
    convention, :func:`tmopt.mismatch.fit.force_lag`), ends cut.
    """
    geo = rec.geometry()
    x = np.array([rec[a] for a in AXES])
    acc = np.array([rec[f"acc_{a}"] for a in AXES])
    force = np.array([rec[f"force_{a}"] for a in AXES])
    xe, acce = x, acc  # Eq. 10's samples (force paired); the kinematic check: all of x, acc
    if force_lag:
        keep = np.arange(max(0, -force_lag), x.shape[1] - max(0, force_lag))
        xe, acce, force = x[:, keep], acc[:, keep], force[:, keep + force_lag]
    d = acce - force
    wa, wb = geo.w_sa[:2, :2], geo.w_sb[:2, :2]
    proj = np.array([wa[0], wb[0], wa[1], wb[1]])  # f_B^s seen by each axis (Eqs. 6-7)
    k = geo.coefficients() / np.linalg.norm(geo.coefficients())
    null = np.linalg.svd(proj.T)[2][2:]  # (2, 4): orthonormal combinations blind to f_B
    ell = null[np.argmax(np.linalg.norm(null - np.outer(null @ k, k), axis=1))]
    ell = ell - (ell @ k) * k
    basis = np.array([k, ell / np.linalg.norm(ell)])  # (2, 4)
    n = xe.shape[1]
    cols = np.zeros((2 * n, 6))
    for a in range(4):  # stiffness of axis a, seen through both combinations
        cols[:n, a], cols[n:, a] = basis[0, a] * xe[a], basis[1, a] * xe[a]
    cols[:n, 4], cols[n:, 5] = 1.0, 1.0
    y = (basis @ d).ravel()
    fam = {"eq": (y - cols @ np.linalg.lstsq(cols, y, rcond=None)[0]).reshape(2, n)}
    h2 = rec.dt**2
    for a, name in enumerate(AXES):
        fam[f"kin_{name}"] = (x[a, 2:] - 2 * x[a, 1:-1] + x[a, :-2]
                              - 0.5 * h2 * (acc[a, 1:-1] + acc[a, :-2]))[None]  # fmt: skip
    return fam


def _psd_on_grid(noise: np.ndarray, fs: float) -> np.ndarray:
    """Welch PSD of each row (8 Hann segments, 50 % overlap) on the rfft grid of its length."""
    from scipy.signal import welch

    n = noise.shape[-1]
    f_w, s_w = welch(noise, fs, nperseg=max(16, n // 8), axis=-1)
    f = np.fft.rfftfreq(n, 1 / fs)
    return np.array([np.interp(f, f_w[1:], row[1:]) for row in np.atleast_2d(s_w)])


def whitened_power(signature: np.ndarray, noise_psd: np.ndarray, fs: float) -> np.ndarray:
    """``w_k = 2 |X_k|^2 / (N fs S_k)`` per row (rows: independent noises), DC bin zeroed
    (absorbed by the fitted intercept); pure noise of PSD S gives E[w_k] = 1."""
    n = signature.shape[-1]
    spec = np.abs(np.fft.rfft(signature, axis=-1)) ** 2
    w = 2 * spec / (n * fs * np.maximum(noise_psd, 1e-300))
    w[:, 0] = 0.0
    return w


def matched_snr(w: np.ndarray) -> float:
    """Matched-filter SNR ``sqrt(4 sum_k |X_k|^2 / (N fs S_k)) = sqrt(2 sum w)``."""
    return float(math.sqrt(2 * w.sum()))


def excess_snr(w: np.ndarray) -> float:
    """Excess power in the best octave band (lowest band: bins 1-3), ``sum w / sqrt(n)``."""
    m = w.shape[1]
    edges = np.unique(np.r_[1, 2 ** np.arange(2, int(math.log2(m)) + 1), m])
    return float(max(w[:, a:b].sum() / math.sqrt(w[:, a:b].size)
                     for a, b in zip(edges[:-1], edges[1:]) if b > a))  # fmt: skip


#: Realisations averaged for noise-like effects: their excess power in a few low bins is
#: itself random (exponential per bin), so one draw would calibrate on luck.
REALISATIONS = 8


@dataclass
class _Clean:
    """Clean residual families per seed (cached) and the noise PSD of each family."""

    settings: dict[str, Any]
    psd: dict[str, np.ndarray]
    families: dict[int, dict[str, np.ndarray]]

    def at(self, seed: int) -> dict[str, np.ndarray]:
        if seed not in self.families:
            rec = generate_recording((), seed, **self.settings)[0]
            self.families[seed] = residual_families(rec)
        return self.families[seed]


def _clean_reference(seed: int, settings: dict[str, Any]) -> _Clean:
    clean = _Clean(dict(settings), {}, {})
    fam_a, fam_b = clean.at(seed), clean.at(seed + 1)
    fs = float(settings.get("sample_rate", Settings.sample_rate))
    clean.psd = {k: _psd_on_grid((fam_a[k] - fam_b[k]) / math.sqrt(2), fs) for k in fam_a}
    return clean


def detectability(inj: Injection, seed: int = 101, settings: dict[str, Any] | None = None,
                  clean: _Clean | None = None) -> dict[str, Any]:  # fmt: skip
    """SNR of one injected effect in each residual family -> {'snr', 'family', 'per_family'}.

    Deterministic effects: matched filter on the run with ``seed``.  Noise-like effects:
    expected excess power, ``w`` averaged over :data:`REALISATIONS` seeds (``seed + 7919
    j``).  ``snr`` is ``inf`` when the effect makes the loop diverge.
    """
    settings = {} if settings is None else settings
    clean = _clean_reference(seed, settings) if clean is None else clean
    noise_like = effect(inj.name).noise_like
    powers: dict[str, list[np.ndarray]] = {}
    for s in [seed + 7919 * j for j in range(REALISATIONS if noise_like else 1)]:
        try:
            rec, _ = generate_recording([inj], s, **settings)
        except GenerationError:
            return {"snr": math.inf, "family": "diverged", "per_family": {}}
        fam, base = residual_families(rec), clean.at(s)
        for k in fam:
            powers.setdefault(k, []).append(
                whitened_power(fam[k] - base[k], clean.psd[k], rec.sample_rate))
    stat = excess_snr if noise_like else matched_snr
    per = {k: stat(np.mean(v, axis=0)) for k, v in powers.items()}
    best = max(per, key=per.get)
    return {"snr": per[best], "family": best, "per_family": per}


def calibrate(name: str, channel: str | None = None, options: dict | None = None,
              targets: tuple[float, ...] = (5.0, 50.0), seed: int = 101,
              settings: dict[str, Any] | None = None) -> dict[str, Any]:  # fmt: skip
    """Magnitudes giving each target SNR (log bisection to 10 %, then 2 significant digits).

    Returns {'near': m5, 'large': m50, 'snr_near', 'snr_large', 'family'}; a target not
    reached within the effect's range gives None.
    """
    model = effect(name)
    clean = _clean_reference(seed, settings or {})

    def rho(m: float) -> dict[str, Any]:
        inj = Injection(name, m, channel, options=options or {})
        return detectability(inj, seed, settings, clean)

    out: dict[str, Any] = {"channel": channel or model.default_channel,
                           "options": dict(options or {})}  # fmt: skip
    for label, target in zip(("near", "large"), targets):
        m = _bisect(rho, target, model.limit)
        if m is None:
            out.update({label: None, f"snr_{label}": None})
            continue
        m = float(f"{m:.2g}")
        got = rho(m)
        out.update({label: m, f"snr_{label}": round(got["snr"], 1), "family": got["family"]})
    return out


def _bisect(rho: Any, target: float, limit: float) -> float | None:
    lo, hi = limit * 1e-9, limit
    if rho(hi)["snr"] < target:
        return None
    for _ in range(40):
        if hi / lo < 1.1:
            break
        mid = math.sqrt(lo * hi)
        if rho(mid)["snr"] < target:
            lo = mid
        else:
            hi = mid
    return math.sqrt(lo * hi)


#: Channel and options used for the calibrated magnitudes of each effect: chosen so the
#: effect is excited by the paper's motion (see docs/mismatch-generator.md); each
#: effect's ``calibration``, or its default channel.
CALIBRATION_CASES: dict[str, tuple[str | None, dict[str, Any]]] = {
    e.name: ((e.calibration.channel, dict(e.calibration.options)) if e.calibration
             else (e.default_channel, {})) for e in CATALOGUE}  # fmt: skip


def calibration_table(seed: int = 101) -> list[dict[str, Any]]:
    """Calibrate every effect on its :data:`CALIBRATION_CASES` channel (default settings)."""
    rows = []
    for name, (channel, options) in CALIBRATION_CASES.items():
        rows.append({"effect": name, **calibrate(name, channel, options, seed=seed)})
    return rows


# --------------------------------------------------------------------------- CLI


def _parse_magnitude(text: str, name: str) -> float:
    if text in ("near", "large"):
        value = MAGNITUDES.get(name, {}).get(text)
        if value is None:
            raise SystemExit(f"no calibrated {text!r} magnitude for {name!r}")
        return float(value)
    try:
        return float(text)
    except ValueError:
        raise SystemExit(f"--magnitude must be a number, 'near' or 'large'; got {text!r}") from None


def _parse_options(items: list[str]) -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {}
    for item in items:
        key, sep, value = item.partition("=")
        effect, dot, opt = key.partition(".")
        if not sep or not dot:
            raise SystemExit(f"--option must look like EFFECT.KEY=VALUE; got {item!r}")
        try:
            parsed: Any = float(value)
        except ValueError:
            parsed = value
        out.setdefault(effect, {})[opt] = parsed
    return out


def _cli_injections(args: argparse.Namespace) -> list[Injection]:
    names = [e for e in args.effect if e != "none"]
    if len(names) != len(args.effect) and names:
        raise SystemExit("--effect none cannot be combined with other effects")
    for flag in ("magnitude", "channel", "onset", "effect_duration"):
        given = getattr(args, flag) or []
        if given and len(given) != len(names):
            raise SystemExit(f"give one --{flag.replace('_', '-')} per --effect "
                             f"({len(names)} effects, {len(given)} values)")  # fmt: skip
    if names and not args.magnitude:
        raise SystemExit("--magnitude is required for each effect")
    opts = _parse_options(args.option or [])
    out = []
    for i, name in enumerate(names):
        ch = args.channel[i] if args.channel else None
        ch = None if ch in (None, "default") else ch
        options = opts.get(name, {})
        if args.magnitude[i] in ("near", "large") and ch is None and name in MAGNITUDES:
            # a calibrated level means the calibrated case unless the user says otherwise
            ch, options = MAGNITUDES[name]["channel"], {**MAGNITUDES[name]["options"], **options}
        out.append(Injection(
            name, _parse_magnitude(args.magnitude[i], name), ch,
            args.onset[i] if args.onset else None,
            args.effect_duration[i] if args.effect_duration else None, options,
        ))  # fmt: skip
    return out


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m tmopt.mismatch.generate",
                                description=__doc__.split("\n\n")[0])  # fmt: skip
    p.add_argument("--effect", action="append", default=[],
                   help=f"effect to conceal (repeat for combinations) or 'none'; one of "
                        f"{', '.join(EFFECT_NAMES)}")  # fmt: skip
    p.add_argument("--magnitude", action="append", help="number (physical units) or near|large")
    p.add_argument("--channel", action="append", help="channel per effect, or 'default'")
    p.add_argument("--onset", action="append", type=float, help="effect onset [s]")
    p.add_argument("--effect-duration", action="append", type=float,
                   help="effect duration [s]")  # fmt: skip
    p.add_argument("--option", action="append", help="EFFECT.KEY=VALUE, e.g. glitch.beta=20")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, help="output folder")
    p.add_argument("--truth-dir", type=Path, help="folder for the truth file (default --out)")
    p.add_argument("--name", help="file stem (default: an opaque hash)")
    p.add_argument("--format", choices=("h5", "csv"), default="h5")
    p.add_argument("--duration", type=float, default=Settings.duration)
    p.add_argument("--sample-rate", type=float, default=Settings.sample_rate)
    p.add_argument("--excitation", default=Settings.excitation,
                   help="paper | multisine:A@P,..;A@P | chirp:A,f0,f1;A,f0,f1 | "
                        "steps:A,P[,ramp];A,P[,ramp] | none")  # fmt: skip
    p.add_argument("--noise-scale", type=float, default=Settings.noise_scale)
    p.add_argument("--controller", choices=("frbf_pid", "pid"), default=Settings.controller)
    p.add_argument("--no-witnesses", action="store_true",
                   help="omit sc_omega* channels when the spacecraft does not rotate")
    p.add_argument("--description", default="")
    p.add_argument("--list", action="store_true", help="list the effects and exit")
    p.add_argument("--calibrate", action="store_true",
                   help="recompute the near/large magnitude table (about a minute) and exit")
    return p


def _list_effects() -> str:
    lines = []
    for model in CATALOGUE:
        name = model.name
        cal = MAGNITUDES.get(name, {})
        lines.append(f"{name:26s} {model.parameter} [{model.unit}], |m| <= {model.limit:g}, "
                     f"channels {'|'.join(model.channels)} (default {model.default_channel}), "
                     f"options {model.options or '-'}, near {cal.get('near')}, "
                     f"large {cal.get('large')}")  # fmt: skip
    return "\n".join(lines)


def _markdown(rows: list[dict[str, Any]]) -> str:
    head = "| effect | channel | options | near | SNR | large | SNR | family |"
    out = [head, "|" + "---|" * 8]
    for r in rows:
        out.append(f"| {r['effect']} | {r['channel']} | {r['options'] or ''} | {r['near']} | "
                   f"{r['snr_near']} | {r['large']} | {r['snr_large']} | {r.get('family')} |")
    return "\n".join(out)


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.list:
        print(_list_effects())
        return 0
    if args.calibrate:
        print(_markdown(calibration_table()))
        return 0
    if not args.effect or args.out is None:
        raise SystemExit("--effect (or 'none') and --out are required")
    settings = dict(duration=args.duration, sample_rate=args.sample_rate,
                    excitation=args.excitation, noise_scale=args.noise_scale,
                    controller=args.controller, witnesses=not args.no_witnesses,
                    description=args.description)  # fmt: skip
    try:
        rec, truth = generate_recording(_cli_injections(args), args.seed, **settings)
        path, tpath = write_generated(rec, truth, args.out, args.name, args.format,
                                      args.truth_dir)  # fmt: skip
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"{path}\n{tpath}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

