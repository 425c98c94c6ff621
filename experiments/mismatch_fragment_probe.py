"""Why a record cut into short pieces raises false alarms (docs/mismatch.md 9.22).

    python experiments/mismatch_fragment_probe.py psd kernel:38202:32
    python experiments/mismatch_fragment_probe.py bias kernel:38202:32
    python experiments/mismatch_fragment_probe.py cost foreign:38206:0
    python experiments/mismatch_fragment_probe.py oracle foreign:38202:32 [...]
    python experiments/mismatch_fragment_probe.py rails kernel:190135 [foreign:180137 ...]

A recording is ``backend:seed[:K]``.  ``psd`` and ``oracle`` take a clean flight-like
recording (calibration seeds < 40000) with its own gaps replaced by K random NaN runs
(``mismatch_gap_calibration.random_gaps``):

* ``psd`` -- the nominal fit's noise models of the cut and the uncut recording (the same
  noise): the ratio cut/uncut of every channel's PSD and, for the equation group, the
  coherence of the two f_B-free rows, at 25 log-spaced frequencies;
* ``bias`` -- the cut recording's nominal equation-group residual, per frequency band and
  segment length: the mean periodogram over the uncut model's PSD, beside what the
  taper alone (``none``) and the taper with the fitted offset (``gls``) are expected to
  leave under that PSD (``tmopt.mismatch.expected_periodogram``): how much of a low
  bin's deficit the offsets explain;
* ``cost`` -- what ``noise_model.DEBIAS`` costs: the uncut recording's nominal fit and
  whole diagnosis with ``offset`` over ``off``, alternated three times in one process
  (median ratio);
* ``oracle`` -- the cut recording diagnosed with its own noise estimate, then with the
  noise model estimated on the uncut residual (its spectrum, the cut layout): whether the
  estimate or the rest of the machinery raises the alarm; ``--part psd`` or
  ``coherence`` takes only the uncut PSDs or only its coherence (the rest its own).

``rails`` takes a benchmark ``acc_clipping`` recording (``mismatch_realistic.cases``):
the clean recording of the same scenario and noise, diagnosed whole and with the clipped
recording's rail samples dropped (``fit.drop_samples``): whether the gaps alone raise a
name.
"""

from __future__ import annotations

import argparse
import copy
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _cut_and_whole(backend: str, seed: int, k: int):
    from mismatch_gap_calibration import random_gaps

    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.realistic import draw_scenario, realistic_recording

    sc = draw_scenario(seed, backend)
    whole = data_from_recording(realistic_recording(replace(sc, gaps=()), (), (), seed,
                                                    backend)[0])  # fmt: skip
    cut = data_from_recording(realistic_recording(
        replace(sc, gaps=random_gaps(k, sc.duration, seed)), (), (), seed, backend)[0])
    return cut, whole


def _nominal_state(data):
    from tmopt.mismatch.diagnose import Settings, fit_state, prepare

    prepared, basis = prepare(copy.deepcopy(data))
    return fit_state(prepared, basis, [], [], False, Settings())


def _coherence(m: np.ndarray) -> float:
    """|S_01| / sqrt(S_00 S_11) of one (2, 2) cross-spectral matrix."""
    return float(abs(m[0, 1]) / np.sqrt(m[0, 0].real * m[1, 1].real))


def psd(backend: str, seed: int, k: int) -> None:
    cut, whole = _cut_and_whole(backend, seed, k)
    st_cut, st_whole = _nominal_state(cut), _nominal_state(whole)
    f = np.geomspace(1e-4, 0.45 * cut.fs, 25)
    for group in ("eq", "kin"):
        mc = getattr(st_cut, f"{group}_noise").matrix(f)
        mw = getattr(st_whole, f"{group}_noise").matrix(f)
        c = mc.shape[1]
        print(f"{backend}:{seed}:{k} {group}: f [Hz], PSD cut/uncut per channel"
              + (", coherence uncut / cut" if c == 2 else ""))  # fmt: skip
        for i, fi in enumerate(f):
            ratio = " ".join(f"{mc[i, j, j].real / mw[i, j, j].real:6.2f}" for j in range(c))
            extra = f"   {_coherence(mw[i]):.2f} / {_coherence(mc[i]):.2f}" if c == 2 else ""
            print(f"  {fi:9.2e}  {ratio}{extra}")


