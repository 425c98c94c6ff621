"""The house (docs/decisions.md, "The house"): imports point down the layers only."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "tmopt"
#: Bottom to top. A module may import its own package and the layers below its own.
LAYERS = [
    {"files", "conf"},  # conf: the Hydra configuration (package data, no code)
    {"physics"},
    {"surrogates", "metrics"},
    {"problems", "mismatch"},
    {"evaluation"},
    {"algorithms"},
    {"run"},
    # next excitation from a diagnosis: a problem built from mismatch's output, solved by
    # any algorithm of the registry through the runner
    {"design"},
    {"reporting"},
    {"__main__", "collect", "simulate"},  # entry modules that keep the commands' names
]
LEVEL = {name: i for i, layer in enumerate(LAYERS) for name in layer}
#: The upward imports the house allows, each with its reason (docs/decisions.md).
UPWARD_ALLOWED = {
    # pymoo's minimize makes the algorithm object run itself; it must run through the
    # command line's runner to give the same archive (tmopt.algorithms.as_pymoo)
    ("algorithms/as_pymoo.py", "run"),
}


def _imports(path: Path) -> set[str]:
    """Top-level tmopt packages that ``path`` imports (``tmopt.X...`` -> ``X``)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        names = [node.module] if isinstance(node, ast.ImportFrom) and node.module and \
            node.level == 0 else [a.name for a in node.names] if isinstance(node, ast.Import) \
            else []
        found.update(n.split(".")[1] for n in names if n.startswith("tmopt.") and "." in n)
    return found


def _package(path: Path) -> str:
    """The layer name of a module: its top-level package; a package's ``__main__`` (the
    command ``python -m tmopt.X``) is an entry module like ``tmopt/__main__.py``."""
    parts = path.relative_to(PACKAGE).parts
    if len(parts) > 1 and parts[-1] == "__main__.py":
        return "__main__"
    return parts[0].removesuffix(".py")


def test_every_package_has_a_layer():
    packages = {_package(p) for p in PACKAGE.rglob("*.py")} - {"__init__"}
    assert packages <= set(LEVEL), f"place {sorted(packages - set(LEVEL))} in LAYERS"


def test_imports_point_down_the_layers_only():
    upward = []
    for path in sorted(PACKAGE.rglob("*.py")):
        me = _package(path)
        if me == "__init__":
            continue
        for other in _imports(path) - {me}:
            allowed = (path.relative_to(PACKAGE).as_posix(), other) in UPWARD_ALLOWED
            if LEVEL.get(other, len(LAYERS)) >= LEVEL[me] and not allowed:
                upward.append(f"{path.relative_to(PACKAGE.parent)} imports tmopt.{other}")
    assert not upward, "\n".join(upward)
