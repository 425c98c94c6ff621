"""Radial-basis-function network in torch (float64), multi-output, with an uncertainty.

Model (one shared basis for all outputs, inputs scaled to the unit box, outputs
standardised)::

    y_j(x) = sum_k w_kj phi(||x - c_k|| / sigma) + b_0j + sum_i b_ij x_i

with a linear polynomial tail, as in the RBF surrogates of Gutmann (2001) and Regis &
Shoemaker (2007, "A stochastic radial basis function method ...", INFORMS J. Comput.),
which makes the cubic kernel well posed and lets the model extrapolate linearly.

* Kernels (Fasshauer 2007, *Meshfree Approximation Methods with MATLAB*, ch. 4), r = ||x-c||/sigma:
  ``gaussian`` exp(-r^2), ``multiquadric`` sqrt(1 + r^2), ``cubic`` r^3.
* Centres: all (distinct) training points, or k-means centres (scipy ``kmeans2``, k-means++
  start seeded by ``seed``).
* Width rule: sigma = factor x (mean distance from each centre to its nearest other centre);
  the factor is chosen from ``width_factors`` by the closed-form leave-one-out error below.
  The cubic kernel is scale-free (sigma only rescales its weights), so it uses factor 1.
* Weights: ridge regression in closed form, (A^T A + lambda I) W = A^T Y with
  lambda = ``ridge`` x mean(diag(A^T A)) (relative, so it does not depend on the kernel's
  scale), solved by Cholesky (ridge regression: Hoerl & Kennard 1970).
* Leave-one-out residuals of a linear smoother, e_i = r_i / (1 - H_ii) with
  H = A (A^T A + lambda I)^-1 A^T (Allen 1974, PRESS), for the basis held fixed.
* Uncertainty: std_j(x) = s_j * d(x) / d_nn, where s_j is the leave-one-out RMS error of
  output j, d(x) the distance (unit box) from x to the nearest training point and d_nn the
  mean nearest-neighbour distance among training points. It is a distance-to-data error
  scale: 0 at training points, about the LOO error at the typical spacing of the data,
  growing linearly away from it. It is not a posterior standard deviation. (This rule
  and the width rule are this project's choices, documented in docs/surrogates.md, not
  taken from a paper.)
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np
import torch
from scipy.cluster.vq import kmeans2

from tmopt.surrogates.base import Surrogate, SurrogateError, torch_threads

KERNELS = ("gaussian", "multiquadric", "cubic")
CENTRES = ("all", "kmeans")
_DTYPE = torch.float64


def _phi(kernel: str, r: torch.Tensor) -> torch.Tensor:
    """Basis function of the scaled distance ``r`` (Fasshauer 2007, Table 4.1 / sec. 4.2)."""
    if kernel == "gaussian":
        return torch.exp(-r * r)
    if kernel == "multiquadric":
        return torch.sqrt(1.0 + r * r)
    return r * r * r


def _dist(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Exact Euclidean distances (no matmul shortcut, so d(x, x) is exactly 0)."""
    return torch.cdist(a, b, compute_mode="donot_use_mm_for_euclid_dist")


def _mean_nn_distance(P: torch.Tensor) -> float:
    """Mean distance from each row of ``P`` to its nearest other row (1.0 if only one row)."""
    if len(P) < 2:
        return 1.0
    D = _dist(P, P)
    D.fill_diagonal_(float("inf"))
    value = float(D.min(dim=1).values.mean())
    return value if value > 0 else 1.0


