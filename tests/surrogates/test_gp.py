"""GP surrogate: accuracy, exact fast prediction, warm start, determinism, fallbacks."""

from __future__ import annotations

import logging

import numpy as np
import pytest
import torch
from botorch.models import ModelListGP, SingleTaskGP
from linear_operator.utils.errors import NotPSDError

import tmopt.surrogates.gp as gp_module
from tmopt.surrogates.base import SurrogateError
from tmopt.surrogates.gp import GPSurrogate


@pytest.fixture(scope="module")
def fitted(smooth3):
    """One fitted model per fit mode on the 3-output problem."""
    X, Y, _ = smooth3
    return {mode: GPSurrogate(fit_mode=mode, warm_start=False).fit(X, Y)
            for mode in ("per_output", "batched", "model_list")}


@pytest.mark.parametrize("name", ["rosenbrock", "ackley"])
def test_r2_on_held_out_points(train_test, r2, name):
    (X, Y), (Xt, Yt) = train_test[name]
    model = GPSurrogate().fit(X, Y)
    assert model.fit_info["stage"] == "mll"
    assert r2(Yt, model.predict_mean(Xt))[0] >= 0.9


@pytest.mark.parametrize("mode", ["per_output", "batched", "model_list"])
def test_fast_predict_equals_botorch_posterior(fitted, smooth3, mode):
    model = fitted[mode]
    Xq = np.random.default_rng(1).uniform(-1.5, 2.5, size=(11, 4))
    mean, std = model.predict(Xq)
    assert mean.shape == std.shape == (11, 3) and mean.dtype == np.float64
    with torch.no_grad():
        post = model.model.posterior(torch.as_tensor(Xq), observation_noise=False)
    np.testing.assert_allclose(mean, post.mean.numpy(), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(std, post.variance.clamp_min(0).sqrt().numpy(),
                               rtol=1e-6, atol=1e-8)
    np.testing.assert_array_equal(model.predict_mean(Xq), mean)
    expected = ModelListGP if mode == "model_list" else SingleTaskGP
    assert isinstance(model.model, expected)


def test_per_output_fit_equals_separate_fits(fitted, smooth3):
    """Copying per-output optima into the batched model changes nothing but the layout."""
    X, _, _ = smooth3
    a, b = fitted["per_output"], fitted["model_list"]
    assert a.fit_info["iterations"] == b.fit_info["iterations"]
    for (ma, sa), (mb, sb) in [(a.predict(X + 0.1), b.predict(X + 0.1))]:
        np.testing.assert_allclose(ma, mb, rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(sa, sb, rtol=1e-6, atol=1e-9)


def test_batched_fit_reaches_the_same_model(fitted, smooth3):
    """Both optimisers maximise the same per-output MLLs from the same start."""
    _, Y, _ = smooth3
    Xt = np.random.default_rng(5).uniform(-1, 2, size=(300, 4))
    a, b = fitted["per_output"].predict(Xt), fitted["batched"].predict(Xt)
    for u, v in zip(a, b):  # mean and std, relative to each output's spread
        assert np.all(np.abs(u - v).max(0) <= 1e-4 * Y.std(0))


def test_single_output_shapes(smooth3):
    X, Y, _ = smooth3
    mean, std = GPSurrogate().fit(X, Y[:, 1]).predict(X[:4])
    assert mean.shape == std.shape == (4, 1)


def test_std_nonnegative_and_smaller_near_data(fitted, smooth3):
    X, _, _ = smooth3
    model = fitted["per_output"]
    _, std_at = model.predict(X)
    _, std_near = model.predict(X + 0.01)
    _, std_far = model.predict(X + 3.0)
    assert np.all(std_at >= 0) and np.all(std_far >= 0)
    assert np.all(std_near < std_far)
    assert np.all(std_at.mean(0) < 0.05 * std_far.mean(0))


def test_deterministic_and_global_rng_untouched(smooth3):
    X, Y, _ = smooth3
    Xq = X[:6] + 0.05
    torch.manual_seed(123)
    before = torch.rand(3)
    torch.manual_seed(123)
    runs = [GPSurrogate(max_attempts=3, seed=7).fit(X, Y).predict(Xq) for _ in range(2)]
    np.testing.assert_array_equal(runs[0][0], runs[1][0])
    np.testing.assert_array_equal(runs[0][1], runs[1][1])
    np.testing.assert_array_equal(torch.rand(3), before)


def test_warm_start_same_quality_fewer_iterations(train_test, r2):
    (X, Y), (Xt, Yt) = train_test["ackley"]
    warm = GPSurrogate(warm_start=True, refit_every=1).fit(X[:250], Y[:250])
    warm.fit(X, Y)
    cold = GPSurrogate(warm_start=False).fit(X, Y)
    assert warm.fit_info["warm_started"] and not cold.fit_info["warm_started"]
    assert sum(warm.fit_info["iterations"]) < sum(cold.fit_info["iterations"])
    r2_warm, r2_cold = r2(Yt, warm.predict_mean(Xt))[0], r2(Yt, cold.predict_mean(Xt))[0]
    assert r2_warm >= 0.9 and abs(r2_warm - r2_cold) < 0.01


def test_refit_every_keeps_hyperparameters_between_optimisations(smooth3):
    X, Y, f = smooth3
    rng = np.random.default_rng(8)
    model = GPSurrogate(refit_every=3, refit_guard=None)
    stages, lengthscales = [], []
    for _ in range(4):
        model.fit(X, Y)
        stages.append(model.fit_info["stage"])
        lengthscales.append(model.model.covar_module.lengthscale.detach().clone())
        new = rng.uniform(-1, 2, size=(3, 4))
        X, Y = np.vstack([X, new]), np.vstack([Y, f(new)])
    assert stages == ["mll", "kept_hypers", "kept_hypers", "mll"]
    assert torch.equal(lengthscales[0], lengthscales[1])
    assert torch.equal(lengthscales[0], lengthscales[2])
    assert not torch.equal(lengthscales[2], lengthscales[3])
    model = GPSurrogate(refit_every=3, refit_guard=None).fit(X, Y)
    model.fit(X[:-3], Y[:-3])                            # kept hyperparameters: the GP
    mean, _ = model.predict(X[-3:])                      # is conditioned on the data given
    with torch.no_grad():
        post = model.model.posterior(torch.as_tensor(X[-3:]))
    np.testing.assert_allclose(mean, post.mean.numpy(), rtol=1e-9, atol=1e-9)
    assert model.model.train_inputs[0].shape[-2] == len(X) - 3


def test_refit_guard_reoptimises_at_once_when_the_new_points_surprise_the_model(smooth3):
    X, Y, f = smooth3
    rng = np.random.default_rng(9)
    model = GPSurrogate(refit_every=5, refit_guard=4.0).fit(X, Y)
    assert model.fit_info["stage"] == "mll"
    same = rng.uniform(-1, 2, size=(4, 4))                 # more of the same function
    X, Y = np.vstack([X, same]), np.vstack([Y, f(same)])
    model.fit(X, Y)
    assert model.fit_info["stage"] == "kept_hypers" and model.fit_info["surprise"] < 4.0
    jump = rng.uniform(-1, 2, size=(4, 4))                 # a step the GP has not seen
    X, Y = np.vstack([X, jump]), np.vstack([Y, f(jump) + [0.0, 0.0, 40.0]])
    model.fit(X, Y)
    assert model.fit_info["stage"] == "mll" and model.fit_info["surprise"] > 4.0
    unguarded = GPSurrogate(refit_every=5, refit_guard=None).fit(X[:-8], Y[:-8])
    unguarded.fit(X[:-4], Y[:-4])
    unguarded.fit(X, Y)
    assert unguarded.fit_info["stage"] == "kept_hypers" and "surprise" not in unguarded.fit_info


def test_guard_max_iter_caps_only_the_refits_the_guard_triggers(smooth3):
    """A guard-triggered re-optimisation runs at most guard_max_iter L-BFGS-B iterations
    per output from the last optimum; the first (cold) and the scheduled fits keep
    max_iter, and without the option the guard's refit is capped like any other."""
    X, Y, f = smooth3
    rng = np.random.default_rng(9)
    same, jump = rng.uniform(-1, 2, size=(4, 4)), rng.uniform(-1, 2, size=(4, 4))
    X1, Y1 = np.vstack([X, same]), np.vstack([Y, f(same)])
    X2, Y2 = np.vstack([X1, jump]), np.vstack([Y1, f(jump) + [0.0, 0.0, 40.0]])
    stages = {}
    for cap in (None, 2):
        model = GPSurrogate(refit_every=5, refit_guard=4.0, max_iter=60, guard_max_iter=cap)
        model.fit(X, Y)
        assert max(model.fit_info["iterations"]) > 2       # the cold fit: max_iter
        model.fit(X1, Y1)
        assert model.fit_info["stage"] == "kept_hypers"
        model.fit(X2, Y2)                                  # the guard fires
        info = model.fit_info
        assert info["stage"] == "mll" and info["surprise"] > 4.0 and info["guard"]
        stages[cap] = info["iterations"]
        model._since_opt = model.refit_every               # the next fit is a scheduled one
        model.fit(X2, Y2)
        assert "guard" not in model.fit_info and max(model.fit_info["iterations"]) > 2
    assert max(stages[2]) <= 2 and max(stages[None]) > 2


def test_the_guard_statistic_is_the_leave_one_out_error_by_brute_force(smooth3):
    """R&W Eq. 5.12 against explicit solves without each point (same hyperparameters, same
    standardisation): mean z^2 at the new points over mean z^2 at the others."""
    X, Y, f = smooth3
    model = GPSurrogate(refit_every=5, refit_guard=1e6).fit(X, Y)
    more = np.random.default_rng(4).uniform(-1, 2, size=(5, 4))
    X2, Y2 = np.vstack([X, more]), np.vstack([Y, f(more) + [0.3, -0.5, 0.2]])
    model.fit(X2, Y2)
    assert model.fit_info["stage"] == "kept_hypers"
    c = model._caches[0]
    new = np.arange(len(X), len(X2))
    worst = 0.0
    with torch.no_grad():
        K = c.part.covar_module(c.Xn).to_dense()
        K = K + c.part.likelihood.noise.reshape(-1, 1, 1) * torch.eye(len(X2), dtype=K.dtype)
        y = c.part.train_targets - c.const                                  # (b, n)
        for j in range(K.shape[0]):
            z2 = []
            for i in range(len(X2)):
                rest = np.setdiff1d(np.arange(len(X2)), [i])
                Kr, k = K[j][rest][:, rest], K[j][rest, i]
                w = torch.linalg.solve(Kr, k)
                mu, var = w @ y[j, rest], K[j, i, i] - k @ w
                z2.append(float((y[j, i] - mu) ** 2 / var))
            z2 = np.array(z2)
            worst = max(worst, z2[new].mean() / np.delete(z2, new).mean())
    assert model.fit_info["surprise"] == pytest.approx(worst, rel=1e-6)


def test_restore_in_a_kept_cycle_continues_exactly(smooth3):
    """A checkpoint taken between re-optimisations: the next fits (kept, guarded, then
    re-optimised) are those of the uninterrupted object."""
    X, Y, f = smooth3
    more = np.random.default_rng(11).uniform(-1, 2, size=(8, 4))
    X2, Y2 = np.vstack([X, more]), np.vstack([Y, f(more)])
    Xq = np.random.default_rng(6).uniform(-1, 2, size=(9, 4))
    original = GPSurrogate(refit_every=3, refit_guard=4.0).fit(X2[:40], Y2[:40])
    original.fit(X2[:44], Y2[:44])
    restored = GPSurrogate(refit_every=3, refit_guard=4.0).restore(
        X2[:44], Y2[:44], original.state())
    stages = []
    for n in (45, 46, 47, 48):
        original.fit(X2[:n], Y2[:n])
        restored.fit(X2[:n], Y2[:n])
        stages.append(original.fit_info["stage"])
        assert restored.fit_info["stage"] == original.fit_info["stage"]
        assert restored.fit_info.get("surprise") == original.fit_info.get("surprise")
        for a, b in zip(original.predict(Xq), restored.predict(Xq)):
            assert np.array_equal(a, b)
    assert "kept_hypers" in stages and "mll" in stages


@pytest.mark.parametrize("mode", ["per_output", "model_list"])
def test_restore_rebuilds_the_fit_and_its_warm_start_exactly(smooth3, mode):
    """A checkpointed fit, restored elsewhere, predicts and warm-starts the next fit alike."""
    X, Y, f = smooth3
    more = np.random.default_rng(5).uniform(-1, 2, size=(6, 4))
    X2, Y2 = np.vstack([X, more]), np.vstack([Y, f(more)])
    Xq = np.random.default_rng(6).uniform(-1, 2, size=(9, 4))
    original = GPSurrogate(fit_mode=mode, refit_every=1).fit(X[:30], Y[:30]).fit(X, Y)
    state = original.state()
    restored = GPSurrogate(fit_mode=mode, refit_every=1).restore(X, Y, state)
    for a, b in zip(original.predict(Xq), restored.predict(Xq)):
        assert np.array_equal(a, b)
    assert restored.fit_info == original.fit_info
    original.fit(X2, Y2)  # the next fit, warm-started from the checkpointed one
    restored.fit(X2, Y2)
    assert restored.fit_info["warm_started"]
    assert restored.fit_info["iterations"] == original.fit_info["iterations"]
    for a, b in zip(original.predict(Xq), restored.predict(Xq)):
        assert np.array_equal(a, b)


def test_restore_refuses_a_state_of_another_shape_or_no_fit(smooth3):
    X, Y, _ = smooth3
    state = GPSurrogate().fit(X, Y).state()
    with pytest.raises(SurrogateError, match="does not fit this model"):
        GPSurrogate().restore(X[:, :3], Y, state)
    with pytest.raises(SurrogateError, match="not fitted"):
        GPSurrogate().state()


def test_warm_start_skipped_when_shapes_change(smooth3):
    X, Y, _ = smooth3
    model = GPSurrogate().fit(X, Y)
    model.fit(X, Y[:, :2])
    assert not model.fit_info["warm_started"]
    model.fit(X[:, :3], Y[:, :2])
    assert not model.fit_info["warm_started"]


def test_degenerate_data_does_not_crash(smooth3):
    X, Y, _ = smooth3
    Xd = np.vstack([X, X[:15], X[:15]])                 # duplicate rows, twice
    Yd = np.c_[np.vstack([Y, Y[:15], Y[:15]])[:, 0], np.full(len(Xd), -2.0)]  # constant
    Xd[:, 2] = 0.3                                      # constant input column
    model = GPSurrogate().fit(Xd, Yd)
    assert model.fit_info["stage"] == "mll"             # handled without a fallback
    mean, std = model.predict(Xd[:5] + 0.05)
    assert np.all(np.isfinite(mean)) and np.all(np.isfinite(std)) and np.all(std >= 0)
    np.testing.assert_allclose(mean[:, 1], -2.0, atol=1e-8)


def test_fallback_noise_then_default_hyperparameters(smooth3, monkeypatch, caplog):
    X, Y, _ = smooth3
    calls = []

    def failing_fit(mll, **kwargs):
        calls.append(1)
        raise NotPSDError("injected")

    monkeypatch.setattr(gp_module, "fit_gpytorch_mll", failing_fit)
    with caplog.at_level(logging.WARNING, logger="tmopt.surrogates.gp"):
        model = GPSurrogate(fit_mode="batched").fit(X, Y)
    assert model.fit_info["stage"] == "default_hypers" and len(calls) == 2
    assert model.fit_info["noise_floor"] == pytest.approx(1e-4)
    assert sum("failed" in r.message for r in caplog.records) == 2
    mean, std = model.predict(X[:3])
    assert np.all(np.isfinite(mean)) and np.all(std >= 0)


def test_fallback_to_rbf_and_error_without_it(smooth3, monkeypatch, caplog):
    X, Y, _ = smooth3

    def failing_cholesky(*args, **kwargs):
        raise NotPSDError("injected")

    monkeypatch.setattr(gp_module, "psd_safe_cholesky", failing_cholesky)
    with caplog.at_level(logging.WARNING, logger="tmopt.surrogates.gp"):
        model = GPSurrogate(max_iter=5).fit(X, Y)
    assert model.fit_info["stage"] == "rbf"
    assert any("RBF" in r.message for r in caplog.records)
    assert model.predict(X[:2])[0].shape == (2, 3)
    with pytest.raises(SurrogateError, match="fell back"):
        _ = model.model
    with pytest.raises(SurrogateError, match="rbf_fallback=False"):
        GPSurrogate(max_iter=5, rbf_fallback=False).fit(X, Y)


def test_bad_data_and_unfitted_use(smooth3):
    X, Y, _ = smooth3
    Xnan = X.copy()
    Xnan[0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        GPSurrogate().fit(Xnan, Y)
    with pytest.raises(ValueError, match="at least 2"):
        GPSurrogate().fit(X[:1], Y[:1])
    with pytest.raises(SurrogateError, match="before fit"):
        GPSurrogate().predict(X)
    with pytest.raises(SurrogateError, match="not fitted"):
        _ = GPSurrogate().model


@pytest.mark.parametrize("kwargs,name", [
    ({"kernel": "periodic"}, "kernel"), ({"noise_floor": 0.0}, "noise_floor"),
    ({"noise_floor": 0.5}, "noise_floor"), ({"max_iter": 0}, "max_iter"),
    ({"max_attempts": 0}, "max_attempts"), ({"fit_mode": "joint"}, "fit_mode"),
    ({"seed": -3}, "seed"), ({"max_iter": True}, "max_iter"),
    ({"refit_every": 0}, "refit_every"), ({"num_threads": -1}, "num_threads"),
    ({"refit_guard": 0.0}, "refit_guard"), ({"refit_guard": float("inf")}, "refit_guard"),
])
def test_bad_arguments_name_the_parameter(kwargs, name):
    with pytest.raises(ValueError, match=rf"^{name}="):
        GPSurrogate(**kwargs)


@pytest.mark.parametrize("kernel", ["rbf", "matern52"])
def test_botorch_model_supports_subset_output(smooth3, kernel):
    """qLogNEHVI-style reuse: the BoTorch model can be cut down to some outputs."""
    X, Y, _ = smooth3
    model = GPSurrogate(kernel=kernel, max_iter=30).fit(X, Y)
    sub = model.model.subset_output([0, 2])
    with torch.no_grad():
        mean = sub.posterior(torch.as_tensor(X[:5] + 0.1)).mean.numpy()
    np.testing.assert_allclose(mean, model.predict(X[:5] + 0.1)[0][:, [0, 2]], rtol=1e-9)


def test_matern_kernel_fits(smooth3, r2):
    X, Y, f = smooth3
    model = GPSurrogate(kernel="matern52").fit(X, Y)
    Xt = np.random.default_rng(6).uniform(-1, 2, size=(200, 4))
    assert np.all(r2(f(Xt), model.predict_mean(Xt)) > 0.97)
