"""Structured configuration and its validation.

The run-level settings are a dataclass registered in Hydra's ConfigStore (``run_schema``),
so Hydra type-checks them while composing. The option groups (``problem``,
``algorithm``, ``surrogate``) are YAML files that start from a class's constructor and
set only what differs from it: their defaults list names ``/constructor/<class path>``, a
node that :func:`register_configs` generates from the constructor's signature (``_target_``
and every argument at its default), so each default is written once, in the signature,
and every argument can be overridden from the command line. :func:`check_node` checks
every key and type of a group node against that signature before anything is built, so a
typo or a wrong type ends with one line naming the key and what is allowed, and the
constructor's own checks name ranges. (Decision recorded in docs/decisions.md.)
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
import hashlib
import importlib
import inspect
import json
import math
import re
import types
import typing
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional

from hydra.core.config_store import ConfigStore
from hydra.utils import get_class
from omegaconf import MISSING, DictConfig, ListConfig, OmegaConf

GROUPS = ("problem", "algorithm", "surrogate", "scheme", "experiment")
#: Keys that change how a run is shown or stored, not what it computes.
RUN_ONLY_KEYS = ("resume", "progress", "plots", "name")
#: The config group whose nodes are generated from constructors (``/constructor/<class>``).
CONSTRUCTOR_GROUP = "constructor"
#: Constructor arguments that ``build`` supplies from another group, never an option's node.
BUILT_ARGUMENTS = ("surrogate",)


#: The PlatEMO-parity arguments added after runs were made (issue 24, part 4; the
#: defaults are the fixes those runs had), by ``module.Class`` under tmopt.algorithms.
PLATEMO_PARITY_ARGUMENTS: dict[str, tuple[str, ...]] = {
    "ctsea.CTSEA": ("archive_copies", "fill_initial_elite", "collapsed_range", "weights"),
    "cmoes.CMOES": ("switch_keeps_populations", "stale_feasible_mask", "reference"),
    "ssde.SSDE": ("reseed_first_nodes", "reference"),
    "kts.KTS": ("paired_convergence_test", "mixed_scale_deletion", "da_update",
                "skip_evaluated", "kmeans_normalised", "reference"),
    "pea.PEA": ("nan_ties", "random_fallback", "reference"),
    "drlsaea.DRLSAEA": ("input_scaling", "same_budget_share", "per_set_reward"),
}


def _objectives_fixed(node: dict) -> bool:
    from tmopt.problems.suites import SCALABLE

    return str(node.get("name", "")).lower() not in SCALABLE


#: Arguments that earlier configurations did not name, so that, while they are at their
#: constructor default, they stay out of config_hash: the archives of earlier runs (same
#: numbers) still resume and finished runs are still skipped. Keyed by (config group, its
#: ``_target_``, argument); the value, if not None, says for which nodes the rule holds.
#: qLogNEHVI's ``max_baseline``, ``sequential`` and ``acq_ftol`` came after runs were made;
#: the suite problems' files named ``n_obj`` only for the problems scalable in objectives
#: (for the others it has one value).
HASH_NEUTRAL_ARGUMENTS: dict[tuple[str, str, str], Callable[[dict], bool] | None] = {
    ("algorithm", "tmopt.algorithms.qlognehvi.QLogNEHVI", "max_baseline"): None,
    ("algorithm", "tmopt.algorithms.qlognehvi.QLogNEHVI", "sequential"): None,
    ("algorithm", "tmopt.algorithms.qlognehvi.QLogNEHVI", "acq_ftol"): None,
    ("problem", "tmopt.problems.suites.PymooBenchmark", "difficulty"): None,
    ("problem", "tmopt.problems.suites.PymooBenchmark", "front_points"): None,
    ("problem", "tmopt.problems.suites.PymooBenchmark", "n_obj"): _objectives_fixed,
    ("problem", "tmopt.problems.stiffness.StiffnessProblem", "information_constraints"): None,
    **{("algorithm", f"tmopt.algorithms.{target}", key): None
       for target, keys in PLATEMO_PARITY_ARGUMENTS.items() for key in keys},
}
#: Arguments added later whose earlier behaviour is a value other than their constructor
#: default (the default being the new behaviour): at that value they stay out of
#: config_hash too. qLogNEHVI's speed settings (docs/speed.md): ``qlognehvi_reference``
#: sets these values, so runs made before keep their hash; the GP's refit guard likewise.
HASH_NEUTRAL_VALUES: dict[tuple[str, str, str], object] = {
    ("algorithm", "tmopt.algorithms.qlognehvi.QLogNEHVI", "cached_posterior"): False,
    ("algorithm", "tmopt.algorithms.qlognehvi.QLogNEHVI", "init_batch_limit"): None,
    ("algorithm", "tmopt.algorithms.qlognehvi.QLogNEHVI", "refit_every"): 1,
    ("algorithm", "tmopt.algorithms.qlognehvi.QLogNEHVI", "refit_guard"): None,
    ("algorithm", "tmopt.algorithms.qlognehvi.QLogNEHVI", "prune_samples"): None,
    ("algorithm", "tmopt.algorithms.qlognehvi.QLogNEHVI", "gp_guard_max_iter"): None,
    ("surrogate", "tmopt.surrogates.gp.GPSurrogate", "refit_guard"): None,
    ("surrogate", "tmopt.surrogates.gp.GPSurrogate", "guard_max_iter"): None,
}
#: For an algorithm that takes no surrogate, the surrogate group changes no number, yet it
#: is part of every configuration: it is hashed with these arguments at the values that
#: earlier runs had, so a new default of the surrogate (the GP's refit schedule, docs/
#: speed.md) leaves the hash of those runs (qLogNEHVI, the evolutionary baselines) alone.
INERT_SURROGATE_VALUES: dict[str, dict[str, object]] = {
    "tmopt.surrogates.gp.GPSurrogate": {"refit_every": 1, "refit_guard": None},
}


class ConfigError(ValueError):
    """A configuration value is invalid; the message is one line naming it."""


def did_you_mean(word: str, choices: Sequence[str]) -> str:
    """`` did you mean 'x'?`` for the closest of ``choices`` to a misspelt ``word``
    (difflib's ratio >= 0.6, case ignored), else ``""``; for one-line errors such as
    ``f"unknown key {k!r};{did_you_mean(k, keys)} allowed keys: ..."``."""
    lowered = {str(c).lower(): str(c) for c in choices}
    close = difflib.get_close_matches(str(word).lower(), list(lowered), n=1)
    return f" did you mean {lowered[close[0]]!r}?" if close else ""


#: Integers are stored as int64 (archives, seeds, metrics): larger ones are refused.
INT64_MAX = 2**63 - 1


def check_value(name: str, value) -> None:
    """What every configured number must be, whatever its parameter: finite (NaN and inf
    are never a setting) and, for an integer, within int64. Lists are checked element by
    element. Parameter-specific ranges are checked by the constructors.

    Raises:
        ConfigError: one line naming ``name``.
    """
    if isinstance(value, (list, tuple, ListConfig)):
        for v in value:
            check_value(name, v)
    elif isinstance(value, bool):
        return
    elif isinstance(value, int) and abs(value) > INT64_MAX:
        raise ConfigError(f"{name}={value} is out of range: integers must lie within "
                          f"+-(2^63 - 1)")
    elif isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(f"{name}={value} is invalid: must be a finite number")


def check_top_level_keys(cfg: DictConfig) -> None:
    """Refuse a key at the top of the configuration that is neither a run setting nor a
    config group (``+foo=1``)."""
    allowed = [f.name for f in dataclasses.fields(RunConfig)]
    for key in cfg:
        if key != "hydra" and key not in allowed:
            raise ConfigError(f"unknown key {key!r};{did_you_mean(key, allowed)} allowed "
                              f"top-level keys: {', '.join(allowed)}")


@dataclass
class RunConfig:
    """Run settings (top level of every configuration).

    Attributes:
        problem, algorithm, surrogate: Group nodes (see ``tmopt/conf/<group>/``).
        seed: Seeds the algorithm; same config and seed give the same numbers.
        budget: Real (expensive) evaluations allowed.
        resume: Resume an interrupted run found in the output folder (by replay).
        progress: One progress line per generation.
        plots: Write PNG plots into the run folder.
        name: Label of a sweep (names its folder ``multirun/<name>``); empty: derived
            from the sweep's command-line overrides (:func:`sweep_name`).
        eval_time_limit: Seconds allowed per design evaluation; a design that overruns
            is recorded as failed and the run goes on (None: no limit).
    """

    problem: Any = MISSING
    algorithm: Any = MISSING
    surrogate: Any = None
    scheme: Any = None
    seed: int = 0
    budget: int = 300
    resume: bool = True
    progress: bool = True
    plots: bool = True
    name: str = ""
    eval_time_limit: Optional[float] = None  # noqa: UP045 - OmegaConf needs Optional
    extras: dict = field(default_factory=dict)


def run_folder_name(override_dirname: str) -> str:
    """``override_dirname`` without ``+``/``++``/``~`` prefixes, so a configuration's folder
    does not depend on how its overrides were spelled (a sweep forces some with ``++``)."""
    return re.sub(r"(^|,)[+~]+", r"\1", override_dirname)


#: Overrides that do not change what a sweep computes, left out of its derived name.
NOT_IN_SWEEP_NAME = ("name", "resume", "progress", "plots", "hydra", "experiment")


def sweep_name(name: str, overrides=()) -> str:
    """``name``, or when empty a folder name derived from a sweep's overrides.

    ``["problem=mw3", "seed=0,1,2", "algorithm=nsga2,nsga3", "problem.n_var=4"]`` ->
    ``algorithm=nsga2+nsga3_problem=mw3_seed=0+1+2_problem.n_var=4`` (sorted, choices
    before dotted keys, so the spelling order does not matter; a preset ``experiment=X``
    keeps ``X`` in front); over 120 characters the tail becomes a short hash. No override
    at all: ``default``.
    """
    if name:
        return str(name)
    parts, preset = [], ""
    for item in overrides or ():
        key, _, value = str(item).lstrip("+~").partition("=")
        if key == "experiment":
            preset = value
        if key.split(".")[0].split("/")[0] in NOT_IN_SWEEP_NAME:
            continue
        value = re.sub(r"[/'\"\\ ]", "-", value.replace(",", "+"))
        parts.append(f"{key}={value}")
    parts.sort(key=lambda p: ("." in p.partition("=")[0], p))  # choices before details
    derived = "_".join(([preset] if preset else []) + parts) or "default"
    if len(derived) > 120:
        derived = f"{derived[:111]}_{hashlib.sha256(derived.encode()).hexdigest()[:8]}"
    return derived


def register_configs(*conf_dirs: str | Path) -> None:
    """Register the run schema, the folder resolver and, for every ``/constructor/<class>``
    that an option file under one of ``conf_dirs`` names (tmopt's own configuration, a
    user's ``--config-dir``), that class's constructor node."""
    store = ConfigStore.instance()
    store.store(name="run_schema", node=RunConfig)
    if not OmegaConf.has_resolver("tmopt_folder"):
        OmegaConf.register_new_resolver("tmopt_folder", run_folder_name)
    if not OmegaConf.has_resolver("tmopt_sweep_name"):
        OmegaConf.register_new_resolver("tmopt_sweep_name", sweep_name)
    for target in constructor_targets(*conf_dirs):
        try:
            node = constructor_node(target)
        except ConfigError:  # reported in one line by check_node if the option is chosen
            node = {"_target_": target}
        store.store(group=CONSTRUCTOR_GROUP, name=target, node=node)


_CONSTRUCTOR_ENTRY = re.compile(rf"^/?{CONSTRUCTOR_GROUP}/(?P<target>[\w.]+)(@\w+)?$")


def constructor_targets(*conf_dirs: str | Path) -> list[str]:
    """Class paths that the option files ``<conf_dir>/<group>/*.yaml`` start from."""
    targets = set()
    for path in sorted(p for d in conf_dirs for p in Path(d).glob("*/*.yaml")):
        stat = path.stat()
        targets.update(_file_targets(str(path), stat.st_mtime_ns, stat.st_size))
    return sorted(targets)


@functools.lru_cache(maxsize=4096)
def _file_targets(path: str, mtime_ns: int, size: int) -> tuple[str, ...]:
    """The constructor targets one option file names. Memoised on the file's stamp (a
    changed file is read again): every command, and every pre-flight of a process that
    checks many (the Python API, the fuzz test), otherwise re-parsed all ~100 option
    files, ~40 % of a pre-flight's time."""
    found = (_CONSTRUCTOR_ENTRY.match(e) if isinstance(e, str) else None
             for e in OmegaConf.load(path).get("defaults") or [])
    return tuple(m["target"] for m in found if m)


def constructor_node(target: str) -> dict:
    """``_target_`` and every argument of the class's constructor at its default
    (``???`` where it has none), less :data:`BUILT_ARGUMENTS`."""
    module, _, name = target.rpartition(".")
    try:  # importlib, not hydra's get_class, which logs every failure at start-up
        cls = getattr(importlib.import_module(module), name)
    except Exception as exc:  # noqa: BLE001
        raise ConfigError(f"{CONSTRUCTOR_GROUP}/{target}: cannot import the class ({exc})") \
            from None
    node: dict = {"_target_": target}
    for arg, param in constructor_parameters(cls).items():
        if arg not in BUILT_ARGUMENTS:
            node[arg] = MISSING if param.default is param.empty else _plain(param.default)
    return node


def _plain(value):
    """A default as OmegaConf stores it (tuples become lists)."""
    return [_plain(v) for v in value] if isinstance(value, (tuple, list)) else value


def constructor_parameters(cls) -> dict[str, inspect.Parameter]:
    """Named parameters of ``cls(...)``, following ``**kwargs`` to a base class in the same
    package.

    A variant that adds arguments to a class of its own module (MGSAEA-IPC to MGSAEA)
    takes the base's as ``**kwargs`` and passes them on, so each default is defined once;
    its parameters are then its own ones followed by the base's; so does an algorithm of its
    own file built on another's (DRL-SAEA on MGSAEA). A ``**kwargs`` passed to a class
    elsewhere stays the last entry (the class accepts any key, as before).
    """
    params: dict[str, inspect.Parameter] = {}
    rest = None
    for init in _init_chain(cls):
        rest = None
        for name, param in inspect.signature(init).parameters.items():
            if name == "self" or param.kind is param.VAR_POSITIONAL:
                continue
            if param.kind is param.VAR_KEYWORD:
                rest = param
            else:
                params.setdefault(name, param)
    if rest is not None:
        params.setdefault(rest.name, rest)
    return params


def _init_chain(cls) -> list:
    """``cls.__init__`` and, while it takes ``**kwargs``, the ``__init__`` of the next base
    class that defines one, if that class is in the same package (``tmopt.algorithms``)."""
    inits = [k for k in cls.__mro__ if "__init__" in vars(k)]
    chain = [inits[0]]
    for base in inits[1:]:
        takes_rest = any(p.kind is p.VAR_KEYWORD for p in
                         inspect.signature(vars(chain[-1])["__init__"]).parameters.values())
        if not takes_rest or _package(base) != _package(chain[-1]):
            break
        chain.append(base)
    return [vars(k)["__init__"] for k in chain]


def _package(cls) -> str:
    return cls.__module__.rpartition(".")[0]


# ---- validation of _target_ nodes ----------------------------------------------------
def check_node(group: str, node: DictConfig | dict, choice: str = "") -> type:
    """Check a group node's keys and value types against its class constructor.

    Returns the class. Raises :class:`ConfigError` with a one-line message.
    """
    label = f"{group}={choice}" if choice else group
    target = node.get("_target_") if node is not None else None
    if not target:
        raise ConfigError(f"{label}: the config has no _target_ naming the class to build")
    try:
        cls = get_class(target)
    except Exception as exc:  # noqa: BLE001
        raise ConfigError(f"{label}: cannot import _target_ {target!r} ({exc})") from None
    params = constructor_parameters(cls)
    accepts_any = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())
    hints = _type_hints(cls)
    missing = [k for k in OmegaConf.missing_keys(node)] if isinstance(node, DictConfig) else []
    if missing:
        raise ConfigError(f"{label}: {group}.{missing[0]} must be set (the constructor has no "
                          "default for it)")
    for key, value in node.items():
        if key.startswith("_"):
            continue
        if key not in params:
            if accepts_any:
                continue
            names = [k for k, p in params.items()
                     if p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
            raise ConfigError(f"{label}: unknown key {group}.{key};{did_you_mean(key, names)} "
                              f"allowed keys: {', '.join(names)}")
        expected = hints.get(key)
        if expected is not None and not _matches(value, expected):
            raise ConfigError(f"{label}: {group}.{key}={_show(value)} has the wrong type; "
                              f"expected {_type_name(expected)}")
        try:
            check_value(f"{group}.{key}", value)
        except ConfigError as exc:
            raise ConfigError(f"{label}: {exc}") from None
    return cls


def _type_hints(cls) -> dict:
    """Type hints of the constructor arguments (see :func:`constructor_parameters`)."""
    hints: dict = {}
    for init in _init_chain(cls):
        try:
            found = typing.get_type_hints(init)
        except Exception:  # noqa: BLE001 - unresolvable hints are simply not checked
            found = {}
        for name, hint in found.items():
            hints.setdefault(name, hint)
    return hints


def _matches(value, expected) -> bool:
    if expected is Any or expected is inspect.Parameter.empty:
        return True
    origin = typing.get_origin(expected)
    if origin in (typing.Union, types.UnionType):
        return any(_matches(value, arg) for arg in typing.get_args(expected))
    if expected is type(None):
        return value is None
    if origin in (list, tuple, Sequence):
        if not isinstance(value, (list, tuple, ListConfig)):
            return False
        args = [a for a in typing.get_args(expected) if a is not Ellipsis]
        return not args or all(_matches(v, args[0]) for v in value)
    if origin is dict or expected is dict:
        return isinstance(value, (dict, DictConfig))
    if expected is float:
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    if expected is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if isinstance(expected, type):
        return isinstance(value, expected)
    return True


def _type_name(expected) -> str:
    return getattr(expected, "__name__", None) or str(expected).replace("typing.", "")


def _show(value) -> str:
    if isinstance(value, (DictConfig, ListConfig)):
        return json.dumps(OmegaConf.to_container(value))
    return repr(value)


def _hash_inert_surrogate(data: dict) -> None:
    """Set the surrogate node to :data:`INERT_SURROGATE_VALUES` when the algorithm takes no
    surrogate (the one ``BUILT_ARGUMENTS`` entry); in place."""
    alg, sur = data.get("algorithm"), data.get("surrogate")
    if not (isinstance(alg, dict) and isinstance(sur, dict)) \
            or sur.get("_target_") not in INERT_SURROGATE_VALUES:
        return
    try:
        takes = "surrogate" in constructor_parameters(get_class(alg.get("_target_", "")))
    except (ImportError, ValueError, AttributeError):  # unknown class: hash the node as is
        return
    if not takes:
        sur.update(INERT_SURROGATE_VALUES[sur["_target_"]])


#: What :func:`earlier_value` returns for an argument the registries do not list.
UNKNOWN = object()


def earlier_value(group: str, node: dict, key: str) -> object:
    """The value a run ran with whose configuration ``node`` (of config group ``group``)
    does not name ``key`` because the argument came later: the constructor default for
    :data:`HASH_NEUTRAL_ARGUMENTS`, the listed value for :data:`HASH_NEUTRAL_VALUES`,
    else :data:`UNKNOWN`.  The same rules keep those runs' hashes, so a
    run that names the value and one made before the argument existed are one setting."""
    target = node.get("_target_")
    if (group, target, key) in HASH_NEUTRAL_VALUES:
        return HASH_NEUTRAL_VALUES[(group, target, key)]
    applies = HASH_NEUTRAL_ARGUMENTS.get((group, target, key), UNKNOWN)
    if applies is UNKNOWN or (applies is not None and not applies(node)):
        return UNKNOWN
    return _plain(constructor_parameters(get_class(target))[key].default)


def config_hash(cfg: DictConfig) -> str:
    """Hash of everything that determines a run's numbers (run-only keys excluded)."""
    data = OmegaConf.to_container(cfg, resolve=True)
    for key in RUN_ONLY_KEYS:
        data.pop(key, None)
    data.pop("hydra", None)
    _hash_inert_surrogate(data)
    for group, target, key in (*HASH_NEUTRAL_ARGUMENTS, *HASH_NEUTRAL_VALUES):
        node = data.get(group)
        if isinstance(node, dict) and node.get("_target_") == target and key in node \
                and node[key] == earlier_value(group, node, key):
            node.pop(key)
    blob = json.dumps(data, sort_keys=True, default=str).encode()
    return hashlib.sha256(blob).hexdigest()[:16]
