"""Files a finished run leaves in its folder.

- ``archive.h5`` (written during the run) and ``archive.csv`` (same rows, for people);
- ``pareto.csv``: the feasible non-dominated set of all real evaluations;
- ``best.json``: the solution chosen from that set by paper Eq. 21;
- ``metrics.json``: counts, feasibility, indicators (IGD/IGD+/HV where a reference front
  or point is known), wall time, the versions of Python and of the libraries that can
  change a run's numbers (:func:`library_versions`); written last, so its presence marks
  a finished run;
- ``pareto.png`` and ``convergence.png``.
"""

from __future__ import annotations

import csv
import functools
import importlib.metadata
import io
import json
import logging
import platform
from pathlib import Path

import numpy as np

from tmopt.evaluation.archive import ArchiveData
from tmopt.files import atomic_write_text
from tmopt.metrics import best_compromise, hypervolume, igd, igd_plus, non_dominated_feasible
from tmopt.metrics.indicators import constraint_violation
from tmopt.run.progress import best_so_far, feasible_share

log = logging.getLogger(__name__)

METRICS_FILE = "metrics.json"
STATUS_COMPLETE = "complete"
#: Distributions whose version can change a run's numbers: the models (torch, botorch,
#: gpytorch, linear_operator), the operators and indicators (pymoo, numpy, scipy), the
#: simulator (numba), the configuration (hydra-core, omegaconf) and the archive (h5py).
RECORDED_LIBRARIES = ("torch", "botorch", "gpytorch", "linear_operator", "pymoo", "numpy",
                      "scipy", "numba", "hydra-core", "omegaconf", "h5py")


def read_metrics(outdir: Path) -> dict | None:
    """The complete ``metrics.json`` in ``outdir`` (any configuration), else None."""
    path = Path(outdir) / METRICS_FILE
    try:
        metrics = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(metrics, dict) or metrics.get("status") != STATUS_COMPLETE:
        return None
    return metrics


def finished_metrics(outdir: Path, config_hash: str) -> dict | None:
    """The metrics of a finished run of the same configuration in ``outdir``, else None."""
    metrics = read_metrics(outdir)
    if metrics is None:
        return None
    if config_hash and metrics.get("config_hash") != config_hash:
        return None
    return metrics


def reference_front(problem) -> np.ndarray | None:
    """The problem's true Pareto front if it can be had offline, else None."""
    try:
        pf = problem.pareto_front()
    except Exception as exc:  # noqa: BLE001 - a missing front only disables IGD
        log.warning("problem %s: no Pareto front available (%s); IGD is not computed",
                    problem.name, exc)
        return None
    return None if pf is None else np.atleast_2d(np.asarray(pf, dtype=float))


def indicator_values(problem, F: np.ndarray, pf: np.ndarray | None) -> dict:
    """IGD, IGD+ and HV of the final set; HV normalised by the true front when known."""
    out: dict = {}
    if pf is not None:
        out["igd"] = _json_float(igd(F, pf)) if len(F) else None
        out["igd_plus"] = _json_float(igd_plus(F, pf)) if len(F) else None
        ideal, nadir = pf.min(axis=0), pf.max(axis=0)
        out["hv"] = _json_float(hypervolume(F, np.full(F.shape[1], 1.1), ideal, nadir)) \
            if len(F) else 0.0
    elif getattr(problem, "hv_ref_point", None) is not None:
        out["hv"] = _json_float(hypervolume(F, problem.hv_ref_point)) if len(F) else 0.0
    return out


def write_outputs(problem, algorithm, data: ArchiveData, outdir: Path | None, *, seed: int,
                  budget: int, wall_time: float, config_hash: str, resumed_from: int,
                  plots: bool, extra_metrics=None, clock=None) -> dict:
    """Compute the final set, choice and metrics; write them (when ``outdir`` is set).

    ``clock``: ``[(evaluations, seconds), ...]`` after each generation of this process
    (seconds since its loop started: surrogate, acquisition and evaluation time), kept as
    ``evaluation_clock`` for anytime curves against wall-clock time
    (:mod:`tmopt.reporting.anytime`); like ``wall_time_s`` it starts again on resume.
    """
    pareto, best = final_choice(data)
    pf = reference_front(problem)
    best_f = best_so_far(data)
    metrics = {
        "status": STATUS_COMPLETE,
        "problem": problem.describe(),
        "algorithm": algorithm.name,
        "seed": int(seed),
        "budget": int(budget),
        "n_evals": len(data),
        "n_failed": int(data.failed.sum()),
        "feasible_ratio": _json_float(feasible_share(data)),
        "pareto_size": int(len(pareto)),
        "best_objectives": None if best_f is None else [_json_float(v) for v in best_f],
        "chosen": _design_dict(problem, data, best, feasible=bool(len(pareto))),
        **indicator_values(problem, data.F[pareto], pf),
        "wall_time_s": round(float(wall_time), 3),
        "evaluation_clock": {"evaluations": [int(n) for n, _ in clock or ()],
                             "seconds": [round(float(t), 3) for _, t in clock or ()]},
        "resumed_from": int(resumed_from),
        "config_hash": config_hash,
        "algorithm_summary": algorithm.summary(),
        "versions": library_versions(),
    }
    if extra_metrics is not None:
        metrics.update(extra_metrics(problem, data, pareto, best))
    if outdir is not None:
        _write_files(problem, data, pareto, metrics, Path(outdir), pf, plots)
    return metrics


