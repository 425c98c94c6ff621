"""A worked example of a user problem (docs/adding-a-problem.md): Binh & Korn's BNH.

T. T. Binh and U. Korn, "MOBES: A multiobjective evolution strategy for constrained
optimization problems", Proc. 3rd Int. Conf. on Genetic Algorithms (Mendel 97), 1997:

    minimise  f1 = 4 x1^2 + 4 x2^2,   f2 = (x1 - 5)^2 + (x2 - 5)^2
    s.t.      g1 = (x1 - 5)^2 + x2^2 - 25 <= 0
              g2 = 7.7 - (x1 - 8)^2 - (x2 + 3)^2 <= 0,   x1 in [0, 5], x2 in [0, 3].

Its Pareto set is x1 = x2 in [0, 3] followed by x2 = 3, x1 in [3, 5]: the constraints
hold there (g1 = 0 only at x = (0, 0)), so the front follows from the objectives in closed
form (Deb,
"Multi-objective optimization using evolutionary algorithms", Wiley 2001, Sec. 14.1.1).
The two constraints are put in two groups only to show how groups are declared.
"""

from __future__ import annotations

import numpy as np

from tmopt.problems.base import ConstraintGroup, ExpensiveProblem


class BinhKorn(ExpensiveProblem):
    """BNH: two objectives, two constraints, two variables (see the module docstring).

    Args:
        front_points: Points of the analytic Pareto front returned by ``pareto_front()``.
        grouped: Put g1 and g2 in separate constraint groups (g1 first) instead of one.
    """

    def __init__(self, *, front_points: int = 500, grouped: bool = True) -> None:
        if isinstance(front_points, bool) or not isinstance(front_points, int) \
                or front_points < 2:
            raise ValueError(f"problem bnh: front_points must be an integer >= 2, "
                             f"got {front_points!r}")
        self.front_points = front_points
        groups = [ConstraintGroup("circle", (0,), 0), ConstraintGroup("keep-out", (1,), 1)] \
            if grouped else None
        super().__init__(n_var=2, n_obj=2, n_ieq_constr=2, xl=[0.0, 0.0], xu=[5.0, 3.0],
                         name="bnh", constraint_groups=groups,
                         constraint_names=["circle", "keep-out"])

    def _evaluate(self, X, out, *args, **kwargs):
        x1, x2 = X[:, 0], X[:, 1]  # X: (n, 2), one row per design
        out["F"] = np.column_stack([4 * x1 ** 2 + 4 * x2 ** 2, (x1 - 5) ** 2 + (x2 - 5) ** 2])
        out["G"] = np.column_stack([(x1 - 5) ** 2 + x2 ** 2 - 25,
                                    7.7 - (x1 - 8) ** 2 - (x2 + 3) ** 2])

    def pareto_set(self, n: int | None = None) -> np.ndarray:
        """Designs on the Pareto set, spread evenly in x1 over [0, 5]."""
        x1 = np.linspace(0.0, 5.0, n or self.front_points)
        return np.column_stack([x1, np.minimum(x1, 3.0)])

    def _calc_pareto_front(self, *args, **kwargs) -> np.ndarray:
        return self.evaluate(self.pareto_set(), return_as_dictionary=True)["F"]
