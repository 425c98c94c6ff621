"""Any pymoo :class:`~pymoo.core.problem.Problem` as a tmopt problem.

tmopt's runner and algorithms need what :class:`ExpensiveProblem` adds to a pymoo problem
(a name, constraint groups, objective and constraint labels); :func:`as_expensive` gives
it to a problem that does not have it, so ``run_optimisation(get_problem("mw3"), ...)``
and ``minimize(my_pymoo_problem, MGSAEAIPC(), ...)`` work on any pymoo problem,
vectorised or elementwise.

Equality constraints ``h(x) = 0`` become inequality constraints ``|h(x)| - eps <= 0``
with pymoo's own tolerance (``eps = 1e-4``, the ``cv_eq`` default of
``pymoo.core.individual``), so a design is feasible here exactly when pymoo calls it
feasible.
"""

from __future__ import annotations

import numpy as np
from pymoo.core.problem import Problem

from tmopt.problems.base import ConstraintGroup, ExpensiveProblem

#: pymoo's tolerance on equality constraints (``cv_eq`` eps in pymoo.core.individual).
EQUALITY_TOLERANCE = 1e-4


class PymooProblem(ExpensiveProblem):
    """Wrap the pymoo problem ``inner``; its objectives, constraints and front are its own.

    Args:
        inner: Any pymoo problem with finite bounds ``xl < xu``.
        name: Name in messages, archives and tables (default: the class name, lower case).
        constraint_groups: As :class:`ExpensiveProblem` (default: one group of all).
    """

    def __init__(self, inner: Problem, name: str | None = None,
                 constraint_groups: list[ConstraintGroup] | None = None) -> None:
        if inner.xl is None or inner.xu is None:
            raise ValueError(f"problem {type(inner).__name__}: tmopt needs finite bounds "
                             "xl and xu on every variable, got none")
        self.inner = inner
        self.n_eq = int(getattr(inner, "n_eq_constr", 0))
        n_ieq = int(inner.n_ieq_constr)
        names = [f"g{i + 1}" for i in range(n_ieq)] + [f"h{i + 1}" for i in range(self.n_eq)]
        super().__init__(n_var=int(inner.n_var), n_obj=int(inner.n_obj),
                         n_ieq_constr=n_ieq + self.n_eq, xl=inner.xl, xu=inner.xu,
                         name=name or type(inner).__name__.lower(),
                         constraint_groups=constraint_groups, constraint_names=names)

    def _evaluate(self, X, out, *args, **kwargs):
        res = self.inner.evaluate(np.asarray(X, float), return_as_dictionary=True)
        out["F"] = res["F"]
        if self.n_ieq_constr:
            G = np.reshape(res.get("G", np.zeros((len(X), 0))), (len(X), -1))
            H = np.reshape(res.get("H", np.zeros((len(X), 0))), (len(X), -1))
            out["G"] = np.hstack([G, np.abs(H) - EQUALITY_TOLERANCE])

    def _calc_pareto_front(self, *args, **kwargs):
        return self.inner.pareto_front(*args, **kwargs)


def as_expensive(problem: Problem) -> ExpensiveProblem:
    """``problem`` itself if it is an :class:`ExpensiveProblem`, else wrapped in
    :class:`PymooProblem`; anything else is a one-line :class:`TypeError`."""
    if isinstance(problem, ExpensiveProblem):
        return problem
    if isinstance(problem, Problem):
        return PymooProblem(problem)
    raise TypeError(f"problem must be a pymoo Problem (or a tmopt ExpensiveProblem), got "
                    f"{type(problem).__name__}")
