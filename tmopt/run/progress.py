"""One progress line (or bar) per generation: evaluations used, best objectives, feasibility."""

from __future__ import annotations

import logging
import sys

import numpy as np
from tqdm import tqdm

from tmopt.evaluation.archive import ArchiveData

log = logging.getLogger("tmopt.progress")


def best_so_far(data: ArchiveData) -> np.ndarray | None:
    """Per-objective minimum over feasible, non-failed evaluations (None if there are none)."""
    ok = ~data.failed
    if data.G.shape[1]:
        ok &= np.all(np.nan_to_num(data.G, nan=np.inf) <= 0.0, axis=1)
    return data.F[ok].min(axis=0) if ok.any() else None


def feasible_share(data: ArchiveData) -> float:
    if len(data) == 0:
        return float("nan")
    ok = ~data.failed
    if data.G.shape[1]:
        ok &= np.all(np.nan_to_num(data.G, nan=np.inf) <= 0.0, axis=1)
    return float(ok.mean())


class ProgressReporter:
    """Logs a line per generation; shows a tqdm bar instead when stderr is a terminal."""

    def __init__(self, budget: int, objective_names: list[str], enabled: bool = True) -> None:
        self.budget = budget
        self.names = objective_names
        self.enabled = enabled
        self.bar = tqdm(total=budget, unit="eval", file=sys.stderr, dynamic_ncols=True) \
            if enabled and sys.stderr.isatty() else None

    def line(self, gen: int, data: ArchiveData, info: dict, replaying: bool = False) -> str:
        best = best_so_far(data)
        best_txt = "none feasible" if best is None else " ".join(
            f"{n}={v:.4g}" for n, v in zip(self.names, best))
        extra = " ".join(f"{k}={v}" for k, v in info.items())
        tag = " (replayed from archive)" if replaying else ""
        return (f"gen {gen:4d} | evals {len(data)}/{self.budget} | feasible "
                f"{100 * feasible_share(data):5.1f}% | best {best_txt}"
                + (f" | {extra}" if extra else "") + tag)

    def update(self, gen: int, data: ArchiveData, info: dict, replaying: bool = False) -> None:
        if not self.enabled:
            return
        text = self.line(gen, data, info, replaying)
        if self.bar is not None:
            self.bar.n = len(data)
            self.bar.set_description_str(text.split(" | best")[0], refresh=False)
            self.bar.set_postfix_str(text.split(" | ", 3)[-1], refresh=True)
        else:
            log.info(text)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
