"""Anytime view of a sweep: what each run would report after its first k evaluations.

Expensive optimisation compares algorithms at equal numbers of real evaluations, and a
sweep's final tables compare each run at its own end. Here every run's archive (complete
or not: an unfinished run counts up to where it got) is cut after its first ``k`` real
evaluations, in the order they were made, and the run's final choice is taken on that
prefix (:func:`tmopt.run.outputs.final_choice`: the feasible non-dominated set, the best
compromise of Eq. 21, else the least violating design). Per ``k``:

- stiffness problem: whether that design is feasible, its convergence time (Eq. 18),
  accuracy (Eq. 19) and M (Eq. 29) of TM1, from the archived objectives (the numbers
  the optimiser saw: one noise draw under ``fixed``), and -- the headline, as in the final
  tables -- the same design re-simulated on the run's held-out noise seeds (``heldout``,
  the block metrics.json has; ``heldout_seeds`` of :func:`anytime_records`, default the
  problem's own): a curve of search draws would show the selection's noise luck growing
  with k. A design chosen at several k is simulated once per run;
- benchmark suites: whether a feasible design exists, IGD, IGD+ and HV of the feasible
  front (:func:`tmopt.run.outputs.indicator_values`).

Runs that have not reached ``k`` are counted as such (``runs`` = reached / all), never
extrapolated. The table tests each setting against the reference algorithm at the same
``k`` (Wilcoxon rank-sum, as the final tables).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence

import numpy as np
from omegaconf import OmegaConf

from tmopt.evaluation.archive import ArchiveData, read_archive
from tmopt.metrics.identification import metric_m
from tmopt.problems.heldout import heldout_metrics
from tmopt.reporting.runs import COMPLETE, INCOMPLETE, RunRecord
from tmopt.run.build import build_problem
from tmopt.run.outputs import final_choice, indicator_values, reference_front
from tmopt.run.progress import feasible_share

log = logging.getLogger(__name__)

#: Pseudo-setting key under which the evaluation count k enters a run's settings.
EVALS_KEY = "evaluations"
#: The key test mass whose numbers Table 3 reports (paper Sec. 4.4).
KEY_TM = "TM1"


def parse_counts(text: str) -> list[int]:
    """``"300,400,697"`` -> ``[300, 400, 697]`` (positive integers, sorted, unique)."""
    try:
        counts = sorted({int(part) for part in text.split(",") if part.strip()})
    except ValueError:
        raise ValueError(f"--at must be comma-separated positive integers, got {text!r}") \
            from None
    if not counts or counts[0] < 1:
        raise ValueError(f"--at must be comma-separated positive integers, got {text!r}")
    return counts


def prefix_values(problem, data: ArchiveData, k: int, front=None,
                  heldout_cache: dict | None = None) -> dict:
    """The run's report after its first ``k`` evaluations (``k <= len(data)``).

    ``heldout_cache``: for the stiffness problem with held-out seeds, the ``heldout``
    block of each chosen row (filled here; None: no held-out scoring)."""
    head = data.rows(0, k)
    pareto, best = final_choice(head)
    chosen = {"feasible": bool(len(pareto))}
    out: dict = {"chosen": chosen, "pareto_size": int(len(pareto)), "n_evals": k}
    names = list(getattr(problem, "objective_names", []))
    t_key, a_key = f"convergence_time_{KEY_TM}", f"convergence_accuracy_{KEY_TM}"
    if best >= 0 and t_key in names and a_key in names:
        t, acc = (float(head.F[best, names.index(key)]) for key in (t_key, a_key))
        out["identification"] = {t_key: t, a_key: acc,
                                 f"M_{KEY_TM}": metric_m(t, acc, *problem.m_weights)}
        if heldout_cache is not None:
            if best not in heldout_cache:
                used = getattr(data, "noise_seeds", None)
                heldout_cache[best] = heldout_metrics(
                    problem, data.X, best, np.zeros(0, dtype=int),
                    used_seeds=used if used is not None and len(used) else None)["heldout"]
            out["heldout"] = heldout_cache[best]
    else:
        out.update(indicator_values(problem, head.F[pareto], front))
        out["feasible_ratio"] = feasible_share(head)  # as metrics.json's, of the prefix
    return out


def anytime_records(run: RunRecord, counts: Sequence[int],
                    heldout_seeds: int | None = None) -> list[RunRecord]:
    """One pseudo-run per ``k`` in ``counts``: the run's report after ``k`` evaluations.

    ``heldout_seeds``: held-out realisations each chosen stiffness design is re-scored on
    (None: the run's own ``problem.heldout_seeds``; 0: none, search draws only).

    Each carries ``evaluations = k`` in its configuration (so it groups by ``k``) and is
    ``complete`` when the run had reached ``k`` (then its metrics are the prefix's),
    ``incomplete`` otherwise; a run without a readable archive (or problem) reached none
    of them, so it still counts among the setting's runs.
    """
    try:
        data = read_archive(run.path / "archive.h5")
        problem = build_problem(OmegaConf.create(run.config))
    except Exception as exc:  # a missing/corrupt archive or config: counted, not fatal
        log.warning("anytime: %s has no readable archive (%s)", run.path, exc)
        return [dataclasses.replace(run, status=INCOMPLETE, metrics=None, n_evals=None,
                                    config={**run.config, EVALS_KEY: k}) for k in counts]
    stiffness = hasattr(problem, "m_weights")
    front = None if stiffness else reference_front(problem)
    if stiffness and heldout_seeds is not None:
        problem.n_heldout = int(heldout_seeds)
    cache = {} if stiffness and getattr(problem, "n_heldout", 0) > 0 else None
    records = []
    for k in counts:
        config = {**run.config, EVALS_KEY: k}
        if k <= len(data):
            metrics = prefix_values(problem, data, k, front, cache)
            records.append(dataclasses.replace(run, status=COMPLETE, config=config,
                                               metrics=metrics, n_evals=k))
        else:
            records.append(dataclasses.replace(run, status=INCOMPLETE, config=config,
                                               metrics=None, n_evals=len(data)))
    return records


def curve_counts(runs: Sequence[RunRecord], counts: Sequence[int], points: int = 40) -> list[int]:
    """Evaluation counts of the curves: ``points`` even steps up to each distinct run
    length (so a 697-evaluation run is resolved as finely as a 10 000 one), plus ``counts``."""
    lengths = {int(r.budget or r.n_evals or 0) for r in runs} - {0}
    grid = {int(c) for c in counts}
    for length in lengths:
        step = max(1, length // points)
        grid.update(range(step, length + 1, step))
        grid.add(length)
    return sorted(grid)


# ---- against wall-clock time ---------------------------------------------------------------
#: Pseudo-setting key under which the wall-clock time t (s) enters a run's settings.
SECONDS_KEY = "seconds"


def evaluations_by(run: RunRecord, seconds: float) -> int | None:
    """Evaluations the run had completed ``seconds`` after its loop started (the
    ``evaluation_clock`` of metrics.json, one entry per generation: surrogate fitting,
    infill search and evaluation all count); None if the run never got that far or has no
    clock (older runs, incomplete runs, resumed runs, whose clock restarts)."""
    clock = (run.metrics or {}).get("evaluation_clock") or {}
    evals, secs = clock.get("evaluations") or [], clock.get("seconds") or []
    if run.status != COMPLETE or not secs or (run.metrics or {}).get("resumed_from"):
        return None
    if seconds > secs[-1]:
        return None
    done = [n for n, t in zip(evals, secs) if t <= seconds]
    return done[-1] if done else 0


def seconds_grid(runs: Sequence[RunRecord], points: int = 30) -> list[float]:
    """Log-spaced times from the earliest first generation to the longest run's end."""
    import numpy as np

    firsts, lasts = [], []
    for run in runs:
        secs = ((run.metrics or {}).get("evaluation_clock") or {}).get("seconds") or []
        if secs:
            firsts.append(max(secs[0], 1e-3))
            lasts.append(secs[-1])
    if not lasts:
        return []
    return [float(t) for t in np.geomspace(min(firsts), max(lasts), points)]


def clock_records(run: RunRecord, grid: Sequence[float]) -> list[RunRecord]:
    """One pseudo-run per time t in ``grid``: the run's report after the evaluations it had
    completed by t (``complete`` if it was still running at t, else ``incomplete``)."""
    import numpy as np

    counts = [evaluations_by(run, t) for t in grid]
    problem = data = front = None
    if any(k is not None for k in counts):
        try:
            data = read_archive(run.path / "archive.h5")
            problem = build_problem(OmegaConf.create(run.config))
            front = None if hasattr(problem, "m_weights") else reference_front(problem)
        except Exception as exc:  # counted, not fatal, as in anytime_records
            log.warning("anytime: %s has no readable archive (%s)", run.path, exc)
            counts = [None] * len(grid)
    records = []
    for t, k in zip(grid, counts):
        config = {**run.config, SECONDS_KEY: t}
        if k is None:
            records.append(dataclasses.replace(run, status=INCOMPLETE, config=config,
                                               metrics=None))
            continue
        if k == 0:  # the initial design not evaluated yet: nothing to report
            metrics = {"chosen": {"feasible": False}, "pareto_size": 0, "n_evals": 0,
                       **indicator_values(problem, np.zeros((0, problem.n_obj)), front)}
        else:
            metrics = prefix_values(problem, data, min(k, len(data)), front)
        records.append(dataclasses.replace(run, status=COMPLETE, config=config,
                                           metrics=metrics, n_evals=k))
    return records


def rescored(run: RunRecord) -> RunRecord:
    """A complete suite run with IGD, IGD+ and HV recomputed from its archive against
    today's front (its final choice as the runner takes it); other runs unchanged."""
    if run.status != COMPLETE:
        return run
    try:
        data = read_archive(run.path / "archive.h5")
        problem = build_problem(OmegaConf.create(run.config))
    except Exception as exc:  # reported, the written numbers kept
        log.warning("rescore: %s keeps its metrics.json numbers (%s)", run.path, exc)
        return run
    pareto, _ = final_choice(data)
    values = indicator_values(problem, data.F[pareto], reference_front(problem))
    return dataclasses.replace(run, metrics={**run.metrics, **values})
