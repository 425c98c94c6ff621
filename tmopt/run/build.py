"""Build the problem and algorithm of a composed configuration, checking it first."""

from __future__ import annotations

from functools import partial

from omegaconf import DictConfig, OmegaConf

from tmopt.algorithms.base import Algorithm, AlgorithmConfigError
from tmopt.problems.base import ExpensiveProblem
from tmopt.run.config import (
    INT64_MAX,
    ConfigError,
    check_node,
    check_top_level_keys,
    constructor_parameters,
)


def _kwargs(node: DictConfig) -> dict:
    data = OmegaConf.to_container(node, resolve=True)
    return {k: v for k, v in data.items() if not k.startswith("_")}


def _construct(group: str, node: DictConfig, choice: str, **extra):
    cls = check_node(group, node, choice)
    try:
        return cls(**_kwargs(node), **extra)
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"{group}={choice}: {exc}") from None


def build_problem(cfg: DictConfig, choice: str = "") -> ExpensiveProblem:
    return _construct("problem", cfg.problem, choice)


def build_algorithm(cfg: DictConfig, choice: str = "", surrogate_choice: str = "") -> Algorithm:
    cls = check_node("algorithm", cfg.algorithm, choice)
    extra = {}
    # The one BUILT_ARGUMENTS entry: a surrogate factory from the surrogate group.
    wants_surrogate = "surrogate" in constructor_parameters(cls)
    if wants_surrogate and "surrogate" not in cfg.algorithm:
        if cfg.get("surrogate") is None:
            raise ConfigError(f"algorithm={choice} needs a surrogate; set surrogate=<name>")
        scls = check_node("surrogate", cfg.surrogate, surrogate_choice)
        extra["surrogate"] = partial(scls, **_kwargs(cfg.surrogate))
        _construct("surrogate", cfg.surrogate, surrogate_choice)  # its checks, now: cheap
    return _construct("algorithm", cfg.algorithm, choice, **extra)


def build(cfg: DictConfig, choices: dict | None = None) -> tuple[ExpensiveProblem, Algorithm]:
    """Problem and algorithm of ``cfg``; every error is a one-line :class:`ConfigError`."""
    choices = choices or {}
    check_top_level_keys(cfg)
    for key in ("budget", "seed"):
        value, low = cfg[key], 1 if key == "budget" else 0
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= INT64_MAX:
            raise ConfigError(f"{key}={value!r} is invalid: must be an integer in "
                              f"[{low}, 2^63 - 1]")
    limit = cfg.get("eval_time_limit")
    if limit is not None and not (isinstance(limit, (int, float)) and 0 < limit < float("inf")):
        raise ConfigError(f"eval_time_limit={limit!r} is invalid: must be null or a number "
                          "of seconds > 0")
    problem = build_problem(cfg, choices.get("problem", ""))
    algorithm = build_algorithm(cfg, choices.get("algorithm", ""), choices.get("surrogate", ""))
    try:
        algorithm.check_budget(problem, cfg.budget)
    except AlgorithmConfigError as exc:
        raise ConfigError(str(exc)) from None
    return problem, algorithm
