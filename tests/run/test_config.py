"""One source of truth per default: option files start from their constructor's node."""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import pytest
from hydra.utils import get_class
from omegaconf import OmegaConf

from tmopt.algorithms.mgsaea import MGSAEA, MGSAEAIPC
from tmopt.run.cli import CONF_DIR, option_config, preflight
from tmopt.run.config import (
    CONSTRUCTOR_GROUP,
    ConfigError,
    check_node,
    constructor_node,
    constructor_parameters,
    constructor_targets,
    register_configs,
)

PACKAGE = Path(__file__).resolve().parents[2] / "tmopt"
OPTION_FILES = sorted(p for group in ("problem", "algorithm", "surrogate")
                      for p in (CONF_DIR / group).glob("*.yaml"))
#: Arguments whose default value other signatures repeat for a reason of their own:
#: ``seed`` 0 is "the first seed" everywhere. (The paper's run settings -- duration, sample
#: rate, Eq. 18's threshold, Eq. 29's weights -- have one home each in tmopt.physics, which
#: every signature names: tests/physics/test_paper_defaults.py.)
OTHER_IDEAS = {"seed"}


def _signature_defaults() -> list[tuple[str, int, str, object]]:
    """(file, line, argument, literal default) of every function in tmopt/."""
    found = []
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            a = node.args
            positional = a.posonlyargs + a.args
            pairs = list(zip(positional[len(positional) - len(a.defaults):], a.defaults))
            pairs += [(k, d) for k, d in zip(a.kwonlyargs, a.kw_defaults) if d is not None]
            for arg, default in pairs:
                try:
                    value = ast.literal_eval(default)
                except ValueError:
                    continue
                found.append((str(path), node.lineno, arg.arg, value))
    return found


def _same(a, b) -> bool:
    if isinstance(a, (tuple, list)) and isinstance(b, (tuple, list)):
        return list(a) == list(b)
    return type(a) is type(b) and a == b


def test_every_option_file_starts_from_its_constructor():
    assert len(OPTION_FILES) > 40
    for path in OPTION_FILES:
        defaults = OmegaConf.load(path).get("defaults") or []
        assert any(str(e).startswith(f"/{CONSTRUCTOR_GROUP}/") for e in defaults), path
        assert "_target_" not in OmegaConf.load(path), path  # the constructor node names it


def test_option_files_set_only_what_differs_from_the_constructor():
    for path in OPTION_FILES:
        raw = OmegaConf.to_container(OmegaConf.load(path), resolve=False)
        node = option_config(path.parent.name, path.stem)
        params = constructor_parameters(get_class(node._target_))
        for key, value in raw.items():
            if key == "defaults" or (isinstance(value, str) and "${" in value):
                continue
            default = params[key].default
            assert default is inspect.Parameter.empty or not _same(default, value), \
                f"{path}: {key}={value!r} repeats the constructor's default"


def test_each_default_is_written_in_one_signature():
    # The constructors of the configured classes own their defaults; no other function
    # (an operator, an inner class, a base class) repeats one for the same argument.
    owners = {}
    for target in constructor_targets(CONF_DIR):
        cls = get_class(target)
        for klass in cls.__mro__:
            init = vars(klass).get("__init__")
            if init is not None and klass.__module__.startswith("tmopt."):
                owners[(inspect.getsourcefile(init), init.__code__.co_firstlineno)] = target
    signatures = _signature_defaults()
    repeated = []
    for target in constructor_targets(CONF_DIR):
        for name, param in constructor_parameters(get_class(target)).items():
            default = param.default
            if name in OTHER_IDEAS or default is param.empty or default is None \
                    or isinstance(default, bool):
                continue
            for path, line, arg, value in signatures:
                own = any(path == f and 0 <= line - first <= 1 for f, first in owners)
                if arg == name and _same(value, default) and not own:
                    repeated.append(f"{target}.{name}={default!r} also in {path}:{line}")
    assert not repeated, "\n".join(repeated)


