"""Progress of a run: a log line per generation and, in a terminal, a tqdm bar."""

from __future__ import annotations

import logging
import sys

import numpy as np
from tqdm import tqdm

from tmopt.evaluation.archive import ArchiveData
from tmopt.metrics import igd, metric_m, non_dominated_feasible

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


class _NotOnTheConsole(logging.Filter):
    """Keeps progress lines off console handlers while the bar shows them there."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not getattr(record, "progress_line", False)


class ProgressReporter:
    """One line per generation in the log (``tmopt.log`` of a run folder); in a terminal
    also a tqdm bar, which then replaces the line on the console.

    The bar is shown only when both stdout and stderr are terminals, so sweeps, CI and
    redirected output get the log lines alone. Each line: generation, evaluations used of
    the budget, feasible share, IGD of the feasible non-dominated set where the problem's
    front is known (``front``), the best M (Eq. 29, TM1) where the objectives are its
    convergence time and accuracy (``m_weights``: the stiffness problem's), the best value
    of each objective among feasible designs, and the algorithm's stage (:meth:`Algorithm.info`).
    """

    def __init__(self, budget: int, objective_names: list[str], enabled: bool = True,
                 front: np.ndarray | None = None,
                 m_weights: tuple[float, float] | None = None) -> None:
        self.budget = budget
        self.names = objective_names
        self.enabled = enabled
        self.front = front
        # Eq. 29's M of TM1 where the objectives are its time and accuracy (stiffness)
        pair = ("convergence_time_TM1", "convergence_accuracy_TM1")
        self.m_columns = [objective_names.index(n) for n in pair] \
            if m_weights is not None and all(n in objective_names for n in pair) else None
        self.m_weights = m_weights
        terminal = sys.stdout.isatty() and sys.stderr.isatty()
        self.bar = tqdm(total=budget, unit="eval", file=sys.stderr, dynamic_ncols=True) \
            if enabled and terminal else None
        self._quiet: list[logging.Handler] = []
        if self.bar is not None:
            self._quiet = [h for h in _handlers(log) if not isinstance(h, logging.FileHandler)]
            for handler in self._quiet:
                handler.addFilter(_QUIET)

    def igd(self, data: ArchiveData) -> float | None:
        """IGD of the feasible non-dominated designs so far (None without a front)."""
        if self.front is None:
            return None
        keep = non_dominated_feasible(data.F, data.G, data.failed)
        return float(igd(data.F[keep], self.front)) if len(keep) else None

    def best_m(self, data: ArchiveData) -> float | None:
        """Smallest M (Eq. 29, TM1) among feasible designs so far (None where not defined)."""
        if self.m_columns is None:
            return None
        keep = non_dominated_feasible(data.F, data.G, data.failed)
        if not len(keep):
            return None
        F = data.F[keep]
        return float(np.min(metric_m(F[:, self.m_columns[0]], F[:, self.m_columns[1]],
                                     *self.m_weights)))

    def line(self, gen: int, data: ArchiveData, info: dict, replaying: bool = False) -> str:
        best = best_so_far(data)
        best_txt = "none feasible" if best is None else " ".join(
            f"{n}={v:.4g}" for n, v in zip(self.names, best))
        distance = self.igd(data)
        igd_txt = "" if distance is None else f" | IGD {distance:.4g}"
        m = self.best_m(data)
        igd_txt += "" if m is None else f" | best M {m:.4g}"
        extra = " ".join(f"{k}={v}" for k, v in info.items())
        tag = " (replayed from archive)" if replaying else ""
        return (f"gen {gen:4d} | evals {len(data)}/{self.budget} | feasible "
                f"{100 * feasible_share(data):5.1f}%{igd_txt} | best {best_txt}"
                + (f" | {extra}" if extra else "") + tag)

    def update(self, gen: int, data: ArchiveData, info: dict, replaying: bool = False) -> None:
        if not self.enabled:
            return
        text = self.line(gen, data, info, replaying)
        log.info(text, extra={"progress_line": True})
        if self.bar is not None:
            head, _, tail = text.partition(" | feasible ")
            self.bar.n = len(data)
            self.bar.set_description_str(head.split(" | ")[0], refresh=False)
            self.bar.set_postfix_str("feasible " + tail, refresh=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
        for handler in self._quiet:
            handler.removeFilter(_QUIET)
        self._quiet = []


_QUIET = _NotOnTheConsole()


def _handlers(logger: logging.Logger) -> list[logging.Handler]:
    """The handlers a record of ``logger`` reaches (it and its ancestors while propagating)."""
    found, current = [], logger
    while current is not None:
        found += current.handlers
        current = current.parent if current.propagate else None
    return found
