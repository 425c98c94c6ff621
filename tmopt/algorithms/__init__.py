"""Optimisers, one file each, with setup/ask/tell steps.

Every algorithm is importable from here (loaded on first use, so that importing one does
not load the others' libraries) and is also a pymoo algorithm
(:mod:`tmopt.algorithms.as_pymoo`)::

    from pymoo.optimize import minimize
    from pymoo.problems import get_problem
    from tmopt.algorithms import MGSAEAIPC

    res = minimize(get_problem("mw3"), MGSAEAIPC(), ("n_evals", 300), seed=1)
"""

from __future__ import annotations

from importlib import import_module

#: Public name -> module under tmopt.algorithms.
_WHERE = {
    "Algorithm": "base", "AlgorithmConfigError": "base",
    "MGSAEA": "mgsaea", "MGSAEAIPC": "mgsaea", "MGSAEAStar": "mgsaea",
    "NSGA2": "nsga2", "NSGA3": "nsga3", "CMOEAD": "cmoead", "CTSEA": "ctsea",
    "SSDE": "ssde", "CMOES": "cmoes", "QLogNEHVI": "qlognehvi",
    "PymooAdapter": "pymoo_adapter", "WrappedPymooAlgorithm": "pymoo_adapter",
}  # fmt: skip
__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name in _WHERE:
        return getattr(import_module(f"tmopt.algorithms.{_WHERE[name]}"), name)
    raise AttributeError(f"module 'tmopt.algorithms' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