BIAS_BANDS = ((0.002, 0.005), (0.005, 0.01), (0.01, 0.02), (0.02, 0.05), (0.05, 0.15))


def bias(backend: str, seed: int, k: int) -> None:
    from tmopt.mismatch.expected_periodogram import SegmentKernel, autocovariance
    from tmopt.mismatch.noise_model import taper

    cut, whole = _cut_and_whole(backend, seed, k)
    st_cut, st_whole = _nominal_state(cut), _nominal_state(whole)
    res, layout, fs = st_cut.eq_fit.residual, st_cut.eq_noise.layout, cut.fs
    n_grid = 1 << int(np.ceil(np.log2(8 * whole.n)))
    grid = np.fft.rfftfreq(n_grid, 1 / fs)
    model = np.real(np.einsum("fii->fi", st_whole.eq_noise.matrix(np.maximum(grid, 1e-6))))
    lengths = [b - a for a, b in layout.bounds]
    print(f"{backend}:{seed}:{k}: {len(lengths)} segments, median {np.median(lengths):.0f} "
          f"samples; eq rows: band [Hz], segment length, bins, periodogram / uncut PSD, "
          f"expected with the taper (none) and the fitted offset (gls)")  # fmt: skip
    for ch in range(res.shape[0]):
        acov = autocovariance(model[:, ch])
        for lo, hi in BIAS_BANDS:
            for name, short in (("< 512", True), (">= 512", False)):
                obs, none, gls, psd_at = [], [], [], []
                for a, b in layout.bounds:
                    if (b - a < 512) != short:
                        continue
                    f = np.fft.rfftfreq(b - a, 1 / fs)
                    sel = (f >= lo) & (f < hi)
                    if not sel.any():
                        continue
                    kern = SegmentKernel(taper(b - a))
                    psd_seg = np.interp(f, grid, model[:, ch])
                    obs += list(np.abs(np.fft.rfft(res[ch, a:b] * kern.w)[sel]) ** 2 / kern.norm)
                    none += list(kern.expected(acov, "none")[sel])
                    gls += list(kern.expected(acov, "gls", psd_seg)[sel])
                    psd_at += list(psd_seg[sel])
                if obs:
                    ref = float(np.mean(psd_at))
                    print(f"  row {ch + 1} {lo:.3f}-{hi:.3f} {name:>6}: {len(obs):4d} bins  "
                          f"{np.mean(obs) / ref:5.2f}  none {np.mean(none) / ref:5.2f}  "
                          f"gls {np.mean(gls) / ref:5.2f}")  # fmt: skip


def cost(backend: str, seed: int, k: int) -> None:
    import time

    import tmopt.mismatch.noise_model as nm
    from tmopt.mismatch.diagnose import diagnose

    _, whole = _cut_and_whole(backend, seed, k)
    jobs = {"nominal fit": lambda: _nominal_state(whole),
            "diagnosis": lambda: diagnose(copy.deepcopy(whole))}  # fmt: skip
    original = nm.DEBIAS
    try:
        for name, job in jobs.items():
            took = {"off": [], "offset": []}
            for _ in range(3):
                for kind in took:
                    nm.DEBIAS = kind
                    t0 = time.perf_counter()
                    job()
                    took[kind].append(time.perf_counter() - t0)
            ratio = float(np.median(np.array(took["offset"]) / np.array(took["off"])))
            print(f"{backend}:{seed} ({whole.n} samples) {name}: offset / off = {ratio:.2f} "
                  f"(median of 3; off {np.median(took['off']):.2f} s)", flush=True)
    finally:
        nm.DEBIAS = original


