"""Test-mass dynamics, control and stiffness identification (Tang et al., Aerospace 2025)."""

from tmopt.physics.control import ControllerSettings
from tmopt.physics.excitation import MultiSine
from tmopt.physics.geometry import Geometry
from tmopt.physics.objectives import evaluate
from tmopt.physics.simulator import SimulationConfig, SimulationResult, simulate

__all__ = [
    "ControllerSettings",
    "Geometry",
    "MultiSine",
    "SimulationConfig",
    "SimulationResult",
    "evaluate",
    "simulate",
]
