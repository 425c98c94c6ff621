"""Command-line entry point: ``python -m tmopt`` / ``tmopt`` (Hydra).

Before Hydra launches anything, :func:`preflight` composes the configuration for every
value that the command line names (each value of a sweep once) and builds its problem and
algorithm. Any unknown config name, wrong type or invalid value thus ends the command
with one line naming it and the choices, exit status 2, and no traceback; nothing of a
sweep starts until the whole sweep is known to be valid.
"""

from __future__ import annotations

import json
import logging
import os
import re
import sys
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import hydra
from hydra import compose
from hydra import version as hydra_version
from hydra._internal.hydra import Hydra
from hydra._internal.utils import create_automatic_config_search_path, get_args_parser
from hydra.core.config_search_path import SearchPathQuery
from hydra.core.global_hydra import GlobalHydra
from hydra.core.hydra_config import HydraConfig
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.types import RunMode
from omegaconf import DictConfig, OmegaConf

from tmopt.evaluation.archive import ArchiveError
from tmopt.files import atomic_write_text
from tmopt.run.build import build
from tmopt.run.config import GROUPS, ConfigError, config_hash, did_you_mean, register_configs
from tmopt.run.run_lock import RunFolderBusy
from tmopt.run.runner import FolderOfAnotherRun

if TYPE_CHECKING:
    from tmopt.algorithms.base import Algorithm

log = logging.getLogger("tmopt")

#: tmopt's own configuration ships inside the package; Hydra reads it through its pkg://
#: source, so an installed tmopt (a wheel, not a clone) has every option. CONF_DIR is the
#: same folder on disk (to find the classes the option files start from).
CONF_PACKAGE = "tmopt.conf"
CONF_SOURCE = f"pkg://{CONF_PACKAGE}"
CONF_DIR = Path(__file__).resolve().parents[1] / "conf"
#: Flags after which Hydra prints information instead of running: no pre-flight needed.
INFO_FLAGS = {"--help", "-h", "--hydra-help", "--info", "-i", "--cfg", "-c",
              "--shell-completion", "-sc", "--version", "--resolve", "-p", "--package"}
MULTIRUN_FLAGS = {"-m", "--multirun"}

register_configs(CONF_DIR)


# ---- where the configuration comes from ----------------------------------------------------
@dataclass(frozen=True)
class ConfigSources:
    """Where Hydra finds the configuration: tmopt's package (or ``--config-path``), the
    primary config's name (``--config-name``) and a user's folder of extra options searched
    first (``--config-dir``), exactly as Hydra's own command line sets them."""

    config_path: str = CONF_SOURCE
    config_name: str = "config"
    config_dir: str | None = None

    def search_path(self):
        """Hydra's search path for these sources (what ``@hydra.main`` builds from them)."""
        path = create_automatic_config_search_path(None, __name__, self.config_path)
        if self.config_dir is not None:
            path.prepend(provider="command-line", path=f"file://{self.config_dir}",
                         anchor=SearchPathQuery(provider="schema"))
        return path

    def folders(self) -> list[Path]:
        """The folders on disk whose option files may start from a constructor."""
        found = [CONF_DIR]
        for extra in (self.config_dir, self.config_path):
            if extra and not extra.startswith("pkg://") and Path(extra).is_dir():
                found.append(Path(extra))
        return found


def config_sources(args: list[str]) -> ConfigSources:
    """The :class:`ConfigSources` of a command line (Hydra's own argument parser reads it).

    A ``--config-dir`` that is not a folder is a one-line :class:`ConfigError`."""
    known, _ = get_args_parser().parse_known_args(args)
    config_dir = None
    if known.config_dir is not None:
        config_dir = os.path.abspath(known.config_dir)
        if not os.path.isdir(config_dir):
            raise ConfigError(f"--config-dir {known.config_dir}: no such folder")
    return ConfigSources(config_path=known.config_path or CONF_SOURCE,
                         config_name=known.config_name or "config", config_dir=config_dir)


# ---- pre-flight -------------------------------------------------------------------------
def available(group: str) -> list[str]:
    """Option names of a config group in every source Hydra searches (tmopt's own options
    and, with ``--config-dir``, the user's)."""
    if GlobalHydra.instance().is_initialized():
        return _options(group)
    with _hydra_context():
        return _options(group)


def _options(group: str) -> list[str]:
    loader = GlobalHydra.instance().config_loader()
    return sorted(set(loader.get_group_options(group)))


