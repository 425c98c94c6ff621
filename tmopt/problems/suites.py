"""Standard constrained benchmark suites, reusing pymoo's implementations."""

from __future__ import annotations

import numpy as np
from pymoo.problems import get_problem

from tmopt.problems.base import ExpensiveProblem


class PymooBenchmark(ExpensiveProblem):
    """A pymoo test problem (e.g. ``mw3``, ``c1dtlz1``) as an :class:`ExpensiveProblem`.

    Args:
        name: pymoo's problem name (see ``pymoo.problems.get_problem``).
        n_var: Number of variables (None: pymoo's default for that problem).
        n_obj: Number of objectives where the family is scalable (None: default).
    """

    def __init__(self, name: str, n_var: int | None = None, n_obj: int | None = None) -> None:
        kwargs = {k: v for k, v in (("n_var", n_var), ("n_obj", n_obj)) if v is not None}
        try:
            inner = get_problem(name, **kwargs)
        except Exception as exc:
            raise ValueError(f"problem {name}: pymoo cannot build it with {kwargs} ({exc})") \
                from exc
        self.inner = inner
        super().__init__(n_var=inner.n_var, n_obj=inner.n_obj, n_ieq_constr=inner.n_ieq_constr,
                         xl=inner.xl, xu=inner.xu, name=name)

    def _evaluate(self, X, out, *args, **kwargs):
        res = self.inner.evaluate(np.asarray(X, float), return_as_dictionary=True)
        out["F"] = res["F"]
        if self.n_ieq_constr:
            out["G"] = res["G"]

    def _calc_pareto_front(self, *args, **kwargs):
        return self.inner.pareto_front(*args, **kwargs)