@functools.cache
def library_versions() -> dict[str, str]:
    """Python's version and the installed version of each of :data:`RECORDED_LIBRARIES`
    ("missing" for one not installed), as pip names them, e.g. ``{"torch": "2.13.0+cpu"}``.

    Recorded in every run's ``metrics.json`` because the same code and seed gave other
    numbers under other library versions (docs/benchmarks-gp.md); the studies' tested set
    is pinned in ``requirements-lock.txt``.
    """
    versions = {"python": platform.python_version()}
    for name in RECORDED_LIBRARIES:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            versions[name] = "missing"
    return versions


def final_choice(data: ArchiveData) -> tuple[np.ndarray, int]:
    """The run's final set and chosen design: the feasible non-dominated designs and the
    best compromise among them (Eq. 21); with none feasible, an empty set and the least
    violating design (-1 for an empty archive)."""
    pareto = non_dominated_feasible(data.F, data.G, data.failed)
    best = int(pareto[best_compromise(data.F[pareto])]) if len(pareto) else _least_violating(data)
    return pareto, best


def _least_violating(data: ArchiveData) -> int:
    cv = constraint_violation(np.nan_to_num(data.G, nan=np.inf))
    cv[data.failed] = np.inf
    return int(np.argmin(cv)) if len(cv) else -1


def _design_dict(problem, data: ArchiveData, i: int, feasible: bool) -> dict | None:
    if i < 0:
        return None
    return {
        "index": i,
        "feasible": feasible,
        "X": [float(v) for v in data.X[i]],
        "F": dict(zip(problem.objective_names, (_json_float(v) for v in data.F[i]))),
        "G": dict(zip(problem.constraint_names, (_json_float(v) for v in data.G[i]))),
    }


def _json_float(x) -> float | None:
    x = float(x)
    return x if np.isfinite(x) else None


def _write_files(problem, data, pareto, metrics, outdir: Path, pf, plots: bool) -> None:
    atomic_write_text(outdir / "archive.csv", _archive_csv(problem, data))
    atomic_write_text(outdir / "pareto.csv", _archive_csv(problem, data, rows=pareto))
    atomic_write_text(outdir / "best.json", json.dumps(metrics["chosen"], indent=2))
    if plots:
        from tmopt.run.plots import plot_convergence, plot_pareto

        try:
            plot_pareto(problem, data, pareto, outdir / "pareto.png", pf)
            plot_convergence(problem, data, outdir / "convergence.png")
        except Exception as exc:  # noqa: BLE001 - a plot must never lose the run's numbers
            log.warning("plotting failed: %s", exc)
    atomic_write_text(outdir / METRICS_FILE, json.dumps(metrics, indent=2))


def _archive_csv(problem, data: ArchiveData, rows=None) -> str:
    rows = np.arange(len(data)) if rows is None else np.asarray(rows, int)
    buf = io.StringIO()
    w = csv.writer(buf)
    xs = [f"x{i + 1}" for i in range(problem.n_var)]
    w.writerow(["index", "batch", *xs, *problem.objective_names, *problem.constraint_names,
                "failed", "reason", "seed", "wall_time_s", "noise_seeds"])
    for i in rows:
        w.writerow([i, int(data.batch[i]), *map(repr, data.X[i].tolist()),
                    *map(repr, data.F[i].tolist()), *map(repr, data.G[i].tolist()),
                    int(data.failed[i]), data.reason[i], int(data.seed[i]),
                    f"{data.wall_time[i]:.6g}",
                    " ".join(str(int(s)) for s in data.noise_seeds[i] if s >= 0)])
    return buf.getvalue()