def preflight(args: list[str]) -> int:
    """Validate every configuration a command line denotes; return how many were checked."""
    sources = config_sources(args)
    register_configs(*sources.folders())
    overrides = get_args_parser().parse_known_args(args)[0].overrides
    try:
        parsed = OverridesParser.create().parse_overrides(overrides)
    except Exception as exc:  # noqa: BLE001 - Hydra's grammar errors are multi-line
        raise ConfigError(f"cannot parse the command line: {_first_line(exc)}") from None
    values: dict[str, list[str]] = {}
    for ov in parsed:
        key = ov.get_key_element()
        vals = list(ov.sweep_string_iterator()) if ov.is_sweep_override() \
            else [ov.get_value_element_as_str()]
        values[ov.input_line] = (key, vals, [_as_override(ov, v) for v in vals])
    combos = _combinations([v[2] for v in values.values()])
    multirun = bool(MULTIRUN_FLAGS.intersection(args))
    with _hydra_context(sources):
        for key, vals, _ in values.values():
            _check_group_values(key, vals)
        for combo in combos:
            _check_one(combo, multirun, sources.config_name)
    return len(combos)


def _as_override(ov, value: str) -> str:
    return f"{ov.get_key_element()}={value}"  # the key element keeps its +/++/~ prefix


def option_config(group: str, option: str) -> DictConfig:
    """The node of ``tmopt/conf/<group>/<option>.yaml`` as Hydra composes it (constructor
    defaults, then the file), e.g. to build one algorithm outside a run."""
    with _hydra_context():
        cfg = compose(config_name="config", overrides=[f"{group}={option}"])
    return cfg[group]


def algorithm_from_registry(option: str, overrides: Sequence[str] = ()) -> Algorithm:
    """The algorithm that ``python -m tmopt algorithm=<option> <overrides>`` would build
    (its surrogate from the ``surrogate`` group, default ``gp``), to run outside a Hydra
    job (e.g. on a problem built in code). An unknown option or key is one
    :class:`ConfigError` line."""
    from tmopt.run.build import build_algorithm

    _check_group_values("algorithm", [option])
    args = [f"algorithm={option}", *overrides]
    try:
        with _hydra_context():
            cfg = compose(config_name="config", overrides=args, return_hydra_config=True)
            choices = dict(cfg.hydra.runtime.choices)
    except Exception as exc:  # noqa: BLE001 - Hydra's composition errors are multi-line
        raise ConfigError(_composition_message(exc, args)) from None
    return build_algorithm(cfg, option, choices.get("surrogate", ""))


def _check_group_values(key: str, vals: list[str]) -> None:
    group = key.lstrip("+~")
    if group not in GROUPS:
        return
    options = available(group)
    for v in vals:
        if v not in options and v != "null":
            raise ConfigError(f"unknown {group} {v!r};{did_you_mean(v, options)} choose one "
                              f"of: {', '.join(options)}")


def _combinations(value_lists: list[list[str]]) -> list[list[str]]:
    """The first value of every override, then each other value of a sweep once."""
    base = [vals[0] for vals in value_lists]
    combos = [base]
    for i, vals in enumerate(value_lists):
        for v in vals[1:]:
            combos.append(base[:i] + [v] + base[i + 1:])
    return combos


def _check_one(overrides: list[str], multirun: bool, config_name: str = "config") -> None:
    try:
        cfg = compose(config_name=config_name, overrides=overrides, return_hydra_config=True)
        outdir = cfg.hydra.sweep.dir if multirun else cfg.hydra.run.dir
    except Exception as exc:  # noqa: BLE001 - turn Hydra's report into one line
        raise ConfigError(_unknown_key_message(exc, overrides, config_name)
                          or _composition_message(exc, overrides)) from None
    _check_output_dir(Path(outdir))
    build(cfg, dict(cfg.hydra.runtime.choices))
    if not multirun:  # a sweep's folders are looked at by its sweeper (sweep_resume.py)
        _check_run_folder(cfg, Path(outdir))


def _check_run_folder(cfg: DictConfig, outdir: Path) -> None:
    """Refuse, before Hydra writes into it, a folder held by a live process or holding a
    run of another configuration (the runner checks again under the lock)."""
    from tmopt.run.run_lock import describe_holder, lock_holder
    from tmopt.run.runner import check_folder_owner

    if not outdir.is_dir():
        return
    holder = lock_holder(outdir)
    if holder is not None:
        raise RunFolderBusy(f"run folder {outdir} is in use by {describe_holder(holder)}")
    task = OmegaConf.masked_copy(cfg, [k for k in cfg if k != "hydra"])
    try:
        check_folder_owner(outdir, config_hash(task), bool(cfg.get("resume", True)))
    except FolderOfAnotherRun as exc:
        raise ConfigError(str(exc)) from None


