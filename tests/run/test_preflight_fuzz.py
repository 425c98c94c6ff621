"""Checks before the first real evaluation (issue 20 part 3), proven by a generator.

The bad configurations are generated, not listed: every option of every config group is
composed as a run would compose it, and for every one of its parameters values that no
parameter may take are derived from the parameter's type (NaN, inf, an integer beyond
int64, a value of the wrong type, a choice that does not exist, a misspelt key), plus the
run settings and the group names themselves. Every one must be refused by pre-flight in
one line that names the parameter, with no traceback and nothing evaluated.
"""

from __future__ import annotations

import inspect
import os
import random
import subprocess
import sys
import types
import typing
from pathlib import Path

import pytest
from hydra.utils import get_class
from omegaconf import ListConfig
from pymoo.core.problem import Problem

from tmopt.run import cli
from tmopt.run.config import ConfigError, _type_hints

REPO = Path(__file__).resolve().parents[2]
#: A cheap problem for the algorithm and surrogate cases (the stiffness problem is
#: covered by its own cases).
CHEAP = ["problem=mw1"]
#: Free labels: any string is valid.
LABELS = {"name"}


def _admits(hint, kind: type) -> bool:
    """Whether a type hint admits values of ``kind`` (unknown hints admit everything)."""
    if hint is None or hint is typing.Any or hint is inspect.Parameter.empty:
        return True
    args = typing.get_args(hint)
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        return any(_admits(a, kind) for a in args)
    if kind is float and hint is int:
        return False
    return isinstance(hint, type) and (issubclass(kind, hint) or (hint is float and kind is int))


def _bad_values(value, hint) -> list[tuple[str, str]]:
    """(override value, what is wrong) pairs that no parameter of this type may take."""
    out = []
    if isinstance(value, bool) or hint is bool:
        return [("maybe", "not a bool"), ("nan", "not a bool")]
    numeric = isinstance(value, (int, float)) or (value is None and (
        _admits(hint, int) or _admits(hint, float)) and hint is not None)
    if numeric:
        out += [("nan", "NaN"), ("inf", "inf"), ("-inf", "-inf"),
                (str(2**64), "beyond int64"), (str(-(2**64)), "beyond int64")]
        if not _admits(hint, str):
            out.append(("not_a_number", "wrong type"))
        if isinstance(value, int) and not _admits(hint, float):
            out.append(("1.5", "not an integer"))
    elif isinstance(value, str):
        out.append(("[1,2]", "wrong type"))
    if isinstance(value, (list, ListConfig)) and value and isinstance(value[0], (int, float)):
        out += [("[" + ",".join(["nan"] * len(value)) + "]", "NaN in a list"),
                ("[" + ",".join(["inf"] * len(value)) + "]", "inf in a list")]
    return out


def _group_cases() -> list[tuple[list[str], str]]:
    """Every parameter of every class that an option of a group builds (the first option
    of each class: the 30 benchmark problems share one class and its checks)."""
    cases, seen = [], set()
    for group in ("problem", "algorithm", "surrogate"):
        for option in cli.available(group):
            node = cli.option_config(group, option)
            if node["_target_"] in seen:
                continue
            seen.add(node["_target_"])
            cls = get_class(node["_target_"])
            hints = _type_hints(cls)
            base = ([] if group == "problem" else CHEAP) + [f"{group}={option}"]
            if option == "stiffness":
                base = ["problem=stiffness", "algorithm=nsga2"]
            for key, value in node.items():
                if key.startswith("_"):
                    continue
                for bad, _why in _bad_values(value, hints.get(key)):
                    cases.append(([*base, f"{group}.{key}={bad}"], key))
                if isinstance(value, str) and key not in LABELS:
                    cases.append(([*base, f"{group}.{key}=no_such_choice"], key))
                cases.append(([*base, f"{group}.{key}x=1"], f"{key}x"))  # misspelt
                cases.append(([*base, f"+{group}.{key}_extra=1"], f"{key}_extra"))
    return cases


def _run_setting_cases() -> list[tuple[list[str], str]]:
    bad = {
        "seed": ["-1", str(2**63), str(2**64), "1.5", "nan", "x"],
        "budget": ["0", "-5", str(2**63), "1.5", "inf", "x"],
        "eval_time_limit": ["0", "-1", "nan", "inf", "x"],
        # (OmegaConf reads an integer as a bool, 2 as true: its documented conversion)
        "resume": ["maybe", "[1]"], "progress": ["maybe", "[1]"], "plots": ["maybe", "[1]"],
    }
    cases = [([*CHEAP, "algorithm=nsga2", f"{key}={v}"], key) for key, vals in bad.items()
             for v in vals]
    for group in ("problem", "algorithm", "surrogate", "scheme", "experiment"):
        cases.append(([*CHEAP, f"{group}=no_such_option"], "no_such_option"))
    cases += [([*CHEAP, "+foo=1"], "foo"), ([*CHEAP, "+seeds=1"], "seeds"),
              ([*CHEAP, "+budgte=3"], "budgte"),
              (["experiment=quick", "scheme=Z"], "Z"),
              (["problem=stiffness", "scheme=A", "scheme.name=Q"], "scheme")]
    return cases


