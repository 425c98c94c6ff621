"""Structured configuration and its validation.

The run-level settings are a dataclass registered in Hydra's ConfigStore (``run_schema``),
so Hydra type-checks them while composing. The option groups (``problem``,
``algorithm``, ``surrogate``) are YAML files naming a class by ``_target_`` plus its
constructor arguments: the constructor signature is their schema. :func:`check_node`
checks every key and type of a group node against that signature before anything is
built, so a typo or a wrong type ends with one line naming the key and what is allowed,
and the constructor's own checks name ranges. (Decision recorded in docs/decisions.md.)
"""

from __future__ import annotations

import hashlib
import inspect
import json
import re
import types
import typing
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Optional

from hydra.core.config_store import ConfigStore
from hydra.utils import get_class
from omegaconf import MISSING, DictConfig, ListConfig, OmegaConf

GROUPS = ("problem", "algorithm", "surrogate", "scheme", "experiment")
#: Keys that change how a run is shown or stored, not what it computes.
RUN_ONLY_KEYS = ("resume", "progress", "plots", "name")
#: Parameters added after runs were made, with the value that reproduces the earlier
#: behaviour: at that value they stay out of config_hash, so the archives of earlier runs
#: (same numbers) still resume and finished runs are still skipped.
#: Keyed by (config group, its ``_target_``, parameter).
HASH_NEUTRAL_DEFAULTS: dict[tuple[str, str, str], object] = {
    ("algorithm", "tmopt.algorithms.qlognehvi.QLogNEHVI", "max_baseline"): None,
    # docs/speed.md: conf/algorithm/qlognehvi_reference.yaml pins these
    ("algorithm", "tmopt.algorithms.qlognehvi.QLogNEHVI", "cached_posterior"): False,
    ("algorithm", "tmopt.algorithms.qlognehvi.QLogNEHVI", "init_batch_limit"): None,
    ("algorithm", "tmopt.algorithms.qlognehvi.QLogNEHVI", "refit_every"): 1,
    ("algorithm", "tmopt.algorithms.qlognehvi.QLogNEHVI", "refit_guard"): None,
    ("algorithm", "tmopt.algorithms.qlognehvi.QLogNEHVI", "prune_samples"): None,
    ("surrogate", "tmopt.surrogates.gp.GPSurrogate", "refit_guard"): None,
}


class ConfigError(ValueError):
    """A configuration value is invalid; the message is one line naming it."""


@dataclass
class RunConfig:
    """Run settings (top level of every configuration).

    Attributes:
        problem, algorithm, surrogate: Group nodes (see ``conf/<group>/``).
        seed: Seeds the algorithm; same config and seed give the same numbers.
        budget: Real (expensive) evaluations allowed.
        resume: Resume an interrupted run found in the output folder (by replay).
        progress: One progress line per generation.
        plots: Write PNG plots into the run folder.
        name: Label of the run or sweep (names the multirun folder).
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
    name: str = "default"
    eval_time_limit: Optional[float] = None  # noqa: UP045 - OmegaConf needs Optional
    extras: dict = field(default_factory=dict)


def run_folder_name(override_dirname: str) -> str:
    """``override_dirname`` without ``+``/``++``/``~`` prefixes, so a configuration's folder
    does not depend on how its overrides were spelled (a sweep forces some with ``++``)."""
    return re.sub(r"(^|,)[+~]+", r"\1", override_dirname)


def register_configs() -> None:
    ConfigStore.instance().store(name="run_schema", node=RunConfig)
    if not OmegaConf.has_resolver("tmopt_folder"):
        OmegaConf.register_new_resolver("tmopt_folder", run_folder_name)


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
    params = _constructor_params(cls)
    accepts_any = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())
    hints = _type_hints(cls)
    for key, value in node.items():
        if key.startswith("_"):
            continue
        if key not in params:
            if accepts_any:
                continue
            allowed = ", ".join(k for k, p in params.items()
                                if p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD))
            raise ConfigError(f"{label}: unknown key {group}.{key}; allowed keys: {allowed}")
        expected = hints.get(key)
        if expected is not None and not _matches(value, expected):
            raise ConfigError(f"{label}: {group}.{key}={_show(value)} has the wrong type; "
                              f"expected {_type_name(expected)}")
    return cls


def _constructor_params(cls) -> dict[str, inspect.Parameter]:
    params = dict(inspect.signature(cls.__init__).parameters)
    params.pop("self", None)
    return params


def _type_hints(cls) -> dict:
    try:
        return typing.get_type_hints(cls.__init__)
    except Exception:  # noqa: BLE001 - unresolvable hints are simply not checked
        return {}


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


def config_hash(cfg: DictConfig) -> str:
    """Hash of everything that determines a run's numbers (run-only keys excluded)."""
    data = OmegaConf.to_container(cfg, resolve=True)
    for key in RUN_ONLY_KEYS:
        data.pop(key, None)
    data.pop("hydra", None)
    for (group, target, key), default in HASH_NEUTRAL_DEFAULTS.items():
        node = data.get(group)
        if isinstance(node, dict) and node.get("_target_") == target \
                and key in node and node[key] == default:
            node.pop(key)
    blob = json.dumps(data, sort_keys=True, default=str).encode()
    return hashlib.sha256(blob).hexdigest()[:16]
