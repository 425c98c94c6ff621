"""tmopt: expensive constrained multi-objective optimisation with surrogate models.

Flagship problem: on-orbit identification of test-mass stiffness in space
gravitational-wave detectors (Tang et al., Aerospace 12(8), 673, 2025).
"""

__version__ = "0.1.0"
