"""Constrained benchmark suites with offline Pareto fronts: MW, C-DTLZ, DAS-CMOP, LIR-CMOP.

The problems themselves are pymoo's implementations (``pymoo.problems.get_problem``),
except LIR-CMOP, which pymoo lacks (:mod:`tmopt.problems.lircmop`);
what this module adds is

* true Pareto fronts computed offline (:mod:`tmopt.problems.fronts`): pymoo downloads
  several of them (MW5, MW7, MW9-11, MW13, MW14, every DAS-CMOP) and has a wrong one for
  C3-DTLZ1, so ``pareto_front()`` here never calls pymoo's;
* the published default sizes, with ``n_var`` (and ``n_obj`` where the family scales)
  overridable from the configuration (``problem.n_var=10``);
* an optional grouping of the constraints (``constraint_groups="split"``), so that
  algorithms with individual-priority constraint handling (MGSAEA-IPC) can be run on
  benchmarks, which have no physical individuals (docs/benchmark-problems.md).
"""

from __future__ import annotations

import numpy as np
from pymoo.problems import get_problem

from tmopt.problems.base import ConstraintGroup
from tmopt.problems.fronts import dascmop as _dascmop
from tmopt.problems.fronts import front_sample, split_name
from tmopt.problems.lircmop import LIRCMOP
from tmopt.problems.pymoo_problem import PymooProblem

#: Problems whose front is offline here, with their default number of objectives.
SUITE_PROBLEMS: dict[str, int] = {
    **{f"mw{k}": (3 if k in (4, 8, 14) else 2) for k in range(1, 15)},
    **{name: 3 for name in ("c1dtlz1", "c1dtlz3", "c2dtlz2", "c3dtlz1", "c3dtlz4")},
    **{f"dascmop{k}": (2 if k <= 6 else 3) for k in range(1, 10)},
    **{f"lircmop{k}": (3 if k >= 13 else 2) for k in range(1, 15)},
}
#: Problems whose number of objectives can be chosen.
SCALABLE = {"mw4", "mw8", "mw14", "c1dtlz1", "c1dtlz3", "c2dtlz2", "c3dtlz1", "c3dtlz4"}
GROUPINGS = (None, "split")


def default_n_var(name: str, n_obj: int) -> int:
    """Published default number of variables.

    MW: D = 15 (Ma & Wang 2019). C-DTLZ: n = M + k - 1 with k = 5 for the DTLZ1-based and
    k = 10 for the others (Jain & Deb 2014, after Deb et al. 2005). DAS-CMOP: 30
    (Fan et al. 2020). LIR-CMOP: 30 (Fan et al. 2019).
    """
    family, which = split_name(name)
    if family == "mw":
        return max(15, n_obj + 1)
    if family in ("dascmop", "lircmop"):
        return 30
    return n_obj + (4 if str(which).endswith("dtlz1") else 9)


def _check_int(problem: str, label: str, value, minimum: int, hint: str = "") -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"problem {problem}: {label} must be an integer >= {minimum}{hint}, "
                         f"got {value!r}")
    return int(value)


def _resolve_n_obj(name: str, n_obj) -> int:
    default = SUITE_PROBLEMS[name]
    if n_obj is None:
        return default
    if name not in SCALABLE:
        if n_obj != default:
            raise ValueError(f"problem {name}: n_obj must be {default} (the problem is not "
                             f"scalable in objectives), got {n_obj!r}")
        return default
    return _check_int(name, "n_obj", n_obj, 2)


def _build_inner(name: str, n_var: int, n_obj: int, difficulty):
    family, which = split_name(name)
    if family == "lircmop":
        return LIRCMOP(which, n_var)
    if family == "dascmop":
        inner = get_problem(name, difficulty)
        # pymoo fixes n_var = 30 in the constructor; its distance functions read
        # self.n_var, and the paper defines the problems for any n >= M + 1.
        inner.n_var, inner.xl, inner.xu = n_var, np.zeros(n_var), np.ones(n_var)
        return inner
    if name in SCALABLE:
        return get_problem(name, n_var=n_var, n_obj=n_obj)
    return get_problem(name, n_var=n_var)