class RBFSurrogate(Surrogate):
    """RBF network with ridge weights, LOO-chosen width and a distance-based std.

    Args:
        kernel: ``"cubic"``, ``"gaussian"`` or ``"multiquadric"``.
        centres: ``"all"`` (every distinct training point) or ``"kmeans"``.
        n_centres: Number of k-means centres; 0 = max(d + 2, n // 2), capped at n.
        width_factors: Candidate factors of the width rule (>0); the one with the
            smallest leave-one-out error is used (ignored by the scale-free cubic kernel).
        ridge: Relative ridge parameter lambda / mean(diag(A^T A)), in [0, 1).
        seed: Seeds the k-means++ start.
        num_threads: torch threads inside fit/predict (restored after); 0 = torch's setting.
    """

    name = "rbf"

    def __init__(self, *, kernel: str = "cubic", centres: str = "all", n_centres: int = 0,
                 width_factors: Sequence[float] = (0.5, 1.0, 2.0, 4.0, 8.0),
                 ridge: float = 1e-8, seed: int = 0, num_threads: int = 1) -> None:
        if kernel not in KERNELS:
            raise ValueError(f"kernel={kernel!r} is invalid: must be one of {KERNELS}")
        if centres not in CENTRES:
            raise ValueError(f"centres={centres!r} is invalid: must be one of {CENTRES}")
        if isinstance(n_centres, bool) or not isinstance(n_centres, int) or n_centres < 0:
            raise ValueError(f"n_centres={n_centres!r} is invalid: must be an integer >= 0 "
                             f"(0 = default rule)")
        factors = [float(f) for f in width_factors]
        if not factors or not all(np.isfinite(f) and f > 0 for f in factors):
            raise ValueError(f"width_factors={list(width_factors)!r} is invalid: must be a "
                             f"non-empty list of finite numbers > 0")
        if not (0.0 <= float(ridge) < 1.0):
            raise ValueError(f"ridge={ridge!r} is invalid: must be in [0, 1)")
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ValueError(f"seed={seed!r} is invalid: must be an integer >= 0")
        if isinstance(num_threads, bool) or not isinstance(num_threads, int) or num_threads < 0:
            raise ValueError(f"num_threads={num_threads!r} is invalid: must be an integer >= 0 "
                             f"(0 = torch's setting)")
        self.num_threads = num_threads
        self.kernel, self.centres, self.n_centres = kernel, centres, n_centres
        self.width_factors = factors if kernel != "cubic" else [1.0]
        self.ridge, self.seed = float(ridge), seed
        self._d: int | None = None
        #: Diagnostics of the last fit: chosen width factor, sigma, LOO RMSE per output.
        self.fit_info: dict = {}

    # ---- fit ---------------------------------------------------------------------------
    def fit(self, X: np.ndarray, Y: np.ndarray) -> RBFSurrogate:
        X, Y = self.check_training_data(X, Y)
        with torch_threads(self.num_threads):
            self._fit(X, Y)
        return self

    def _fit(self, X: np.ndarray, Y: np.ndarray) -> None:
        self._lo = X.min(axis=0)
        span = X.max(axis=0) - self._lo
        self._span = np.where(span > 0, span, 1.0)  # a constant input column maps to 0
        self._y_mean = Y.mean(axis=0)
        y_std = Y.std(axis=0)
        self._y_std = np.where(y_std > 0, y_std, 1.0)  # a constant output is fitted as 0
        Xn = torch.as_tensor((X - self._lo) / self._span, dtype=_DTYPE)
        Ys = torch.as_tensor((Y - self._y_mean) / self._y_std, dtype=_DTYPE)
        self._C = self._choose_centres(Xn)
        spacing = _mean_nn_distance(self._C)
        D = _dist(Xn, self._C)
        best = None
        for factor in self.width_factors:
            W, loo = self._solve(D, Xn, Ys, factor * spacing)
            score = float((loo ** 2).mean())
            if np.isfinite(score) and (best is None or score < best[0]):
                best = (score, factor, W, loo)
        if best is None:
            raise SurrogateError("RBF fit failed for every width factor (singular system)")
        _, factor, self._W, loo = best
        self._sigma = factor * spacing
        self._Xn = torch.unique(Xn, dim=0)
        # With all points as centres the query-centre distances also give d(x).
        self._centres_are_data = torch.equal(self._C, self._Xn)
        self._d_nn = _mean_nn_distance(self._Xn)
        self._s_loo = loo.pow(2).mean(dim=0).sqrt().numpy() * self._y_std
        self._d = X.shape[1]
        self.fit_info = {"width_factor": factor, "sigma": self._sigma,
                         "n_centres": len(self._C), "loo_rmse": self._s_loo.copy()}

    def _choose_centres(self, Xn: torch.Tensor) -> torch.Tensor:
        distinct = torch.unique(Xn, dim=0)
        if self.centres == "all":
            return distinct
        n, d = distinct.shape
        k = self.n_centres or max(d + 2, n // 2)
        k = min(k, n)
        if k == n:
            return distinct
        rng = np.random.default_rng(self.seed)
        with warnings.catch_warnings():  # an empty cluster is dropped below, not an error
            warnings.simplefilter("ignore")
            C, _ = kmeans2(distinct.numpy(), k, iter=20, minit="++", seed=rng)
        return torch.unique(torch.as_tensor(C, dtype=_DTYPE), dim=0)

    def _design(self, D: torch.Tensor, Xn: torch.Tensor, sigma: float) -> torch.Tensor:
        """A = [phi(D / sigma), 1, x] from the point-centre distances D (rows: points)."""
        Phi = _phi(self.kernel, D / sigma)
        return torch.cat([Phi, torch.ones(len(Xn), 1, dtype=_DTYPE), Xn], dim=1)

    def _solve(self, D: torch.Tensor, Xn: torch.Tensor, Ys: torch.Tensor, sigma: float):
        """Ridge weights and leave-one-out residuals (Allen 1974) for one width."""
        A = self._design(D, Xn, sigma)
        G = A.T @ A
        lam = self.ridge * float(G.diagonal().mean())
        G.diagonal().add_(lam)
        L, info = torch.linalg.cholesky_ex(G)
        if int(info) != 0:  # singular even with the ridge: least squares instead
            W = torch.linalg.lstsq(G, A.T @ Ys).solution
            AGinv = torch.linalg.lstsq(G, A.T).solution.T
        else:
            W = torch.cholesky_solve(A.T @ Ys, L)
            AGinv = torch.cholesky_solve(A.T, L).T
        h = (A * AGinv).sum(dim=1)
        resid = Ys - A @ W
        # h -> 1 means point i is interpolated; its LOO residual is then unknowable.
        loo = resid / (1.0 - h).clamp_min(1e-12).unsqueeze(1)
        return W, loo

    # ---- predict -----------------------------------------------------------------------
    def _scaled(self, X: np.ndarray) -> torch.Tensor:
        X = self.check_query_data(X, self._d)
        return torch.as_tensor((X - self._lo) / self._span, dtype=_DTYPE)

    def _mean(self, D: torch.Tensor, xn: torch.Tensor) -> np.ndarray:
        mean = (self._design(D, xn, self._sigma) @ self._W).numpy()
        return mean * self._y_std + self._y_mean

    def predict_mean(self, X: np.ndarray) -> np.ndarray:
        xn = self._scaled(X)
        with torch.no_grad(), torch_threads(self.num_threads):
            return self._mean(_dist(xn, self._C), xn)

    def predict(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xn = self._scaled(X)
        with torch.no_grad(), torch_threads(self.num_threads):
            D = _dist(xn, self._C)
            mean = self._mean(D, xn)
            D_data = D if self._centres_are_data else _dist(xn, self._Xn)
            d_min = D_data.min(dim=1).values.numpy()
        std = (d_min / self._d_nn)[:, None] * self._s_loo[None, :]
        return mean, std
