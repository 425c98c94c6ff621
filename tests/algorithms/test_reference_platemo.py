"""``algorithm.reference=platemo``'s arguments came after runs were made: at their defaults
they leave every earlier configuration's hash alone (those runs resume and are skipped),
and any other value is a different configuration."""

from __future__ import annotations

import pytest
from omegaconf import OmegaConf

from tmopt.run.cli import option_config
from tmopt.run.config import PLATEMO_PARITY_ARGUMENTS, config_hash

RUN = {"seed": 0, "budget": 300, "problem": {"_target_": "x.Problem"}}
OPTIONS = {"ctsea.CTSEA": "ctsea", "cmoes.CMOES": "cmoes", "ssde.SSDE": "ssde",
           "kts.KTS": "kts", "pea.PEA": "pea", "drlsaea.DRLSAEA": "drlsaea"}


def _hash(node: dict) -> str:
    return config_hash(OmegaConf.create({**RUN, "algorithm": node}))


@pytest.mark.parametrize("target", sorted(PLATEMO_PARITY_ARGUMENTS))
def test_new_arguments_at_their_defaults_keep_the_earlier_hash(target):
    node = OmegaConf.to_container(option_config("algorithm", OPTIONS[target]))
    added = PLATEMO_PARITY_ARGUMENTS[target]
    assert set(added) <= set(node)
    earlier = {k: v for k, v in node.items() if k not in added}
    assert _hash(node) == _hash(earlier)
    assert _hash({**node, "reference": "platemo"}) != _hash(earlier)
    for key in added:
        assert _hash({**node, key: "changed"}) != _hash(earlier), key


def test_every_algorithm_with_parity_arguments_is_covered():
    assert set(OPTIONS) == set(PLATEMO_PARITY_ARGUMENTS)
