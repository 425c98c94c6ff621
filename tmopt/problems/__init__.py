"""Problems an optimiser sees: vectorised pymoo problems with constraint groups.

``base`` (ExpensiveProblem, ConstraintGroup), ``suites`` (MW, C-DTLZ, DAS-CMOP with
offline fronts; imported on demand because it loads pymoo's problem collection),
``stiffness`` (the paper's problem on top of :mod:`tmopt.physics`), ``faulty`` (failures
on purpose, for the robustness tests), ``examples`` (the worked example of
docs/adding-a-problem.md). Budget, archive and failures: :mod:`tmopt.evaluation`.
"""

from tmopt.problems.base import ConstraintGroup, ExpensiveProblem

__all__ = ["ConstraintGroup", "ExpensiveProblem"]
