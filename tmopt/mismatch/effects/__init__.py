"""The catalogue of physical effects the nominal model leaves out: one module per effect,
holding how it is injected into a simulation and how it enters the diagnosis.

The registry below is the one list of effects that the generator, the diagnosis, the
report, the tests and the experiments read; it is found by :func:`base.discover` from the
modules of this package, so adding an effect = adding one module (see
:mod:`tmopt.mismatch.effects.base` for what it must define).
"""

from __future__ import annotations

from tmopt.mismatch.effects.base import (
    Builder,
    Calibration,
    Candidate,
    Context,
    Effect,
    Injection,
    discover,
)

__all__ = ["CATALOGUE", "EFFECTS", "EFFECT_NAMES", "effect", "Builder", "Calibration",
           "Candidate", "Context", "Effect", "Injection"]  # fmt: skip

#: Every effect, in catalogue order.
CATALOGUE: tuple[Effect, ...] = discover(__name__, __path__)
#: The same effects by name.
EFFECTS: dict[str, Effect] = {e.name: e for e in CATALOGUE}
EFFECT_NAMES: tuple[str, ...] = tuple(EFFECTS)


def effect(name: str) -> Effect:
    """The registered effect called ``name`` (ValueError naming the choices otherwise)."""
    if name not in EFFECTS:
        raise ValueError(f"unknown effect {name!r}; choose from {list(EFFECT_NAMES)}")
    return EFFECTS[name]
