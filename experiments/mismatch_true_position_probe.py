"""What the true position (docs/mismatch.md 9.19) does to one benchmark recording's report.

    python experiments/mismatch_true_position_probe.py kernel:190011 [foreign:190011 ...] \\
        [--variants main,readout,products_on_readout,gate0.9]

Each recording (``backend:seed`` of ``mismatch_benchmark.py --realistic``) is diagnosed
under each variant, and its conclusion is printed:

* ``main`` -- the tool's defaults (the stiffness on the true position);
* ``readout`` -- ``Settings(true_position=False)``: every regressor on the readout as
  recorded;
* ``products_on_readout`` -- the true position, but the unnamed ``x*y`` products built on
  the readout;
* ``gateT`` (e.g. ``gate0.9``) -- the readout-noise estimate taken only where its Wiener
  gain is >= T (elsewhere nothing is taken out).

The variants other than ``main`` and ``readout`` are monkeypatches for diagnosis: none is
an option of the tool.  Section 10 of docs/mismatch.md quotes this probe on the two false
alarms of the twentieth run (seed 190011) and on 9.19's design cases (kernel 170028,
foreign 170020).
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


@contextlib.contextmanager
def _patched(module, name: str, value):
    old = getattr(module, name)
    setattr(module, name, value)
    try:
        yield
    finally:
        setattr(module, name, old)


def _products_on_readout(ctx):
    import tmopt.mismatch.generic as g

    d, out = ctx.data, []
    for a, b in ((0, 2), (1, 3)):
        for on in (a, b):
            out.append(g._series_candidate(ctx, on, g.XY_PRODUCT, d.x[a] * d.x[b], "m^-1 s^-2",
                                           f"a bilinear coupling {g.AXES[a]}*{g.AXES[b]} "
                                           "(lines at f_x +- f_y)"))  # fmt: skip
    return out


def _gated(threshold: float):
    """``true_position._segment_noise`` with its Wiener gain set to 0 below ``threshold``."""
    import tmopt.mismatch.true_position as tp

    return functools.partial(tp._segment_noise, min_gain=threshold)


def conclusion(backend: str, seed: int, variant: str) -> str:
    from mismatch_realistic import case_recording

    import tmopt.mismatch.generic as generic
    import tmopt.mismatch.true_position as tp
    from tmopt.mismatch.diagnose import Settings, diagnose
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.report import build_report

    rec = case_recording(backend, seed)[0]
    settings = Settings(true_position=variant != "readout")
    with contextlib.ExitStack() as stack:
        if variant == "products_on_readout":
            stack.enter_context(_patched(generic, "_products", _products_on_readout))
        elif variant.startswith("gate"):
            stack.enter_context(_patched(tp, "_segment_noise", _gated(float(variant[4:]))))
        elif variant not in ("main", "readout"):
            raise ValueError(f"variant must be main, readout, products_on_readout or gateT "
                             f"(0 < T <= 1); got {variant!r}")  # fmt: skip
        return build_report(diagnose(data_from_recording(rec), settings))["conclusion"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recordings", nargs="+", help="backend:seed, e.g. kernel:190011")
    ap.add_argument("--variants", default="main,readout,products_on_readout,gate0.9")
    a = ap.parse_args(argv)
    variants = a.variants.split(",")
    for v in variants:
        if v.startswith("gate") and not 0 < float(v[4:] or "nan") <= 1:
            print(f"--variants: a gate's threshold must be in (0, 1]; got {v!r}", file=sys.stderr)
            return 2
    for spec in a.recordings:
        backend, _, seed = spec.partition(":")
        if backend not in ("kernel", "foreign") or not seed.isdigit():
            print(f"a recording is backend:seed with backend kernel or foreign; got {spec!r}",
                  file=sys.stderr)  # fmt: skip
            return 2
        for v in variants:
            print(f"{spec} [{v}]: {conclusion(backend, int(seed), v)}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
