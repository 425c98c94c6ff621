"""Base class for expensive constrained multi-objective problems.

An :class:`ExpensiveProblem` is a pymoo :class:`~pymoo.core.problem.Problem` (vectorised:
``X (n, n_var) -> F (n, n_obj), G (n, n_constr)``, ``G <= 0`` feasible) that also declares
*constraint groups* with a priority. A group collects the constraints that belong to one
individual of the physical system (e.g. one test mass); the group(s) with the smallest
priority number are the *key individual constraints* that MGSAEA-IPC satisfies first
(paper Sec. 3.2.2). Problems without a natural grouping get one group holding every
constraint.

Budget counting, archiving and failure handling live in :mod:`tmopt.evaluation.evaluator`,
so a problem only has to compute its objectives.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from pymoo.core.problem import Problem


@dataclass(frozen=True)
class ConstraintGroup:
    """Constraints that belong to one individual (e.g. one test mass).

    Attributes:
        name: Human-readable name, e.g. ``"TM1"``.
        indices: Column indices into ``G``.
        priority: 0 is the most important (the key individual); larger numbers later.
    """

    name: str
    indices: tuple[int, ...]
    priority: int = 0


class ExpensiveProblem(Problem):
    """A pymoo problem with named constraint groups and input validation.

    Args:
        n_var: Number of decision variables (>= 1).
        n_obj: Number of objectives (>= 1).
        n_ieq_constr: Number of inequality constraints ``G <= 0``.
        xl, xu: Lower and upper bounds, scalars or arrays of length ``n_var``, ``xl < xu``.
        name: Problem name used in messages, archives and tables.
        constraint_groups: Optional grouping of the constraint columns; every column must
            appear in exactly one group. Default: one group ``"all"`` with priority 0.
        objective_names, constraint_names: Optional labels for tables and plots.
    """

    def __init__(
        self,
        n_var: int,
        n_obj: int,
        n_ieq_constr: int = 0,
        xl: float | Sequence[float] | np.ndarray = 0.0,
        xu: float | Sequence[float] | np.ndarray = 1.0,
        name: str | None = None,
        constraint_groups: Sequence[ConstraintGroup] | None = None,
        objective_names: Sequence[str] | None = None,
        constraint_names: Sequence[str] | None = None,
        **kwargs,
    ) -> None:
        self.name = name or type(self).__name__
        _require_int(self.name, "n_var", n_var, 1)
        _require_int(self.name, "n_obj", n_obj, 1)
        _require_int(self.name, "n_ieq_constr", n_ieq_constr, 0)
        xl_arr, xu_arr = _validated_bounds(self.name, n_var, xl, xu)
        super().__init__(n_var=n_var, n_obj=n_obj, n_ieq_constr=n_ieq_constr,
                         xl=xl_arr, xu=xu_arr, vtype=float, **kwargs)
        self.constraint_groups = _validated_groups(self.name, n_ieq_constr, constraint_groups)
        self.objective_names = list(objective_names or [f"f{i + 1}" for i in range(n_obj)])
        self.constraint_names = list(constraint_names or [f"g{i + 1}" for i in range(n_ieq_constr)])
        if len(self.objective_names) != n_obj:
            raise ValueError(f"problem {self.name}: objective_names has "
                             f"{len(self.objective_names)} entries, expected n_obj={n_obj}")
        if len(self.constraint_names) != n_ieq_constr:
            raise ValueError(f"problem {self.name}: constraint_names has "
                             f"{len(self.constraint_names)} entries, expected {n_ieq_constr}")

    # ---- constraint groups ---------------------------------------------------------
    @property
    def has_declared_groups(self) -> bool:
        """True when the problem declares more than one constraint group."""
        return len(self.constraint_groups) > 1

    def key_constraint_indices(self) -> np.ndarray:
        """Columns of ``G`` in the group(s) with the smallest priority number."""
        if not self.constraint_groups:
            return np.zeros(0, dtype=int)
        top = min(g.priority for g in self.constraint_groups)
        return np.array(sorted(i for g in self.constraint_groups if g.priority == top
                               for i in g.indices), dtype=int)

    # ---- what every benchmark can offer ----------------------------------------------
    def pareto_front(self, *args, **kwargs) -> np.ndarray | None:  # noqa: D401
        """The true Pareto front if known (rows of objective vectors), else None."""
        return super().pareto_front(*args, **kwargs)

    def describe(self) -> dict:
        """Plain-dict summary for run folders and tables."""
        return {
            "name": self.name,
            "n_var": int(self.n_var),
            "n_obj": int(self.n_obj),
            "n_constr": int(self.n_ieq_constr),
            "objectives": self.objective_names,
            "constraints": self.constraint_names,
            "constraint_groups": [
                {"name": g.name, "indices": list(g.indices), "priority": g.priority}
                for g in self.constraint_groups
            ],
        }


def _require_int(problem: str, name: str, value, minimum: int) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"problem {problem}: {name} must be an integer >= {minimum}, "
                         f"got {value!r}")


def _validated_bounds(problem: str, n_var: int, xl, xu) -> tuple[np.ndarray, np.ndarray]:
    xl_arr = np.broadcast_to(np.asarray(xl, dtype=float), (n_var,)).copy() \
        if np.ndim(xl) == 0 else np.asarray(xl, dtype=float)
    xu_arr = np.broadcast_to(np.asarray(xu, dtype=float), (n_var,)).copy() \
        if np.ndim(xu) == 0 else np.asarray(xu, dtype=float)
    for label, arr in (("xl", xl_arr), ("xu", xu_arr)):
        if arr.shape != (n_var,):
            raise ValueError(f"problem {problem}: {label} has shape {arr.shape}, "
                             f"expected ({n_var},) for n_var={n_var}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"problem {problem}: {label} must be finite, got {arr.tolist()}")
    bad = np.flatnonzero(xl_arr >= xu_arr)
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"problem {problem}: lower bound must be < upper bound for every "
                         f"variable; variable {i} has xl={float(xl_arr[i])!r} >= "
                         f"xu={float(xu_arr[i])!r}")
    return xl_arr, xu_arr


def _validated_groups(problem: str, n_constr: int,
                      groups: Sequence[ConstraintGroup] | None) -> tuple[ConstraintGroup, ...]:
    if n_constr == 0:
        return ()
    if not groups:
        return (ConstraintGroup("all", tuple(range(n_constr)), 0),)
    seen: list[int] = [i for g in groups for i in g.indices]
    if sorted(seen) != list(range(n_constr)):
        raise ValueError(f"problem {problem}: constraint_groups must cover each of the "
                         f"{n_constr} constraint columns exactly once, got indices {sorted(seen)}")
    return tuple(groups)
