"""Scores of stiffness designs on many noise seeds: held-out re-scoring and the floor line.

A design's objectives are one noise draw (or a mean of K, or a prediction); an optimiser
that picks the best of hundreds of draws picks noise luck along with excitation quality.
After a run, :func:`heldout_metrics` re-simulates the chosen design (Eq. 21) and every
design of the final feasible front on held-out seeds -- seeds no noise mode of the search
can draw (:mod:`tmopt.physics.noise`, checked against the archive's record) -- and sets
the numbers beside the physical floor (:mod:`tmopt.physics.floor`).  The runner merges
the result into ``metrics.json`` (blocks ``heldout``, ``heldout_front``, ``floor``).
"""

from __future__ import annotations

import logging
import time

import numpy as np

from tmopt.physics import objectives as phys_obj
from tmopt.physics.floor import stiffness_floor
from tmopt.physics.noise import check_heldout, heldout_seeds

__all__ = ["QUANTITIES", "scores", "summary", "heldout_metrics", "floor_block"]

#: The per-run quantities of Table 3, by their metrics.json name (threshold of M in
#: parentheses; the others at the problem's epsilon).
QUANTITIES = ("convergence_time", "convergence_accuracy", "final_accuracy", "M",
              "M(7e-11)", "M(5e-11)")  # fmt: skip
_STRICT = {"M(7e-11)": 7e-11, "M(5e-11)": 5e-11}
#: Seconds between progress lines of a long scoring (a front of a few hundred designs x
#: 32 seeds is minutes of simulation after the search's last line).
PROGRESS_EVERY_S = 10.0

log = logging.getLogger("tmopt.progress")


