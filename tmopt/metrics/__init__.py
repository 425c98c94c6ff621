"""Performance indicators, solution-choice rules and the paper's metric M (Eq. 29)."""

from tmopt.metrics.identification import metric_m, metric_m_at_threshold
from tmopt.metrics.indicators import (
    constraint_violation,
    feasible_ratio,
    hypervolume,
    igd,
    igd_plus,
    non_dominated_feasible,
)
from tmopt.metrics.selection import best_compromise

__all__ = ["best_compromise", "constraint_violation", "feasible_ratio", "hypervolume", "igd",
           "igd_plus", "metric_m", "metric_m_at_threshold", "non_dominated_feasible"]
