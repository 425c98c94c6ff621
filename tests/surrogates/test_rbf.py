"""RBF network: accuracy, shapes, uncertainty, determinism, degenerate data, arguments."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from tmopt.surrogates.base import SurrogateError
from tmopt.surrogates.rbf import RBFSurrogate


@pytest.mark.parametrize("name", ["rosenbrock", "ackley"])
@pytest.mark.parametrize("kernel,centres", [("cubic", "all"), ("gaussian", "all"),
                                            ("multiquadric", "all"), ("cubic", "kmeans")])
def test_r2_on_held_out_points(train_test, r2, name, kernel, centres):
    (X, Y), (Xt, Yt) = train_test[name]
    model = RBFSurrogate(kernel=kernel, centres=centres).fit(X, Y)
    assert r2(Yt, model.predict_mean(Xt))[0] >= 0.9


def test_shapes_multi_and_single_output(smooth3):
    X, Y, _ = smooth3
    model = RBFSurrogate().fit(X, Y)
    mean, std = model.predict(X[:7])
    assert mean.shape == std.shape == (7, 3)
    mean1, std1 = RBFSurrogate().fit(X, Y[:, 0]).predict(X[:5])
    assert mean1.shape == std1.shape == (5, 1)
    assert mean.dtype == std.dtype == np.float64


def test_predict_mean_equals_predict(smooth3):
    X, Y, _ = smooth3
    model = RBFSurrogate(kernel="gaussian").fit(X, Y)
    Xq = np.random.default_rng(1).uniform(-1, 2, size=(9, 4))
    np.testing.assert_array_equal(model.predict_mean(Xq), model.predict(Xq)[0])


def test_std_zero_at_data_and_growing_away(smooth3):
    X, Y, _ = smooth3
    model = RBFSurrogate().fit(X, Y)
    _, std_at = model.predict(X)
    np.testing.assert_allclose(std_at, 0.0, atol=1e-12)
    direction = np.ones(4) / 2.0
    stds = [model.predict(X[:1] + t * direction)[1][0] for t in (0.05, 0.5, 3.0)]
    assert np.all(stds[0] < stds[1]) and np.all(stds[1] < stds[2])
    assert np.all(model.predict(np.full((1, 4), 10.0))[1] > model.predict(X.mean(0))[1])


@pytest.mark.parametrize("centres", ["all", "kmeans"])
def test_std_is_loo_error_scaled_by_distance(smooth3, centres):
    """std_j(x) = LOO RMSE_j x d(x) / d_nn, recomputed here independently with NumPy."""
    X, Y, _ = smooth3
    model = RBFSurrogate(kernel="multiquadric", centres=centres).fit(X, Y)
    lo, span = X.min(0), X.max(0) - X.min(0)
    U = (X - lo) / span
    D = np.linalg.norm(U[:, None] - U[None], axis=2)
    np.fill_diagonal(D, np.inf)
    d_nn = D.min(1).mean()
    Xq = np.random.default_rng(4).uniform(-1.5, 2.5, size=(20, 4))
    d_q = np.linalg.norm((Xq - lo) / span - U[:, None], axis=2).min(0)
    expected = (d_q / d_nn)[:, None] * model.fit_info["loo_rmse"][None]
    np.testing.assert_allclose(model.predict(Xq)[1], expected, rtol=1e-10)


def test_closed_form_loo_matches_refits():
    """PRESS residuals (Allen 1974) equal explicit leave-one-out refits of the same basis."""
    rng = np.random.default_rng(3)
    X = rng.random((25, 2))
    Y = np.c_[np.sin(4 * X[:, 0]) + X[:, 1] ** 2]
    model = RBFSurrogate(kernel="gaussian", centres="kmeans", n_centres=8,
                         width_factors=[1.0], ridge=1e-6)
    model.fit(X, Y)
    Xn = torch.as_tensor((X - model._lo) / model._span)
    Ys = torch.as_tensor((Y - model._y_mean) / model._y_std)
    D = torch.cdist(Xn, model._C)
    _, loo = model._solve(D, Xn, Ys, model._sigma)
    A = model._design(D, Xn, model._sigma)
    lam = 1e-6 * float((A.T @ A).diagonal().mean())
    for i in range(len(X)):
        keep = torch.arange(len(X)) != i
        G = A[keep].T @ A[keep] + lam * torch.eye(A.shape[1], dtype=torch.float64)
        w = torch.linalg.solve(G, A[keep].T @ Ys[keep])
        np.testing.assert_allclose(float(Ys[i, 0] - A[i] @ w[:, 0]), float(loo[i, 0]),
                                   rtol=1e-6, atol=1e-9)


def test_width_factor_chosen_from_grid(smooth3):
    X, Y, _ = smooth3
    model = RBFSurrogate(kernel="gaussian", width_factors=[0.5, 2.0, 8.0]).fit(X, Y)
    assert model.fit_info["width_factor"] in (0.5, 2.0, 8.0)
    assert RBFSurrogate(kernel="cubic", width_factors=[3.0]).width_factors == [1.0]


def test_deterministic(smooth3):
    X, Y, _ = smooth3
    Xq = np.random.default_rng(2).uniform(-1, 2, size=(10, 4))
    runs = [RBFSurrogate(centres="kmeans", seed=5).fit(X, Y).predict(Xq) for _ in range(2)]
    np.testing.assert_array_equal(runs[0][0], runs[1][0])
    np.testing.assert_array_equal(runs[0][1], runs[1][1])


def test_degenerate_data_does_not_crash(smooth3):
    X, Y, _ = smooth3
    Xd = np.vstack([X, X[:10]])                 # duplicate rows
    Yd = np.c_[np.vstack([Y, Y[:10]])[:, :2], np.full(len(Xd), 7.0)]  # constant column
    Xd[:, 3] = 1.5                              # constant input column
    for kernel in ("cubic", "gaussian", "multiquadric"):
        mean, std = RBFSurrogate(kernel=kernel).fit(Xd, Yd).predict(Xd[:5] + 0.1)
        assert np.all(np.isfinite(mean)) and np.all(np.isfinite(std)) and np.all(std >= 0)
        np.testing.assert_allclose(mean[:, 2], 7.0)


def test_bad_data_raises(smooth3):
    X, Y, _ = smooth3
    Xnan = X.copy()
    Xnan[3, 1] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        RBFSurrogate().fit(Xnan, Y)
    with pytest.raises(ValueError, match="same n"):
        RBFSurrogate().fit(X, Y[:-1])
    with pytest.raises(SurrogateError, match="before fit"):
        RBFSurrogate().predict(X)
    model = RBFSurrogate().fit(X, Y)
    with pytest.raises(ValueError, match=r"\(q, 4\)"):
        model.predict(X[:, :3])
    with pytest.raises(ValueError, match="NaN"):
        model.predict(Xnan)


@pytest.mark.parametrize("kwargs,name", [
    ({"kernel": "linear"}, "kernel"), ({"centres": "random"}, "centres"),
    ({"n_centres": -1}, "n_centres"), ({"n_centres": 2.5}, "n_centres"),
    ({"width_factors": []}, "width_factors"), ({"width_factors": [1.0, -2.0]}, "width_factors"),
    ({"ridge": -1e-3}, "ridge"), ({"ridge": 1.0}, "ridge"), ({"seed": -1}, "seed"),
])
def test_bad_arguments_name_the_parameter(kwargs, name):
    with pytest.raises(ValueError, match=rf"^{name}="):
        RBFSurrogate(**kwargs)
