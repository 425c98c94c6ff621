"""Operators shared by the evolutionary and surrogate-assisted algorithms, on plain arrays.

``constraints`` (constrained dominance, CDP sorting, MGSAEA's granularity), ``survival``
(SPEA2 and NSGA-II environmental selection), ``variation`` (tournaments, GA and DE
children) and ``stage`` (the stage switch of Eq. 20). The total constraint violation is
:func:`tmopt.metrics.indicators.constraint_violation`; argument checks are in
:mod:`tmopt.algorithms.base`.
"""
