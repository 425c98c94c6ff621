"""Run folders of a sweep: find them, read them, and say what varies between them.

A run folder is what ``python -m tmopt`` leaves for one configuration: Hydra's
``.hydra/`` (overrides, choices), ``config.yaml`` (resolved), ``metrics.json`` (written
last, ``status: complete``), ``failure.json`` when the run stopped on an error, and
``archive.h5`` as the run goes. Its status here:

- ``complete``: ``metrics.json`` says so (a stale ``failure.json`` from an earlier attempt
  is then ignored, because a re-run that finished supersedes it);
- ``failed``: ``failure.json`` and no complete ``metrics.json``;
- ``incomplete``: neither (interrupted, or still running); the archive tells how far.

Runs are described by *effective* settings read from their configuration, not by the
folder name: a run of ``algorithm=nsga2 seed=0`` and a run of ``scheme=B
problem.n_freq=3`` with the default algorithm are the same setting if their resolved
configurations agree, whichever sweep (or launcher) produced them.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from omegaconf import OmegaConf

from tmopt.run.config import UNKNOWN, earlier_value

COMPLETE, FAILED, INCOMPLETE = "complete", "failed", "incomplete"
#: Config groups of tmopt/conf/ (their effective value is Hydra's recorded choice).
GROUP_KEYS = ("problem", "algorithm", "surrogate", "scheme", "experiment")
#: Keys that never define a setting (how a run is shown or stored, or which launcher).
IGNORED_KEYS = ("seed", "name", "resume", "progress", "plots")
#: Folders inside a sweep that are never runs.
SKIP_DIRS = (".hydra", ".submitit", "collected", "__pycache__")
#: Settings every table shows even when they do not vary within the sweep.
ALWAYS_KEYS = ("problem", "algorithm")


@dataclass
class RunRecord:
    """One run folder, read once.

    Attributes:
        path: The folder.
        status: ``complete``, ``failed`` or ``incomplete``.
        overrides: Command-line overrides of the run (``key -> value``), seed included.
        choices: Hydra's config group choices (``algorithm -> nsga2``).
        config: Resolved configuration (``config.yaml``; ``.hydra/config.yaml`` if absent).
        metrics: ``metrics.json`` when complete.
        failure: ``failure.json`` when failed.
        n_evals: Real evaluations done (metrics, else the archive; None if unknown).
        name: The folder relative to the sweep folder (for tables).
    """

    path: Path
    status: str
    overrides: dict[str, str] = field(default_factory=dict)
    choices: dict[str, str | None] = field(default_factory=dict)
    config: dict = field(default_factory=dict)
    metrics: dict | None = None
    failure: dict | None = None
    n_evals: int | None = None
    name: str = ""

    @property
    def seed(self) -> int | None:
        seed = self.config.get("seed", self.overrides.get("seed"))
        return None if seed is None else int(seed)

    @property
    def budget(self) -> int | None:
        budget = self.config.get("budget")
        return None if budget is None else int(budget)

    def value(self, key: str) -> str:
        """Effective value of a setting key (group choice or dotted config key) as text.

        A key the run's configuration does not have is the value the run ran with when
        the argument came after the run (the hash-neutral registries of
        :mod:`tmopt.run.config`: :func:`~tmopt.run.config.earlier_value`), else ``""``
        (e.g. ``algorithm.batch_size`` of an algorithm without that parameter), unlike a
        key set to null (``None``).
        """
        if key in GROUP_KEYS:
            choice = self.choices.get(key) or self.overrides.get(key)
            if choice is None and key == "algorithm" and self.metrics:
                choice = self.metrics.get("algorithm")
            return str(choice)
        group, _, argument = key.partition(".")
        node: object = self.config
        for part in key.split("."):
            if not isinstance(node, dict) or part not in node:
                if key in self.overrides:
                    return str(self.overrides[key])
                # an argument of a group's node that came after this run was made
                earlier = earlier_value(group, node, argument) if part == argument \
                    and isinstance(node, dict) else UNKNOWN  # fmt: skip
                return "" if earlier is UNKNOWN else _text(earlier)
            node = node[part]
        return _text(node)

    @property
    def identification(self) -> dict:
        return (self.metrics or {}).get("identification") or {}

    @property
    def is_stiffness(self) -> bool:
        target = str((self.config.get("problem") or {}).get("_target_", ""))
        return target.endswith("StiffnessProblem") or self.value("problem") == "stiffness"


def _text(value) -> str:
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e15:
        return str(int(value))
    return str(value)


# ---- discovery ----------------------------------------------------------------------
def discover_runs(sweep_dir: str | Path) -> list[RunRecord]:
    """Every run folder under ``sweep_dir`` (itself included), sorted by path."""
    root = Path(sweep_dir)
    if not root.is_dir():
        raise FileNotFoundError(f"sweep folder {root} does not exist")
    runs = [read_run(p) for p in sorted(_run_dirs(root))]
    for run in runs:
        run.name = str(run.path.relative_to(root)) if run.path != root else run.path.name
    return runs


def _run_dirs(root: Path) -> Iterable[Path]:
    markers = ("metrics.json", "failure.json", "config.yaml", "archive.h5")
    stack = [root]
    while stack:
        folder = stack.pop()
        if (folder / ".hydra").is_dir() or any((folder / m).exists() for m in markers):
            yield folder
        stack += [p for p in folder.iterdir() if p.is_dir() and p.name not in SKIP_DIRS]


def read_run(path: Path) -> RunRecord:
    """Read one run folder (never raises for a damaged run: it is reported instead)."""
    metrics = _json(path / "metrics.json")
    failure = _json(path / "failure.json")
    run = RunRecord(path=path, status=INCOMPLETE, overrides=_overrides(path),
                    choices=_choices(path), config=_config(path))
    if metrics is not None and metrics.get("status") == COMPLETE:
        run.status, run.metrics, run.n_evals = COMPLETE, metrics, metrics.get("n_evals")
        return run
    if failure is not None:
        run.status, run.failure = FAILED, failure
    run.n_evals = _archive_rows(path / "archive.h5")
    return run


def _json(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def _overrides(path: Path) -> dict[str, str]:
    raw = _yaml(path / ".hydra" / "overrides.yaml")
    items = raw if isinstance(raw, list) else _split_dirname(path.name)
    out: dict[str, str] = {}
    for item in items:
        key, sep, value = str(item).partition("=")
        if sep and not key.startswith("hydra"):
            out[key.lstrip("+~")] = value
    return out


def _split_dirname(name: str) -> list[str]:
    """``a=1,b=x`` -> ``["a=1", "b=x"]`` (a folder name written by Hydra's override_dirname)."""
    parts: list[str] = []
    for piece in name.split(","):
        if "=" in piece or not parts:
            parts.append(piece)
        else:  # a comma inside a value, e.g. a list
            parts[-1] += "," + piece
    return [p for p in parts if "=" in p]


def _choices(path: Path) -> dict[str, str | None]:
    hydra_cfg = _yaml(path / ".hydra" / "hydra.yaml", resolve=False)
    try:
        choices = hydra_cfg["hydra"]["runtime"]["choices"]
    except (KeyError, TypeError):
        return {}
    return {k: v for k, v in choices.items() if not str(k).startswith("hydra/")}


def _config(path: Path) -> dict:
    resolved = _yaml(path / "config.yaml")
    if isinstance(resolved, dict):
        return resolved
    composed = _yaml(path / ".hydra" / "config.yaml")
    return composed if isinstance(composed, dict) else {}


def _yaml(path: Path, resolve: bool = True):
    if not path.is_file():
        return None
    try:
        return OmegaConf.to_container(OmegaConf.load(path), resolve=resolve)
    except Exception:  # noqa: BLE001 - a damaged file means "unknown", reported as such
        try:
            return OmegaConf.to_container(OmegaConf.load(path), resolve=False)
        except Exception:  # noqa: BLE001
            return None


def _archive_rows(path: Path) -> int | None:
    if not path.is_file():
        return None
    from tmopt.evaluation.archive import ArchiveError, read_archive

    try:
        return len(read_archive(path))
    except (ArchiveError, OSError):
        return None


# ---- settings -----------------------------------------------------------------------
def setting_keys(runs: list[RunRecord]) -> list[str]:
    """Keys whose effective value differs between runs (seed excluded), group keys first."""
    keys = set(ALWAYS_KEYS)
    for run in runs:
        keys.update(k for k in run.overrides if k not in IGNORED_KEYS)
    varying = [k for k in keys if k in ALWAYS_KEYS or len({r.value(k) for r in runs}) > 1]
    varying += [k for k in _unnamed_differences(runs, varying) if k not in varying]
    order = {k: i for i, k in enumerate(GROUP_KEYS)}
    return sorted(varying, key=lambda k: (order.get(k, len(order)), k))


def _unnamed_differences(runs: list[RunRecord], keys: list[str]) -> list[str]:
    """Configuration keys no override names that still differ between runs of one setting:
    a default changed between two sweeps (qLogNEHVI's ``gp_guard_max_iter``, null then 5)
    leaves both sweeps' folders with the same overrides, and pooling them would average two
    configurations as one.  Values are effective values (:meth:`RunRecord.value`: an
    argument added later reads as what the older run ran with)."""
    out: set[str] = set()
    for group in group_runs(runs, keys).values():
        if len(group) < 2:
            continue
        leaves = set().union(*(_leaves(r.config) for r in group))
        out.update(k for k in leaves
                   if k.split(".")[0] not in IGNORED_KEYS and k.split(".")[0] != "hydra"
                   and len({r.value(k) for r in group}) > 1)  # fmt: skip
    return sorted(out)


def _leaves(node: object, prefix: str = "") -> set[str]:
    """Dotted keys of a nested configuration's leaves (a list is one leaf)."""
    if not isinstance(node, dict):
        return {prefix} if prefix else set()
    out: set[str] = set()
    for k, v in node.items():
        out |= _leaves(v, f"{prefix}.{k}" if prefix else str(k))
    return out


def setting_of(run: RunRecord, keys: list[str]) -> tuple[tuple[str, str], ...]:
    return tuple((k, run.value(k)) for k in keys)


def group_runs(runs: list[RunRecord], keys: list[str]) -> dict[tuple, list[RunRecord]]:
    """Runs grouped by their values of ``keys`` (insertion order = first appearance)."""
    groups: dict[tuple, list[RunRecord]] = {}
    for run in runs:
        groups.setdefault(setting_of(run, keys), []).append(run)
    return groups


def deduplicate(runs: list[RunRecord]) -> tuple[list[RunRecord], list[RunRecord]]:
    """Drop complete runs that repeat another's configuration and seed (same config hash).

    Two sweeps written into one folder may both contain e.g. scheme B, 3 frequencies,
    seed 0; counting that run twice would bias the mean. Returns (kept, dropped).
    """
    seen: set[str] = set()
    kept, dropped = [], []
    for run in runs:
        key = (run.metrics or {}).get("config_hash") if run.status == COMPLETE else None
        if key and key in seen:
            dropped.append(run)
            continue
        if key:
            seen.add(key)
        kept.append(run)
    return kept, dropped
