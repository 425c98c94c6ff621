"""CachedJointGP: the same joint posterior and qLogNEHVI as through BoTorch/GPyTorch."""

from __future__ import annotations

import pytest
import torch
from botorch.acquisition.multi_objective.logei import (
    qLogNoisyExpectedHypervolumeImprovement,
)
from botorch.acquisition.multi_objective.objective import IdentityMCMultiOutputObjective
from botorch.sampling import SobolQMCNormalSampler
from botorch.utils.low_rank import extract_batch_covar

from tmopt.surrogates.base import SurrogateError
from tmopt.surrogates.gp import GPSurrogate
from tmopt.surrogates.gp_posterior import CachedJointGP, JointCovariance

D = torch.float64


@pytest.fixture(scope="module", params=["rbf", "matern52"])
def gp(request, smooth3):
    X, Y, _ = smooth3
    return GPSurrogate(kernel=request.param, max_iter=30).fit(X, Y)


def _dense(posterior):
    return posterior.mean, extract_batch_covar(posterior.distribution).to_dense()


def _assert_same(a, b):
    (ma, ca), (mb, cb) = _dense(a), _dense(b)
    scale = cb.abs().max()
    torch.testing.assert_close(ma, mb, rtol=1e-9, atol=1e-9)
    torch.testing.assert_close(ca, cb, rtol=0, atol=1e-9 * scale)


def test_posterior_equals_botorch_without_and_with_remembered_rows(gp):
    fast, base = CachedJointGP(gp), gp.model
    rng = torch.Generator().manual_seed(0)
    Z = torch.rand(7, 4, generator=rng, dtype=D) * 3 - 1
    with torch.no_grad():
        _assert_same(fast.posterior(Z), base.posterior(Z))       # nothing remembered: all rows
        Xq = torch.rand(3, 2, 4, generator=rng, dtype=D) * 3 - 1   # t-batch of 3, q = 2
        joint = torch.cat([Z.expand(3, -1, -1), Xq], dim=-2)
        post = fast.posterior(joint)                              # Z's rows reused
        assert isinstance(extract_batch_covar(post.distribution), JointCovariance)
        _assert_same(post, base.posterior(joint))
        more = torch.cat([Z, Xq[0]])                              # Z and pending points
        _assert_same(fast.posterior(more), base.posterior(more))  # extends what it remembers
        assert fast._known[0].shape == (9, 4)
        other = torch.rand(5, 4, generator=rng, dtype=D)          # other leading rows
        _assert_same(fast.posterior(other), base.posterior(other))


def test_the_trailing_rows_are_read_without_assembling_and_equal_the_dense_ones(gp):
    fast = CachedJointGP(gp)
    Z = torch.linspace(-1, 2, 24, dtype=D).reshape(6, 4)
    X = torch.cat([Z.expand(2, -1, -1), torch.full((2, 3, 4), 0.3, dtype=D)], dim=-2)
    with torch.no_grad():
        fast.posterior(Z)
        op = extract_batch_covar(fast.posterior(X).distribution)
    dense = op.to_dense()
    torch.testing.assert_close(dense, dense.mT, rtol=0, atol=1e-12 * dense.abs().max())
    for rows in (slice(-3, None), slice(-1, None), slice(7, 9)):
        torch.testing.assert_close(op[..., rows, :].to_dense(), dense[..., rows, :])
    torch.testing.assert_close(op[..., 1:4, :].to_dense(), dense[..., 1:4, :])  # via dense


@pytest.mark.parametrize("pending", [False, True])
def test_qlognehvi_values_and_gradients_equal_botorch(gp, pending):
    """The acquisition BoTorch builds on either model: same values and gradients."""
    torch.manual_seed(3)
    baseline = torch.rand(10, 4, dtype=D) * 3 - 1
    X_pending = torch.rand(2, 4, dtype=D) if pending else None
    Xq = (torch.rand(5, 1, 4, dtype=D) * 3 - 1).requires_grad_(True)

    def acq(model):
        return qLogNoisyExpectedHypervolumeImprovement(
            model=model, ref_point=[-6.0, -20.0], X_baseline=baseline, X_pending=X_pending,
            sampler=SobolQMCNormalSampler(torch.Size([32]), seed=1),
            objective=IdentityMCMultiOutputObjective(outcomes=[0, 1]),
            constraints=[lambda Z: Z[..., 2] - 3.5], prune_baseline=False)

    values = []
    for model in (gp.model, CachedJointGP(gp)):
        v = acq(model)(Xq)
        values.append((v.detach(), torch.autograd.grad(v.sum(), Xq)[0]))
    (v0, g0), (v1, g1) = values
    assert torch.isfinite(v0).all()
    torch.testing.assert_close(v1, v0, rtol=1e-7, atol=1e-9)
    torch.testing.assert_close(g1, g0, rtol=1e-6, atol=1e-8)


def test_other_requests_go_to_the_botorch_model(gp):
    fast = CachedJointGP(gp)
    X = torch.rand(4, 4, dtype=D)
    with torch.no_grad():
        noisy = fast.posterior(X, observation_noise=True)
        torch.testing.assert_close(noisy.variance, gp.model.posterior(
            X, observation_noise=True).variance)
    assert fast.num_outputs == 3 and fast.batch_shape == torch.Size()


def test_a_model_list_or_a_single_output_is_refused(smooth3):
    X, Y, _ = smooth3
    with pytest.raises(SurrogateError, match="one batched GP of >= 2 outputs"):
        CachedJointGP(GPSurrogate(fit_mode="model_list", max_iter=5).fit(X, Y))
    with pytest.raises(SurrogateError, match="one batched GP of >= 2 outputs"):
        CachedJointGP(GPSurrogate(max_iter=5).fit(X, Y[:, :1]))