def grouped_constraints(n_constr: int, grouping: str | None) -> list[ConstraintGroup] | None:
    """Constraint groups for a benchmark: one group (None) or one per constraint ("split").

    "split": constraint i forms group ``g{i+1}`` with priority i, so the first constraint
    is the key individual and the others follow in index order.
    """
    if grouping is None or n_constr == 0:
        return None
    return [ConstraintGroup(f"g{i + 1}", (i,), i) for i in range(n_constr)]


class PymooBenchmark(PymooProblem):
    """A constrained suite problem (``mw1``..``mw14``, C-DTLZ, ``dascmop1``..``dascmop9``,
    ``lircmop1``..``lircmop14``).

    Args:
        name: Problem name, e.g. ``"mw3"``, ``"c2dtlz2"``, ``"dascmop7"``, ``"lircmop5"``.
        n_var: Number of variables (None: the published default, see
            :func:`default_n_var`); at least ``n_obj + 1`` (LIR-CMOP1-12: 5).
        n_obj: Number of objectives (None: 2 or 3 as published); only MW4, MW8, MW14 and
            the C-DTLZ problems accept other values (>= 2).
        difficulty: DAS-CMOP only: 1..16 (Fan et al. 2020, Table 2) or a triplet
            (eta, zeta, gamma) in [0, 1]; None means 8, i.e. (0.5, 0.5, 0.5).
        constraint_groups: None (one group holding every constraint) or ``"split"`` (one
            group per constraint, priority = index; see :func:`grouped_constraints`).
        front_points: Number of points sampled for the Pareto front (>= 10).
    """

    def __init__(self, name: str, *, n_var: int | None = None, n_obj: int | None = None,
                 difficulty: int | list[float] | None = None,
                 constraint_groups: str | None = None, front_points: int = 2000) -> None:
        key = str(name).lower()
        if key not in SUITE_PROBLEMS:
            raise ValueError(f"problem {name!r} is not a suite problem with an offline front; "
                             f"choose one of: {', '.join(SUITE_PROBLEMS)}")
        n_obj = _resolve_n_obj(key, n_obj)
        n_var = default_n_var(key, n_obj) if n_var is None else \
            _check_int(key, "n_var", n_var, n_obj + 1, f" (n_obj + 1 for n_obj={n_obj})")
        self.difficulty = self._checked_difficulty(key, difficulty)
        if constraint_groups not in GROUPINGS:
            raise ValueError(f"problem {key}: constraint_groups must be null or 'split', "
                             f"got {constraint_groups!r}")
        self.front_points = _check_int(key, "front_points", front_points, 10)
        self.grouping = constraint_groups
        inner = _build_inner(key, n_var, n_obj, self.difficulty)
        super().__init__(inner, name=key, constraint_groups=grouped_constraints(
            inner.n_ieq_constr, constraint_groups))

    @staticmethod
    def _checked_difficulty(key: str, difficulty):
        if not key.startswith("dascmop"):
            if difficulty is not None:
                raise ValueError(f"problem {key}: difficulty applies to DAS-CMOP only, "
                                 f"got {difficulty!r}")
            return None
        if difficulty is None:
            return 8
        try:
            _dascmop.triplet(difficulty)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"problem {key}: {exc}") from None
        return difficulty if isinstance(difficulty, (int, np.integer)) else tuple(difficulty)

    def _calc_pareto_front(self, *args, **kwargs) -> np.ndarray:
        """The offline front (tmopt.problems.fronts); pymoo's own is never called."""
        return front_sample(self.name, self.n_obj, self.front_points, self.difficulty).F

    def describe(self) -> dict:
        info = super().describe()
        info["constraint_grouping"] = self.grouping or "single"
        if self.difficulty is not None:
            info["difficulty"] = list(_dascmop.triplet(self.difficulty))
        return info