def scores(problem, X: np.ndarray, seeds: np.ndarray) -> dict[str, np.ndarray]:
    """Every design of ``X`` (n, d) run on every seed (S,): arrays (n, S) per quantity.

    Keys ``"<quantity>_TM<k>"`` for each objective test mass k (:data:`QUANTITIES`), and
    ``"eq20"``: the run kept Eq. 20 on its realised motion and force (every decision
    test mass) and did not diverge.  Designs x seeds go to the simulator in one call per
    chunk (``problem.chunk`` runs).
    """
    X = np.atleast_2d(np.asarray(X, dtype=float))
    seeds = np.asarray(seeds, dtype=np.int64)
    n, s = len(X), len(seeds)
    out: dict[str, list] = {}
    step = max(1, problem.chunk // max(1, s))
    t0 = last = time.monotonic()
    for start in range(0, n, step):
        block = X[start:start + step]
        res = problem.simulate_designs(np.repeat(block, s, axis=0),
                                       seed=np.tile(seeds, len(block)))  # fmt: skip
        for key, v in _run_scores(problem, res).items():
            out.setdefault(key, []).append(v.reshape(len(block), s))
        now = time.monotonic()
        if now - last >= PROGRESS_EVERY_S:
            log.info("held-out scoring: %d/%d designs x %d seeds (%.0f s)",
                     start + len(block), n, s, now - t0)
            last = now
    return {k: np.vstack(v) for k, v in out.items()}


def _run_scores(problem, res) -> dict[str, np.ndarray]:
    cols = {}
    for tm in problem.objective_tms:
        base = phys_obj.evaluate(res, idx=tm - 1, eps=problem.epsilon, weights=problem.m_weights)
        for q in ("convergence_time", "convergence_accuracy", "final_accuracy", "M"):
            cols[f"{q}_TM{tm}"] = base[q]
        for name, eps in _STRICT.items():
            cols[f"{name}_TM{tm}"] = phys_obj.evaluate(res, idx=tm - 1, eps=eps,
                                                       weights=problem.m_weights)["M"]
    g = problem._normalised(phys_obj.eq20_realised(res))
    cols["eq20"] = np.all(g <= 0, axis=1) & ~res.diverged
    return cols


def summary(values: np.ndarray, rms: bool = False) -> dict:
    """``mean``, ``std`` (ddof 1), ``median`` (and ``rms``) of one design's values."""
    v = np.asarray(values, dtype=float)
    out = {"mean": float(v.mean()), "std": float(v.std(ddof=1)) if v.size > 1 else 0.0,
           "median": float(np.median(v))}
    if rms:
        out["rms"] = float(np.sqrt(np.mean(v**2)))
    return out


def _design_block(problem, sc: dict, row: int, tm: int) -> dict:
    block = {}
    for q in QUANTITIES:
        block[q] = summary(sc[f"{q}_TM{tm}"][row], rms=q in ("convergence_accuracy",
                                                             "final_accuracy"))
    return block


def heldout_metrics(problem, X: np.ndarray, best: int, front: np.ndarray,
                    used_seeds: np.ndarray | None = None) -> dict:
    """metrics.json blocks ``heldout`` (the chosen design) and ``heldout_front``.

    Args:
        problem: The :class:`~tmopt.problems.stiffness.StiffnessProblem` of the run.
        X: The archive's designs (n, d).
        best: Row of the chosen design (Eq. 21; the least violating when none is feasible).
        front: Rows of the final feasible non-dominated set.
        used_seeds: Noise seeds that scored the search (the archive's record): the
            held-out seeds must not be among them (raises otherwise).
    """
    seeds = heldout_seeds(problem.n_heldout)
    check_heldout(seeds, np.zeros(0) if used_seeds is None else used_seeds)
    rows = list(dict.fromkeys([int(best), *map(int, front)]))
    log.info("held-out scoring: the chosen design and the front, %d designs x %d seeds",
             len(rows), len(seeds))
    sc = scores(problem, X[rows], seeds)
    first = problem.objective_tms[0]
    heldout = {"n_seeds": int(len(seeds)), "seeds": [int(seeds[0]), int(seeds[-1])],
               "design": int(best), **_design_block(problem, sc, 0, first),
               "eq20_share": float(sc["eq20"][0].mean())}  # fmt: skip
    for tm in problem.objective_tms[1:]:
        heldout[f"TM{tm}"] = _design_block(problem, sc, 0, tm)
    ordered = [rows.index(int(i)) for i in front]
    means = {q: [float(sc[f"{q}_TM{first}"][r].mean()) for r in ordered] for q in QUANTITIES}
    front_block = {"index": [int(i) for i in front], **{f"{q}_mean": v for q, v in means.items()},
                   "eq20_share": [float(sc["eq20"][r].mean()) for r in ordered]}
    if len(front):
        k = int(np.argmin(means["M"]))
        front_block["best_M"] = {"index": int(front[k]), "M_mean": means["M"][k],
                                 "M_std": float(sc[f"M_TM{first}"][ordered[k]].std(ddof=1))}
    return {"heldout": heldout, "heldout_front": front_block}


def floor_block(problem, heldout: dict | None = None, identification: dict | None = None
                ) -> dict:  # fmt: skip
    """The floor of the key stiffness (and TM2's in scheme C) at the held-out convergence
    time, and ``below_floor``: every reported accuracy or M below its floor (noise luck)."""
    out: dict = {}
    for j, tm in enumerate(problem.objective_tms):
        fl = stiffness_floor(problem.config, idx=tm - 1, constraints=problem.constraint_mode)
        block = (heldout if j == 0 else heldout.get(f"TM{tm}")) if heldout else None
        t0 = block["convergence_time"]["mean"] if block else None
        entry = fl.as_dict(t0=t0, weights=problem.m_weights)
        entry["below_floor"] = _below(fl, entry, block, identification, tm, problem.m_weights)
        if j == 0:
            out.update(entry)
        else:
            out[f"TM{tm}"] = entry
    return out


def _below(fl, entry: dict, block: dict | None, ident: dict | None, tm: int,
           weights) -> list[str]:  # fmt: skip
    """Names of reported numbers below their floor: the floor of a mean for means and
    single draws (a single draw below it is luck), of the rms for rms values."""
    flags = []
    if block:
        checks = [("final_accuracy.mean", block["final_accuracy"]["mean"], fl.final_mean),
                  ("final_accuracy.rms", block["final_accuracy"]["rms"], fl.final),
                  ("convergence_accuracy.mean", block["convergence_accuracy"]["mean"],
                   entry["convergence_accuracy_mean"]),
                  ("convergence_accuracy.rms", block["convergence_accuracy"]["rms"],
                   entry["convergence_accuracy_rms"]),
                  ("M.mean", block["M"]["mean"], entry["M"])]  # fmt: skip
        flags += [f"heldout.{name}" for name, value, floor in checks if value < floor]
    if ident:
        tag = f"TM{tm}"
        t0 = ident.get(f"convergence_time_{tag}")
        pairs = [(f"final_accuracy_{tag}", fl.final_mean)]
        if t0 is not None:
            pairs.append((f"convergence_accuracy_{tag}", fl.convergence_accuracy(t0, "mean")))
        pairs.append((f"M_{tag}", fl.m_floor(weights)[0]))
        flags += [f"identification.{k}" for k, floor in pairs
                  if ident.get(k) is not None and ident[k] < floor]
    return flags
