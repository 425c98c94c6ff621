"""The step features' fine onset search (docs/mismatch.md 9.10; ``generic.FINE_ONSETS``)."""

from __future__ import annotations

import numpy as np

from tmopt.mismatch.generic import _adjoint_whiten
from tmopt.mismatch.noise_model import Layout, NoiseModel


def test_the_onset_search_uses_the_adjoint_of_the_whitening():
    """``<W x, y> = <x, W' y>`` for the coloured (coupled, two segments) and the white
    model: the fine onset search's numerators are exact cumulative sums of ``W' e``."""
    rng = np.random.default_rng(3)
    n = 3000
    red = np.cumsum(rng.standard_normal((2, n)), axis=1) * 0.05
    residual = rng.standard_normal((2, n)) + red + 0.3 * rng.standard_normal(n)
    layout = Layout(((0, 1800), (1800, n)), n)
    for kind in ("smoothed", "white"):
        noise = NoiseModel.estimate(residual, layout, 4.0, kind=kind)
        x, y = rng.standard_normal((2, n)), rng.standard_normal((2, n))
        lhs = float(np.sum(noise.whiten(x) * y))
        rhs = float(np.sum(x * _adjoint_whiten(noise, y)))
        assert abs(lhs - rhs) < 1e-6 * np.sqrt(np.sum(x**2) * np.sum(y**2)), (kind, lhs, rhs)