#: The cases of the issue's report (all ran to completion or gave tracebacks before).
REPORTED = [
    (["surrogate=rbf", "surrogate.ridge=-1"], "ridge"),
    (["surrogate=gp", "surrogate.noise_floor=-1"], "noise_floor"),
    ([*CHEAP, "algorithm=nsga2", "algorithm.crossover_prob=2"], "crossover_prob"),
    ([*CHEAP, "algorithm=nsga2", "algorithm.crossover_eta=-1"], "crossover_eta"),
    ([*CHEAP, "algorithm=nsga3", "algorithm.mutation_eta=-1"], "mutation_eta"),
    ([*CHEAP, "algorithm=nsga2", "algorithm.mutation_eta=nan"], "mutation_eta"),
    ([*CHEAP, f"seed={2**63 + 1}"], "seed"),
    ([*CHEAP, "+foo=1"], "foo"),
    ([*CHEAP, "hydra.run.dir=/proc/tmopt-cannot-be-here"], "/proc/tmopt-cannot-be-here"),
]

#: Every generated case (about 1000; ~0.15 s of CPU each): the slow test.
GROUP_CASES = _group_cases()
CASES = GROUP_CASES + _run_setting_cases() + REPORTED
#: The default suite's share: all run-setting and reported cases and a seeded sample of
#: the group cases, 150 in all.
SAMPLE = _run_setting_cases() + REPORTED
SAMPLE = SAMPLE + random.Random(20).sample(GROUP_CASES, 150 - len(SAMPLE))


def test_the_generator_makes_enough_bad_configurations():
    assert len(SAMPLE) >= 150 and len(CASES) >= 1000, (len(SAMPLE), len(CASES))
    for cases in (SAMPLE, CASES):
        keys = {ov.split("=")[0].lstrip("+").split(".")[0] for overrides, _ in cases
                for ov in overrides[-1:]}
        assert {"problem", "algorithm", "surrogate", "seed", "budget"} <= keys


def test_every_generated_bad_configuration_is_refused_in_one_line_naming_it(monkeypatch):
    _refuse_all(SAMPLE, monkeypatch)


def test_a_wrapped_problem_names_its_own_base_parameter(monkeypatch):
    """The full generator's one miss at stop 52: ``problem=faulty problem.base=<unknown>``
    was refused naming the *suite's* problem, not the parameter ``base``."""
    _refuse_all([(["problem=faulty", "problem.base=no_such_choice"], "base")], monkeypatch)


@pytest.mark.slow
def test_every_bad_configuration_of_every_parameter_is_refused(monkeypatch):
    _refuse_all(CASES, monkeypatch)


def _refuse_all(cases, monkeypatch) -> None:
    def no_evaluation(*args, **kwargs):
        raise AssertionError("pre-flight evaluated a design")

    monkeypatch.setattr(Problem, "evaluate", no_evaluation)
    accepted, wrong = [], []
    for overrides, name in cases:
        try:
            cli.preflight(overrides)
        except ConfigError as exc:
            message = str(exc)
            if "\n" in message or name not in message:
                wrong.append((overrides, message))
            continue
        except AssertionError:
            raise
        except Exception as exc:  # noqa: BLE001 - what the test is looking for
            wrong.append((overrides, f"{type(exc).__name__}: {exc}"))
            continue
        accepted.append(overrides)
    print(f"\n{len(cases)} bad configurations: {len(cases) - len(accepted) - len(wrong)} "
          f"refused in one line naming the parameter, {len(accepted)} accepted, "
          f"{len(wrong)} other")
    assert not accepted, accepted
    assert not wrong, wrong


@pytest.mark.parametrize("overrides, name", REPORTED[:3] + REPORTED[6:],
                         ids=lambda v: v if isinstance(v, str) else " ".join(v[-1:]))
def test_the_command_exits_2_with_one_line_and_writes_nothing(tmp_path, overrides, name):
    run = tmp_path / "run"
    extra = [] if any(o.startswith("hydra.run.dir") for o in overrides) \
        else [f"hydra.run.dir={run}"]
    env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, "-m", "tmopt", *overrides, *extra], cwd=REPO,
                          env=env, capture_output=True, text=True, timeout=600)
    lines = (proc.stdout + proc.stderr).strip().splitlines()
    assert proc.returncode == 2, lines
    assert len(lines) == 1 and lines[0].startswith("tmopt: error: ") and name in lines[0], lines
    assert not run.exists()


def test_the_valid_defaults_pass_preflight():
    """The generator's refusals are not a pre-flight that refuses everything."""
    assert cli.preflight([*CHEAP, "algorithm=nsga2"]) == 1
    assert cli.preflight(["surrogate=rbf", "surrogate.ridge=0.001"]) == 1
