"""Offline Pareto fronts of the benchmark suites: computed here, never downloaded.

``pareto_front(name, n_obj, ...)`` returns the true front of a suite problem as rows of
objective vectors; ``front_sample`` also returns the variables behind every point, and
``front_designs`` turns them into decision vectors, so that the tests can evaluate the
real problem at the front and check that it is attained and feasible. How each family's
front is obtained is described in its module (``mw``, ``cdtlz``, ``dascmop``,
``lircmop``) and
summarised in ``docs/benchmark-problems.md``.
"""

from __future__ import annotations

import re
from functools import lru_cache

import numpy as np

from tmopt.problems.fronts import cdtlz, dascmop, designs, lircmop, mw
from tmopt.problems.fronts.sampling import FrontSample

__all__ = ["FRONT_SOURCE", "FrontSample", "front_designs", "front_sample", "pareto_front",
           "split_name"]

CDTLZ = ("c1dtlz1", "c1dtlz3", "c2dtlz2", "c3dtlz1", "c3dtlz4")
#: How each front is obtained: "analytic" (closed form, at most filtered by the
#: constraints), "sampled" (lowest feasible point along a dense set of directions, then the
#: non-dominated ones) or both. No front is shipped as a file.
FRONT_SOURCE = {
    **{f"mw{k}": "sampled" for k in (1, 3, 6, 7, 9, 10, 11, 12, 13)},
    "mw2": "analytic", "mw4": "analytic", "mw8": "analytic", "mw14": "analytic",
    "mw5": "analytic (16 points) + sampled (arcs)",
    **{name: "analytic" for name in CDTLZ},
    **{f"dascmop{k}": "sampled" for k in range(1, 10)},
    **{f"lircmop{k}": "analytic" for k in (1, 2, 3, 4, 13, 14)},
    **{f"lircmop{k}": "sampled (boundary of the feasible region)" for k in range(5, 13)},
}
FAMILY_SIZE = {"mw": 14, "dascmop": 9, "lircmop": 14}


def split_name(name: str) -> tuple[str, int | str]:
    """``"mw3" -> ("mw", 3)``, ``"dascmop7" -> ("dascmop", 7)``, ``"lircmop5" ->
    ("lircmop", 5)``, ``"c2dtlz2" -> ("cdtlz", ...)``.

    Raises ValueError naming the supported problems for anything else.
    """
    key = str(name).lower()
    m = re.fullmatch(r"(mw|dascmop|lircmop)(\d+)", key)
    if m and 1 <= int(m[2]) <= FAMILY_SIZE[m[1]]:
        return m[1], int(m[2])
    if key in CDTLZ:
        return "cdtlz", key
    raise ValueError(f"no offline Pareto front for problem {name!r}; supported: mw1..mw14, "
                     f"{', '.join(CDTLZ)}, dascmop1..dascmop9, lircmop1..lircmop14")


def _difficulty_key(difficulty) -> tuple[float, float, float] | None:
    return None if difficulty is None else dascmop.triplet(difficulty)


@lru_cache(maxsize=64)
def _cached(name: str, n_obj: int, n_points: int, difficulty) -> FrontSample:
    family, which = split_name(name)
    if family == "mw":
        return mw.front_sample(which, n_obj, n_points)
    if family == "dascmop":
        return dascmop.front_sample(which, difficulty or 8, n_points)
    if family == "lircmop":
        return lircmop.front_sample(which, n_points)
    F = cdtlz.front(which, n_obj, n_points)
    g = 2 * F.sum(1) - 1 if which.endswith("dtlz1") else np.linalg.norm(F, axis=1) - 1
    return FrontSample(F, F[:, :-1], g)


def front_sample(name: str, n_obj: int, n_points: int = 2000, difficulty=None) -> FrontSample:
    """Front of a suite problem with the position variables and distance of each point."""
    sample = _cached(str(name).lower(), int(n_obj), int(n_points), _difficulty_key(difficulty))
    return FrontSample(sample.F.copy(), sample.pos.copy(), sample.g.copy())


def pareto_front(name: str, n_obj: int, n_points: int = 2000, difficulty=None) -> np.ndarray:
    """True Pareto front of a suite problem, (n, n_obj), computed offline (cached)."""
    return front_sample(name, n_obj, n_points, difficulty).F


def front_designs(name: str, n_var: int, n_obj: int, xu: float, sample: FrontSample) -> np.ndarray:
    """Decision vectors whose evaluation gives the points of ``sample`` (for checks)."""
    family, which = split_name(name)
    if family == "mw":
        return designs.mw_designs(which, n_var, n_obj, xu, sample)
    if family == "dascmop":
        return designs.dascmop_designs(which, n_var, sample)
    if family == "lircmop":
        return designs.lircmop_designs(which, n_var, sample)
    return designs.cdtlz_designs(which, n_var, sample.F)