def oracle(backend: str, seed: int, k: int, part: str = "all") -> None:
    import tmopt.mismatch.noise_model as nm
    from tmopt.mismatch.diagnose import diagnose
    from tmopt.mismatch.report import build_report

    cut, whole = _cut_and_whole(backend, seed, k)
    st = _nominal_state(whole)
    models = {2: st.eq_noise, 4: st.kin_noise}
    spec = f"{backend}:{seed}:{k}"
    print(f"{spec} own estimate: {build_report(diagnose(copy.deepcopy(cut)))['conclusion']}",
          flush=True)  # fmt: skip
    original = nm.NoiseModel.estimate.__func__

    def uncut(cls, residual, layout, fs, *args, **kwargs):
        c = residual.shape[0]
        if c not in models or layout.n == models[c].layout.n:
            return original(cls, residual, layout, fs, *args, **kwargs)
        take = {"all": {"knots", "coefs", "coh_f", "coh", "transfer"},
                "psd": {"knots", "coefs"}, "coherence": {"coh_f", "coh"}}[part]
        own = original(cls, residual, layout, fs, *args, **kwargs)
        if own.kind != models[c].kind or own.transfer is not None:
            return own
        return replace(own, _cache={}, **{n: getattr(models[c], n) for n in take})

    nm.NoiseModel.estimate = classmethod(uncut)
    try:
        rep = build_report(diagnose(copy.deepcopy(cut)))
    finally:
        nm.NoiseModel.estimate = classmethod(original)
    print(f"{spec} uncut {'spectrum' if part == 'all' else part}: {rep['conclusion']}",
          flush=True)  # fmt: skip


def rails(backend: str, seed: int) -> None:
    from mismatch_realistic import build, cases

    from tmopt.mismatch.diagnose import diagnose
    from tmopt.mismatch.fit import data_from_recording, drop_samples
    from tmopt.mismatch.plausibility import rail_samples
    from tmopt.mismatch.realistic import realistic_recording
    from tmopt.mismatch.report import build_report

    [case] = [c for c in cases(backend, seed // 10000 * 10000, False) if c["seed"] == seed]
    sc, effects, ooc, _ = build(case)
    clipped = data_from_recording(realistic_recording(sc, effects, ooc, seed, backend)[0])
    clean = data_from_recording(realistic_recording(sc, [], [], seed, backend)[0])
    mask = rail_samples(clipped)
    if not mask.any() or clean.n != clipped.n:
        print(f"{backend}:{seed}: no rail samples on a common grid (not acc_clipping?)")
        return
    dropped = drop_samples(clean, mask, "the clipped recording's rail samples")
    print(f"{backend}:{seed} clean, whole: "
          f"{build_report(diagnose(copy.deepcopy(clean)))['conclusion']}", flush=True)
    print(f"{backend}:{seed} clean, {int(mask.sum())} rail samples dropped "
          f"({len(dropped.segments)} segments): "
          f"{build_report(diagnose(dropped))['conclusion']}", flush=True)  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("mode", choices=("psd", "bias", "cost", "oracle", "rails"))
    p.add_argument("recordings", nargs="+", help="backend:seed[:K]")
    p.add_argument("--part", choices=("all", "psd", "coherence"), default="all",
                   help="oracle: take from the uncut model its PSDs and coherence (all), "
                        "its PSDs only, or its coherence only")  # fmt: skip
    a = p.parse_args(argv)
    for spec in a.recordings:
        parts = spec.split(":")
        need = 2 if a.mode == "rails" else 3
        if len(parts) != need or parts[0] not in ("kernel", "foreign") or \
                not all(x.isdigit() for x in parts[1:]):  # fmt: skip
            print(f"error: {a.mode} takes backend:seed" + ("" if need == 2 else ":K")
                  + f" with backend kernel or foreign; got {spec!r}", file=sys.stderr)
            return 2
        seed = int(parts[1])
        if a.mode != "rails" and seed >= 40000:
            print(f"error: {spec!r}: psd, bias, cost and oracle take calibration seeds "
                  "(< 40000)",
                  file=sys.stderr)  # fmt: skip
            return 2
        if a.mode == "psd":
            psd(parts[0], seed, int(parts[2]))
        elif a.mode == "bias":
            bias(parts[0], seed, int(parts[2]))
        elif a.mode == "cost":
            cost(parts[0], seed, int(parts[2]))
        elif a.mode == "oracle":
            oracle(parts[0], seed, int(parts[2]), a.part)
        else:
            rails(parts[0], seed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