def test_a_variant_takes_its_base_arguments_once_and_they_are_checked():
    own = constructor_parameters(MGSAEAIPC)
    assert list(own)[0] == "ungrouped" and set(constructor_parameters(MGSAEA)) < set(own)
    assert constructor_node("tmopt.algorithms.mgsaea.MGSAEAIPC")["wmax"] == \
        inspect.signature(MGSAEA.__init__).parameters["wmax"].default
    assert "surrogate" not in constructor_node("tmopt.algorithms.mgsaea.MGSAEAIPC")
    node = OmegaConf.create({"_target_": "tmopt.algorithms.mgsaea.MGSAEAIPC", "wmax": "ten"})
    with pytest.raises(ConfigError, match="algorithm.wmax='ten' has the wrong type"):
        check_node("algorithm", node, "mgsaea_ipc")
    node = OmegaConf.create({"_target_": "tmopt.algorithms.mgsaea.MGSAEAIPC", "wmx": 10})
    with pytest.raises(ConfigError, match=r"unknown key algorithm.wmx; did you mean 'wmax'\? "
                                          "allowed keys: ungrouped"):
        check_node("algorithm", node, "mgsaea_ipc")
    with pytest.raises(TypeError):
        MGSAEAIPC(100)  # keyword arguments only


def test_arguments_left_to_the_constructor_can_be_overridden_and_are_composed():
    assert preflight(["algorithm=mgsaea_ipc", "algorithm.wmax=10", "surrogate=rbf",
                      "surrogate.ridge=1e-6", "problem=mw3", "problem.front_points=500"]) == 1
    node = option_config("algorithm", "nsga2")
    assert node.crossover_eta == inspect.signature(
        get_class(node._target_).__init__).parameters["crossover_eta"].default


def test_a_required_argument_left_unset_is_one_line():
    node = OmegaConf.create(constructor_node("tmopt.problems.suites.PymooBenchmark"))
    with pytest.raises(ConfigError, match="problem=x: problem.name must be set"):
        check_node("problem", node, "x")


def test_an_option_whose_class_cannot_be_imported_breaks_only_itself(tmp_path):
    (tmp_path / "algorithm").mkdir()
    (tmp_path / "algorithm" / "broken.yaml").write_text(
        f"defaults:\n  - /{CONSTRUCTOR_GROUP}/tmopt.algorithms.nope.Nope@_here_\n  - _self_\n")
    assert constructor_targets(tmp_path) == ["tmopt.algorithms.nope.Nope"]
    with pytest.raises(ConfigError, match="cannot import the class"):
        constructor_node("tmopt.algorithms.nope.Nope")
    register_configs(tmp_path)  # no error at start-up: check_node names it when chosen
    assert preflight(["algorithm=nsga2", "problem=mw3", "budget=300"]) == 1


def test_sweep_name_is_given_or_derived_from_the_overrides():
    from tmopt.run.config import sweep_name

    assert sweep_name("mine", ["seed=0,1"]) == "mine"
    assert sweep_name("", []) == "default"
    derived = sweep_name("", ["seed=0,1,2", "problem=mw3", "problem.n_var=4",
                              "algorithm=nsga2,nsga3", "progress=false", "hydra/launcher=x"])
    assert derived == "algorithm=nsga2+nsga3_problem=mw3_seed=0+1+2_problem.n_var=4"
    assert derived == sweep_name("", ["algorithm=nsga2,nsga3", "problem.n_var=4",
                                      "problem=mw3", "seed=0,1,2"])  # spelling order
    long = sweep_name("", [f"problem.x{i}={i}" for i in range(40)])
    assert len(long) == 120 and long != sweep_name("", [f"problem.x{i}={i}" for i in range(41)])


def test_an_option_file_changed_between_two_commands_is_read_again(tmp_path):
    """constructor_targets memoises each file's targets on its stamp (mtime, size): a
    user who edits an option file in a long-lived process (the Python API) sees the edit."""
    option = tmp_path / "algorithm" / "mine.yaml"
    option.parent.mkdir()
    option.write_text("defaults:\n  - /constructor/tmopt.algorithms.nsga2.NSGA2\n")
    assert constructor_targets(tmp_path) == ["tmopt.algorithms.nsga2.NSGA2"]
    option.write_text("defaults:\n  - /constructor/tmopt.algorithms.mgsaea.MGSAEA\n  - _self_\n")
    assert constructor_targets(tmp_path) == ["tmopt.algorithms.mgsaea.MGSAEA"]
