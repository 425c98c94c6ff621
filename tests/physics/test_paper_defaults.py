"""Each paper default of the evaluation is written once (issue 21: one home per idea).

The run settings of Sec. 4.1 (1200 s at 10 Hz), Eq. 18's threshold (Sec. 4.3), Eq. 29's
weights (Sec. 4.4) and the design's period bounds live in one place each; every signature,
dataclass field and module constant elsewhere names that place. The scan below reads the
*definitions* of tmopt/ (argument defaults, class fields, module constants) and fails when
one of these values is written again as a literal outside its home.
"""

from __future__ import annotations

import ast
import inspect
import operator
from pathlib import Path

import pytest

from tmopt.physics import excitation, objectives
from tmopt.physics.control import PAPER_RATE
from tmopt.physics.scenario import Settings
from tmopt.physics.simulator import SimulationConfig
from tmopt.problems.stiffness import StiffnessProblem
from tmopt.run.config import constructor_node

PACKAGE = Path(__file__).resolve().parents[2] / "tmopt"

#: Argument / field names whose paper value may be written only in its home.
BY_NAME = {"duration": 1200.0, "sample_rate": 10.0, "fs": 10.0, "eps": 1e-10,
           "epsilon": 1e-10}  # fmt: skip
#: Values distinctive enough to be the paper's default under any name.
BY_VALUE = [(1 / 60, 1e10), (60.0, 1200.0), 1 / 60, 1e10]
#: (file relative to tmopt/, name defined there) of each value's one home.
HOMES = {
    ("physics/control.py", "PAPER_RATE"),
    ("physics/simulator.py", "duration"),  # SimulationConfig.duration
    ("physics/objectives.py", "EPSILON"),
    ("physics/objectives.py", "M_WEIGHTS"),
    ("physics/excitation.py", "PERIOD_BOUNDS"),
}

_OPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
        ast.Div: operator.truediv, ast.Pow: operator.pow}  # fmt: skip


def _value(node: ast.AST):
    """The number or tuple of numbers ``node`` writes literally (``1 / 60`` included);
    None for anything that names something."""
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) \
            and not isinstance(node.value, bool):
        return float(node.value)
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        v = _value(node.operand)
        return None if v is None or isinstance(v, tuple) else -v
    if isinstance(node, ast.BinOp) and type(node.op) in _OPS:
        a, b = _value(node.left), _value(node.right)
        if isinstance(a, float) and isinstance(b, float):
            return _OPS[type(node.op)](a, b)
        return None
    if isinstance(node, (ast.Tuple, ast.List)):
        vals = [_value(e) for e in node.elts]
        return tuple(vals) if all(isinstance(v, float) for v in vals) else None
    return None


def _definitions(tree: ast.AST):
    """(name, value node, line) of every argument default, class field and module constant."""
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            a = node.args
            positional = a.posonlyargs + a.args
            yield from ((arg.arg, d, d.lineno) for arg, d in
                        zip(positional[len(positional) - len(a.defaults):], a.defaults))
            yield from ((arg.arg, d, d.lineno) for arg, d in zip(a.kwonlyargs, a.kw_defaults)
                        if d is not None)
        elif isinstance(node, (ast.Module, ast.ClassDef)):
            for stmt in node.body:
                if isinstance(stmt, ast.AnnAssign) and stmt.value is not None \
                        and isinstance(stmt.target, ast.Name):
                    yield stmt.target.id, stmt.value, stmt.lineno
                elif isinstance(stmt, ast.Assign):
                    for target in stmt.targets:
                        if isinstance(target, ast.Name):
                            yield target.id, stmt.value, stmt.lineno


def _close(a, b) -> bool:
    if isinstance(a, tuple) or isinstance(b, tuple):
        return isinstance(a, tuple) and isinstance(b, tuple) and len(a) == len(b) \
            and all(_close(x, y) for x, y in zip(a, b))
    return abs(a - b) <= 1e-12 * max(abs(a), abs(b))


def repeated_paper_defaults(source: str, where: str) -> list[str]:
    """``where:line name=value`` for each paper default ``source`` writes outside its home."""
    found = []
    for name, node, line in _definitions(ast.parse(source)):
        value = _value(node)
        if value is None or (where, name) in HOMES:
            continue
        by_name = name in BY_NAME and _close(value, BY_NAME[name])
        if by_name or any(_close(value, v) for v in BY_VALUE):
            found.append(f"{where}:{line} {name}={ast.unparse(node)}")
    return found


def test_each_paper_default_is_written_once_in_tmopt():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        found += repeated_paper_defaults(path.read_text(), path.relative_to(PACKAGE).as_posix())
    assert not found, "name the home instead:\n" + "\n".join(found)


@pytest.mark.parametrize("source", [
    "def f(x, duration: float = 1200.0): ...",
    "def f(*, sample_rate=10): ...",
    "def f(eps=1e-10): ...",
    "def f(weights=(1 / 60, 1e10)): ...",
    "class C:\n    epsilon: float = 1e-10\n",
    "W1 = 1.0 / 60.0\n",
    "PERIODS = (60, 1200)\n",
    "f = lambda fs=10.0: fs\n",
])
def test_the_scan_finds_a_second_definition(source):
    assert repeated_paper_defaults(source, "physics/other.py")


@pytest.mark.parametrize("source", [
    "def f(duration: float = SimulationConfig.duration): ...",
    "def f(gain_bounds=(0.0, 10.0), bias=(1e-10, 1e-10), sample_rate=20.0): ...",
    "def f(duration=60.0): ...",
])
def test_the_scan_leaves_other_ideas_and_named_homes_alone(source):
    assert repeated_paper_defaults(source, "physics/other.py") == []


def test_the_homes_hold_the_paper_values():
    assert SimulationConfig.duration == 1200.0 and PAPER_RATE == 10.0  # Sec. 4.1
    assert SimulationConfig.sample_rate == PAPER_RATE
    assert objectives.EPSILON == 1e-10  # Sec. 4.3
    assert objectives.M_WEIGHTS == (1 / 60, 1e10)  # Eq. 29, Sec. 4.4
    assert excitation.PERIOD_BOUNDS == (60.0, SimulationConfig.duration)
    for path in sorted(PACKAGE.rglob("*.py")):  # every home is where HOMES says
        rel = path.relative_to(PACKAGE).as_posix()
        names = {n for n, _, _ in _definitions(ast.parse(path.read_text()))}
        assert all(name in names for where, name in HOMES if where == rel), rel


def test_users_show_the_values_of_the_homes():
    # the constructor's node (what the YAML shows and the config hash reads) keeps the numbers
    node = constructor_node("tmopt.problems.stiffness.StiffnessProblem")
    assert node["duration"] == 1200.0 and node["sample_rate"] == 10.0
    assert node["epsilon"] == 1e-10 and list(node["m_weights"]) == [1 / 60, 1e10]
    assert list(node["period_bounds"]) == [60.0, 1200.0]
    params = inspect.signature(StiffnessProblem.__init__).parameters
    assert params["m_weights"].default is objectives.M_WEIGHTS
    settings = Settings()
    assert (settings.duration, settings.sample_rate) == (1200.0, 10.0)
    assert settings.stiffness == (1e-7,) * 4 and settings.bias == (1e-10,) * 4
