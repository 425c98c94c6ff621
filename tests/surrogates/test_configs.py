"""tmopt/conf/surrogate/*.yaml build the models the way algorithms receive them (a factory)."""

from __future__ import annotations

from functools import partial

import pytest
from omegaconf import OmegaConf

from tmopt.run.cli import option_config
from tmopt.run.config import check_node
from tmopt.surrogates.base import Surrogate


@pytest.mark.parametrize("name", ["gp", "rbf"])
def test_config_builds_a_working_factory(name, smooth3):
    node = option_config("surrogate", name)
    cls = check_node("surrogate", node, name)
    kwargs = {k: v for k, v in OmegaConf.to_container(node).items() if not k.startswith("_")}
    factory = partial(cls, **kwargs)
    first, second = factory(), factory()
    assert isinstance(first, Surrogate) and first is not second
    X, Y, _ = smooth3
    mean, std = first.fit(X, Y).predict(X[:3])
    assert mean.shape == std.shape == (3, 3)
    assert first.name == name
