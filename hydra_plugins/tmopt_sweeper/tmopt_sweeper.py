"""``hydra/sweeper=tmopt``: Hydra's basic sweeper, less the runs that need no launching.

The cartesian product, batching and launching are Hydra's :class:`BasicSweeper`'s. Before
the first batch is launched every job of the sweep is composed (as the basic sweeper's own
validation and the launcher compose it) and classified by
:func:`tmopt.run.sweep_resume.plan_sweep`; one summary line says what is skipped, resumed and
started, and each batch goes to the launcher without its skipped and running jobs. A sweep
without ``name=`` gets a name derived from its overrides (:func:`tmopt.run.config.sweep_name`),
so sweeps do not all land in ``multirun/default``.
"""

# No `from __future__ import annotations`: Hydra execs plugin modules outside sys.modules,
# where dataclasses cannot resolve string annotations.
import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Optional

from hydra._internal.core_plugins.basic_sweeper import BasicSweeper, BasicSweeperConf
from hydra.core.config_store import ConfigStore
from omegaconf import open_dict, read_write

from tmopt.run.config import sweep_name
from tmopt.run.sweep_resume import RunPlan, detail_lines, job_target, plan_sweep, summary_line

log = logging.getLogger(__name__)


@dataclass
class TmoptSweeperConf(BasicSweeperConf):
    _target_: str = "hydra_plugins.tmopt_sweeper.tmopt_sweeper.ResumingSweeper"


ConfigStore.instance().store(group="hydra/sweeper", name="tmopt", node=TmoptSweeperConf,
                             provider="tmopt")


class ResumingSweeper(BasicSweeper):
    """Basic sweeper that launches only the jobs whose runs are not finished."""

    def __init__(self, max_batch_size: Optional[int] = None,  # noqa: UP045
                 params: Optional[dict] = None) -> None:  # noqa: UP045
        super().__init__(max_batch_size=max_batch_size, params=params)
        self.plans: Optional[dict[tuple[str, ...], RunPlan]] = None  # noqa: UP045

    def sweep(self, arguments: list[str]):
        self.plans = None
        if not self.config.get("name"):  # a sweep without name=: one derived from its overrides
            name = sweep_name("", arguments)
            with read_write(self.config), open_dict(self.config):
                self.config.name = name
            arguments = [*arguments, f"name='{name}'"]  # quoted: it holds '=' and '+'

        return super().sweep(arguments)

    def is_done(self) -> bool:
        self._plan()
        # batches with nothing to launch are passed over (a launcher refuses an empty one)
        while self.batch_index < len(self.overrides) and not any(
                self.plans[tuple(job)].launch for job in self.overrides[self.batch_index]):
            self.batch_index += 1
        return super().is_done()

    def get_job_batch(self) -> Sequence[Sequence[str]]:
        return [job for job in super().get_job_batch() if self.plans[tuple(job)].launch]

    def validate_batch_is_legal(self, batch: Sequence[Sequence[str]]) -> None:
        """Already done: planning composed every job with the same call."""

    def _plan(self) -> None:
        if self.plans is not None:
            return
        jobs = [job for batch in self.overrides for job in batch]
        loader = self.hydra_context.config_loader

        def target_of(overrides: Sequence[str]):
            return job_target(loader.load_sweep_config(self.config, list(overrides)))

        plans = plan_sweep(jobs, target_of)
        self.plans = {p.overrides: p for p in plans}
        print(summary_line(plans), flush=True)
        for line in detail_lines(plans):
            log.info(line)
