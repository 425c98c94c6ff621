"""What the equation group's cross-spectrum estimate (docs/mismatch.md 9.21) does to a
recording's report.

    python experiments/mismatch_cross_spectrum_probe.py foreign:180077 [kernel:150079 ...] \\
        [clipped] [--cross coherence,regression] [--bands]

Each recording (``backend:seed`` of ``mismatch_benchmark.py --realistic``, or ``clipped``:
the test recording with the x2 accelerometer clipped at 80 % of its range,
``tests/mismatch/test_honest_attribution.py``) is diagnosed with each cross-spectrum
(``noise_model.CROSS_SPECTRUM``), and the selected keys and the CPU time are printed.
``--bands``: also the nominal equation residual's lowest bands -- the band-median
coherence |coh| and the regression's transfer |h| -- and the coherence with bands of
8 and 16 bins (what smaller bands would give).  Section 9.21 quotes this probe.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))


def recording(spec: str):
    if spec == "clipped":
        sys.path.insert(0, str(ROOT))
        from tests.mismatch.test_honest_attribution import _clipped_x2

        return _clipped_x2()
    from mismatch_realistic import case_recording

    from tmopt.mismatch.fit import data_from_recording

    backend, _, seed = spec.partition(":")
    return data_from_recording(case_recording(backend, int(seed))[0])


def bands(data) -> None:
    """Lowest bands of the nominal equation residual under each estimate."""
    import numpy as np

    import tmopt.mismatch.noise_model as nm
    from tmopt.mismatch.diagnose import Settings, fit_state, prepare

    data, basis = prepare(data)
    r = fit_state(data, basis, [], [], False, Settings()).eq_fit.residual
    for cross in nm.CROSS_KINDS:
        m = nm.NoiseModel.estimate(r, data.layout, data.fs, cross=cross)
        v = m.coh[:5, 0, 1] if m.coh is not None else m.transfer[:5, 1, 0]
        print(f"    {cross:10s} centres {np.round(m.coh_f[:5] * 1e3, 2)} mHz  "
              f"|{'coh' if m.coh is not None else 'h'}| {np.round(np.abs(v), 3)}")
    edges = nm.band_edges
    for few in (16, 8):
        nm.band_edges = lambda f, min_bins=8, per_decade=10, few=few: edges(
            f, few if min_bins == 32 else min_bins, per_decade)
        try:
            m = nm.NoiseModel.estimate(r, data.layout, data.fs, cross="coherence")
        finally:
            nm.band_edges = edges
        print(f"    coherence, {few:2d}-bin bands: centres {np.round(m.coh_f[:5] * 1e3, 2)} "
              f"mHz  |coh| {np.round(np.abs(m.coh[:5, 0, 1]), 3)}")


def main(argv=None) -> int:
    import copy

    import tmopt.mismatch.noise_model as nm
    from tmopt.mismatch.diagnose import diagnose

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recordings", nargs="+", help="backend:seed (e.g. foreign:180077) or clipped")
    ap.add_argument("--cross", default="coherence,regression")
    ap.add_argument("--bands", action="store_true")
    a = ap.parse_args(argv)
    kinds = a.cross.split(",")
    bad = [k for k in kinds if k not in nm.CROSS_KINDS]
    if bad:
        print(f"--cross: each must be one of {nm.CROSS_KINDS}; got {bad}", file=sys.stderr)
        return 2
    for spec in a.recordings:
        backend, _, seed = spec.partition(":")
        if spec != "clipped" and (backend not in ("kernel", "foreign") or not seed.isdigit()):
            print(f"a recording is backend:seed (kernel or foreign) or 'clipped'; got {spec!r}",
                  file=sys.stderr)  # fmt: skip
            return 2
    default = nm.CROSS_SPECTRUM
    for spec in a.recordings:
        data = recording(spec)
        print(spec, flush=True)
        if a.bands:
            bands(copy.deepcopy(data))
        for cross in kinds:
            nm.CROSS_SPECTRUM = cross
            t = time.process_time()
            try:
                dg = diagnose(copy.deepcopy(data))
            finally:
                nm.CROSS_SPECTRUM = default
            names = [ev.candidate.key for ev, _ in dg.selected]
            print(f"  [{cross}] {names}  (CPU {time.process_time() - t:.0f} s)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
