"""The readout timing feature's regressors on benchmark recordings (docs/mismatch.md 9.34).

    python experiments/mismatch_timing_regressors.py --records foreign:340007,kernel:340140 \
        [--bands 10]

For each recording (made as ``mismatch_benchmark.py --realistic`` makes it) and each
excited axis, the first step's statistics of three timing columns against the nominal
fit: the excitation-tone part (``tones``, shipped), the measured accelerometer term's
central difference (``measured``, withdrawn) and its band-limited form (``band``) -- each
as the GLR under the null's noise model and as the selection reads it (the profile
likelihood ratio, ``Settings.kin_profile``) -- and the fitted timing when the kinematic
noise model is estimated again with the column in.  Then, per frequency band, the
correlation of the whitened measured column with the whitened residual and the share of
the column's energy there: where the measured term is endogenous (the loop's reply to the
readout noise is in both).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _columns(data, basis, state):
    """``{axis: {regressor: column}}`` of the timing feature (excited axes)."""
    from tmopt.mismatch import generic
    from tmopt.mismatch.effects.base import Context
    from tmopt.mismatch.fit import AXES, Column

    ctx = Context(data, basis, state.eq_fit.residual, state.eq_noise)
    out: dict[int, dict] = {}
    for reg in generic.TIMING_REGRESSORS:
        for cand in generic._readout_timings(ctx, reg):
            out.setdefault(AXES.index(cand.channel.split()[0]), {})[reg] = cand.columns[0]
    rows = data.kin_index
    for a, cols in out.items():
        values = np.zeros((4, rows.size))
        values[a] = -generic.central_derivative(generic.kinematic_series(data, a), rows, data.dt)
        cols["measured"] = Column(f"measured[{AXES[a]}]", values, None, (), a)
    return out


def _band_correlations(data, state, col, axis: int, bands: int) -> list[str]:
    from tmopt.mismatch.diagnose import _orth

    whiten = state.kin_noise.whiten
    q = _orth(state.kin_cols, whiten)

    def perp(arr):
        v = whiten(arr).ravel()
        return (v - q @ (q.T @ v) if q.size else v).reshape(4, -1)[axis]

    c, r = np.fft.rfft(perp(col.values)), np.fft.rfft(perp(state.kin_fit.residual))
    f = np.fft.rfftfreq(data.kin_index.size, data.dt)
    edges = np.r_[0.0, np.geomspace(1e-3, f[-1], bands)]
    total = float(np.sum(np.abs(c) ** 2)) or 1.0
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        m = (f >= lo) & (f < hi)
        den = float(np.sqrt(np.sum(np.abs(c[m]) ** 2) * np.sum(np.abs(r[m]) ** 2))) or 1.0
        out.append(f"{lo:.3g}-{hi:.3g} Hz {np.sum(np.real(np.conj(c[m]) * r[m])) / den:+.2f} "
                   f"({np.sum(np.abs(c[m]) ** 2) / total:.2f})")  # fmt: skip
    return out


def main(argv: list[str] | None = None) -> None:
    from mismatch_realistic import case_recording, parse_records

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--records", required=True,
                    help="SEED (both simulators) or BACKEND:SEED, comma-separated")
    ap.add_argument("--bands", type=int, default=10, help="frequency bands (>= 2)")
    a = ap.parse_args(argv)
    records = parse_records(a.records)
    if a.bands < 2:
        raise SystemExit(f"--bands: must be >= 2 (got {a.bands})")

    from tmopt.mismatch.diagnose import (
        Settings,
        _fit_kin,
        _profile_ratio,
        fit_state,
        prepare,
        residual_groups,
    )
    from tmopt.mismatch.fit import AXES, data_from_recording

    for backend, seed in records:
        rec, _ = case_recording(backend, seed)
        data, basis = prepare(data_from_recording(rec))
        state = fit_state(data, basis, [], [], False, Settings())
        group = residual_groups(data, state)["kinematic"]
        target = state.kinematic_target(data)

        def refit(cols, target=target, state=state, data=data):
            return _fit_kin(target, state.kin_cols + cols, data.kin_layout, data.fs)

        ratio = _profile_ratio(state.kin_noise, state.kin_fit.residual, refit)
        print(f"{backend}:{seed} (fs {data.fs} Hz, convention {data.acc_convention})",
              flush=True)  # fmt: skip
        for axis, cols in sorted(_columns(data, basis, state).items()):
            for reg in ("tones", "measured", "band"):
                col = cols[reg]
                fit, _ = refit([col])
                print(f"    {AXES[axis]} readout {reg:8s} GLR {group.glr([col]):8.1f} "
                      f"profile {ratio([col]):8.1f} refitted tau {fit.coef[-1]:+.3g} s")
            print("    measured column vs residual, per band (correlation, column's "
                  "energy share): " + "; ".join(
                      _band_correlations(data, state, cols["measured"], axis, a.bands)))


if __name__ == "__main__":
    main()
