"""Problems an optimiser sees: vectorised pymoo problems with constraint groups.

``base`` (ExpensiveProblem, ConstraintGroup), ``evaluator`` (budget, archive, failures),
``suites`` (MW, C-DTLZ, DAS-CMOP with offline fronts; imported on demand because it loads
pymoo's problem collection), ``examples`` (the worked example of docs/adding-a-problem.md).
"""

from tmopt.problems.base import ConstraintGroup, ExpensiveProblem

__all__ = ["ConstraintGroup", "ExpensiveProblem"]