def _check_output_dir(path: Path) -> None:
    """The output folder must exist as a writable folder or be creatable."""
    ancestor = path
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise ConfigError(f"output folder {path} cannot be created: {ancestor} is a file")
    try:  # try it (os.access says yes to root even where the file system says no)
        tempfile.TemporaryDirectory(dir=ancestor, prefix=".tmopt-probe-").cleanup()
    except OSError as exc:
        raise ConfigError(f"output folder {path} cannot be created: {ancestor} is not "
                          f"writable ({exc.strerror or exc})") from None


def _unknown_key_message(exc: Exception, overrides: list[str],
                         config_name: str = "config") -> str | None:
    """``unknown key a.b; did you mean 'c'? allowed keys: ...`` for Hydra's "Key 'b' is
    not in struct" (composed once more without that override, to list the keys)."""
    text = f"{exc} {exc.__cause__ or ''}"
    found = re.search(r"Could not override '([\w.]+)'", text)
    if not found or "not in struct" not in text:
        return None
    path = found[1]
    parent, _, key = path.rpartition(".")
    others = [o for o in overrides if o.split("=", 1)[0].lstrip("+~") != path]
    try:
        node = compose(config_name=config_name, overrides=others)
        node = OmegaConf.select(node, parent) if parent else node
        keys = [str(k) for k in node if not str(k).startswith("_")]
    except Exception:  # noqa: BLE001 - fall back to Hydra's own words
        return None
    return f"unknown key {path};{did_you_mean(key, keys)} allowed keys: {', '.join(keys)}"


def _composition_message(exc: Exception, overrides: list[str]) -> str:
    text = _first_line(exc)
    cause = exc.__cause__ or exc.__context__
    if cause is not None and _first_line(cause) not in text:
        text = f"{text}: {_first_line(cause)}"
    return f"invalid configuration ({' '.join(overrides) or 'defaults'}): {text}"


def _first_line(exc: BaseException) -> str:
    lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
    return lines[0] if lines else type(exc).__name__


class _hydra_context:
    """Hydra's compose API on the search path of ``sources`` (default: tmopt's own
    configuration), cleared afterwards."""

    def __init__(self, sources: ConfigSources | None = None) -> None:
        self.sources = sources or ConfigSources()

    def __enter__(self):
        GlobalHydra.instance().clear()
        hydra_version.setbase(None)
        Hydra.create_main_hydra2(task_name="tmopt", config_search_path=self.sources.search_path())
        return self

    def __exit__(self, *exc):
        GlobalHydra.instance().clear()
        return False


# ---- the Hydra task -------------------------------------------------------------------
def run_from_config(cfg: DictConfig) -> dict | None:
    """Build, run and report one configuration inside a Hydra job."""
    hc = HydraConfig.get()
    choices = dict(hc.runtime.choices)
    outdir = Path(hc.runtime.output_dir)
    multirun = hc.mode == RunMode.MULTIRUN
    try:
        problem, algorithm = build(cfg, choices)
        from tmopt.run.runner import run_optimisation

        # the runner holds the folder's lock and writes config.yaml once the folder is
        # known to be this run's (a refused run leaves another run's folder as it was)
        result = run_optimisation(
            problem, algorithm, budget=cfg.budget, seed=cfg.seed, outdir=outdir,
            config_hash=config_hash(cfg), resume=cfg.resume, progress=cfg.progress,
            plots=cfg.plots, extra_metrics=getattr(problem, "extra_metrics", None),
            eval_time_limit=cfg.eval_time_limit,
            config_text=OmegaConf.to_yaml(cfg, resolve=True))
    except (RunFolderBusy, FolderOfAnotherRun) as exc:  # leave the folder as it is
        log.error("tmopt: not run: %s", exc)
        if not multirun:
            sys.exit(1)
        return None
    except (ConfigError, ArchiveError, OSError) as exc:
        _record_failure(outdir, exc)
        log.error("tmopt: error: %s", exc)
        if not multirun:
            sys.exit(2 if isinstance(exc, ConfigError) else 1)
        return None
    print(summary_table(result.metrics, outdir))
    return result.metrics


def _record_failure(outdir: Path, exc: Exception) -> None:
    try:
        outdir.mkdir(parents=True, exist_ok=True)
        atomic_write_text(outdir / "failure.json",
                          json.dumps({"error": type(exc).__name__, "message": str(exc)}))
    except OSError:
        pass


