"""CPU and peak memory of one diagnosis against the record's length.

    python experiments/mismatch_length_scaling.py [--backend kernel] [--fs 10] \
        [--seed 38400] [--durations 1800,3600,7200,14400]

The benchmark's recordings last 1200-3600 s; a flight recording may last hours (LISA
Pathfinder's system-identification runs did).  Each duration is a clean flight-like
recording (:func:`tmopt.mismatch.realistic.draw_scenario` with the duration and sample
rate fixed, everything else drawn from ``--seed``: a calibration seed, never a
benchmark's), diagnosed with the default settings in a fresh child process, so its peak
resident memory is its own.  Printed per duration: samples, CPU seconds and peak memory,
each as a ratio to the first (shortest) duration, what the tool reported, and the
log-log slope of CPU against samples (1 = linear).  The machines are shared: read the
ratios, not the seconds.
"""

from __future__ import annotations

import argparse
import math
import multiprocessing as mp


def _one(args: tuple[str, float, int, float]) -> dict:
    import resource
    import time

    from tmopt.mismatch.diagnose import Settings, diagnose
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.realistic import draw_scenario, realistic_recording
    from tmopt.mismatch.report import build_report

    backend, fs, seed, duration = args
    rec, _ = realistic_recording(draw_scenario(seed, backend, duration=duration, sample_rate=fs),
                                 seed=seed, backend=backend)  # fmt: skip
    t0 = time.process_time()
    rep = build_report(diagnose(data_from_recording(rec), Settings()))
    cpu = time.process_time() - t0
    found = [f"{e['name']}[{e['channel']}]" for e in rep["effects"]]
    if rep["unexplained"]:
        found.append("unexplained " + ";".join(rep["unexplained_at"]["channels"]))
    return {"duration": duration, "samples": int(rep["data_used"]["samples_used"]),
            "cpu_s": cpu, "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            "found": found or ["-"]}  # fmt: skip


def _slope(rows: list[dict]) -> float:
    """Least-squares slope of log CPU against log samples."""
    xs = [math.log(r["samples"]) for r in rows]
    ys = [math.log(r["cpu_s"]) for r in rows]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--backend", choices=("kernel", "foreign"), default="kernel")
    ap.add_argument("--fs", type=float, default=10.0,
                    help="sample rate, Hz (the benchmark draws 2-10)")
    ap.add_argument("--seed", type=int, default=38400)
    ap.add_argument("--durations", default="1800,3600,7200,14400",
                    help="seconds, comma-separated, >= 600 each")
    a = ap.parse_args(argv)
    durations = sorted(float(x) for x in a.durations.split(","))
    if not durations or durations[0] < 600.0:
        ap.error(f"--durations: each must be >= 600 s (got {a.durations})")
    if not 0.5 <= a.fs <= 50.0:
        ap.error(f"--fs: must lie in 0.5..50 Hz (got {a.fs})")
    rows = []
    ctx = mp.get_context("spawn")
    for dur in durations:  # one fresh process each: its peak memory is its own
        with ctx.Pool(1) as pool:
            row = pool.apply(_one, ((a.backend, a.fs, a.seed, dur),))
        ref = rows[0] if rows else row
        rows.append(row)
        cpu_x, mem_x = row["cpu_s"] / ref["cpu_s"], row["peak_mb"] / ref["peak_mb"]
        print(f"{dur:8.0f} s {row['samples']:8d} samples  CPU {row['cpu_s']:7.1f} s "
              f"(x{cpu_x:5.2f})  peak {row['peak_mb']:7.0f} MB (x{mem_x:5.2f})  "
              f"{', '.join(row['found'])}", flush=True)  # fmt: skip
    if len(rows) > 1:
        first, last = rows[0], rows[-1]
        print(f"CPU ~ samples^{_slope(rows):.2f}; samples x{last['samples'] / first['samples']:.1f}"
              f" -> CPU x{last['cpu_s'] / first['cpu_s']:.1f}, "
              f"peak memory x{last['peak_mb'] / first['peak_mb']:.1f}")  # fmt: skip


if __name__ == "__main__":
    main()
