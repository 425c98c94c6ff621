"""Performance indicators and solution-choice rules."""

from tmopt.metrics.indicators import (
    feasible_ratio,
    hypervolume,
    igd,
    igd_plus,
    non_dominated_feasible,
)
from tmopt.metrics.selection import best_compromise

__all__ = ["best_compromise", "feasible_ratio", "hypervolume", "igd", "igd_plus",
           "non_dominated_feasible"]
