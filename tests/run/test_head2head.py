"""The head-to-head preset (issue 24): its sweep is valid before anything runs, and the
documented split of the full comparison (DAS-CMOP at 500 only) is needed and sufficient."""

from __future__ import annotations

from pathlib import Path

import pytest
from omegaconf import OmegaConf

from tmopt.run.cli import preflight
from tmopt.run.config import ConfigError

PRESET = Path(__file__).resolve().parents[2] / "tmopt" / "conf" / "experiment" / \
    "head2head.yaml"
ISSUE_24_ALGORITHMS = {"mgsaea", "mgsaea_ipc", "mgsaea_star", "kts", "drlsaea", "pea",
                       "qlognehvi"}


def test_the_preset_sweeps_the_seven_algorithms_and_every_value_is_valid():
    params = OmegaConf.load(PRESET).hydra.sweeper.params
    assert set(params.algorithm.split(",")) == ISSUE_24_ALGORITHMS
    sweep = [f"{key}={value}" for key, value in params.items()]
    assert preflight(["-m", "experiment=head2head", *sweep]) > 0


def test_dascmop_needs_the_larger_budget_for_the_mgsaea_family():
    with pytest.raises(ConfigError, match="initial sample of 329 .* dascmop1"):
        preflight(["-m", "experiment=head2head", "algorithm=drlsaea", "problem=dascmop1",
                   "budget=300"])
    assert preflight(["-m", "experiment=head2head", "algorithm=mgsaea_ipc,kts,drlsaea,pea",
                      "problem=dascmop1", "budget=500"]) > 0