def summary_table(metrics: dict, outdir: Path | None = None) -> str:
    """Markdown table of a finished run's result."""
    prob = metrics["problem"]
    chosen = metrics.get("chosen") or {}
    rows = [f"## {prob['name']} / {metrics['algorithm']} / seed {metrics['seed']}", "",
            "| quantity | value |", "|---|---|",
            f"| real evaluations | {metrics['n_evals']} / {metrics['budget']} |",
            f"| feasible share | {_fmt(metrics['feasible_ratio'])} |",
            f"| final non-dominated set | {metrics['pareto_size']} designs |"]
    for name, v in zip(prob["objectives"], metrics.get("best_objectives") or []):
        rows.append(f"| best feasible {name} | {_fmt(v)} |")
    label = "chosen (Eq. 21)" if chosen.get("feasible") else "least-violating (none feasible)"
    for name, v in (chosen.get("F") or {}).items():
        rows.append(f"| {label} {name} | {_fmt(v)} |")
    for key, v in (metrics.get("identification") or {}).items():
        if isinstance(v, float) and key not in prob["objectives"]:  # those are shown above
            rows.append(f"| chosen: {key} | {_fmt(v)} |")
    rows += _heldout_rows(metrics)
    for key in ("igd", "igd_plus", "hv"):
        if metrics.get(key) is not None:
            rows.append(f"| {key} | {_fmt(metrics[key])} |")
    rows.append(f"| wall time | {metrics['wall_time_s']:.1f} s |")
    if outdir is not None:
        rows += ["", f"outputs: {outdir}"]
    return "\n".join(rows)


def _heldout_rows(metrics: dict) -> list[str]:
    """The chosen design on held-out noise seeds and the physical floor (stiffness runs)."""
    rows = []
    held = metrics.get("heldout")
    if held:
        n = held["n_seeds"]
        for q in ("M", "convergence_time", "convergence_accuracy", "final_accuracy"):
            st = held[q]
            rows.append(f"| chosen, held-out ({n} seeds): {q} | {_fmt(st['mean'])} ± "
                        f"{_fmt(st['std'])} (median {_fmt(st['median'])}) |")
        rows.append(f"| chosen, held-out runs keeping Eq. 20 | {_fmt(held['eq20_share'])} |")
    floor = metrics.get("floor")
    if floor:
        line = (f"final accuracy >= {_fmt(floor['final_accuracy_mean'])} (mean |error|), "
                f"M >= {_fmt(floor['M'])}")
        if "convergence_accuracy_mean" in floor:
            line += (f", convergence accuracy >= {_fmt(floor['convergence_accuracy_mean'])} "
                     f"at {_fmt(floor['convergence_time'])} s")
        rows.append(f"| physical floor ({floor['parameter']}) | {line} |")
        if floor.get("below_floor"):
            rows.append(f"| below the floor (noise luck) | {', '.join(floor['below_floor'])} |")
    return rows


def _fmt(v) -> str:
    return "n/a" if v is None else f"{v:.4g}"


@hydra.main(version_base=None, config_path=CONF_SOURCE, config_name="config")
def _hydra_main(cfg: DictConfig) -> None:
    run_from_config(cfg)


def force_swept_group_keys(args: list[str]) -> list[str]:
    """In a sweep over a group, override that group's keys with ``++``.

    Hydra composes a sweep's base configuration with the group's *default* option, where
    a key of the swept options (``algorithm.n_init`` while sweeping ``algorithm=a,b``)
    may not exist, and refuses it. ``++`` (add or override) lets each job's own option
    take it; pre-flight still rejects a key that an option does not accept.
    """
    if not MULTIRUN_FLAGS.intersection(args):
        return args
    try:
        parsed = OverridesParser.create().parse_overrides(
            get_args_parser().parse_known_args(args)[0].overrides)
    except Exception:  # noqa: BLE001 - pre-flight reports grammar errors
        return args
    swept = {ov.get_key_element() for ov in parsed
             if ov.is_sweep_override() and ov.get_key_element() in GROUPS}
    return [f"++{a}" if not a.startswith(("-", "+", "~")) and "=" in a
            and a.split("=", 1)[0].split(".", 1)[0] in swept and "." in a.split("=", 1)[0]
            else a for a in args]


def main() -> None:
    """Console entry: pre-flight every configuration, then hand over to Hydra."""
    sys.argv[1:] = force_swept_group_keys(sys.argv[1:])
    args = sys.argv[1:]
    try:
        if INFO_FLAGS.intersection(args):
            register_configs(*config_sources(args).folders())
        else:
            preflight(args)
    except ConfigError as exc:
        print(f"tmopt: error: {exc}", file=sys.stderr)
        sys.exit(2)
    except RunFolderBusy as exc:
        print(f"tmopt: not run: {exc}", file=sys.stderr)
        sys.exit(1)
    _hydra_main()
