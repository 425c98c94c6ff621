"""Gaussian-process surrogate on BoTorch/GPyTorch, multi-output, float64.

One call fits every output column into one ``SingleTaskGP`` with ``m`` outputs, which
GPyTorch holds as a batch of ``m`` independent GPs (one Cholesky/kernel call per step for
all outputs at prediction time). ``fit_mode`` picks how its hyperparameters are learned:

* ``"per_output"`` (default): one L-BFGS-B run per output on a single-output GP of the same
  form, the results copied into the batched model. Cheapest, because each output stops
  at its own convergence (see the benchmark in docs/surrogates.md).
* ``"batched"``: BoTorch's batched L-BFGS-B on the batched model (``fit_gpytorch_mll`` ->
  ``fmin_l_bfgs_b_batched``): one optimiser loop, but every step evaluates all outputs
  until the slowest one converges.
* ``"model_list"``: a ``ModelListGP`` of ``m`` single-output GPs (fitted and predicted
  one by one), the layout BoTorch documents for independent outputs.

Inputs are scaled to the unit box (``Normalize``) and outputs
standardised (``Standardize``) inside the model, so :attr:`GPSurrogate.model` is a BoTorch
model in raw units that acquisition functions (qLogNEHVI) can use directly.

Choices (see docs/surrogates.md):

* Kernel and priors: BoTorch's defaults since 0.12, an ARD RBF kernel without output
  scale and a LogNormal(sqrt(2) + log(d)/2, sqrt(3)) lengthscale prior (Hvarfner, Hellsten &
  Nardi 2024, "Vanilla Bayesian optimization performs great in high dimensions"), or the
  same prior on a Matern-5/2 kernel (``kernel="matern52"``).
* Noise: the objectives are deterministic, so the noise is learned (BoTorch's
  LogNormal(-4, 1) prior) but bounded below by ``noise_floor`` (variance on the
  standardised scale; BoTorch's own floor is 1e-4, ours 1e-6 lets a well-resolved
  function be interpolated closely).
* Warm start: the last successful hyperparameters are the L-BFGS-B start of the next fit
  when the shapes match; ``max_iter`` caps the iterations; with ``refit_every`` = k the
  hyperparameters are re-optimised on every k-th fit only, and the fits in between
  condition the GP with the kept hyperparameters on the new data, unless the guard
  (``refit_guard``) finds the new data surprising: if, for some output, the mean squared
  standardised leave-one-out error of the conditioned GP at the points the last fit did
  not see, z_i^2 = [K^-1 (y - c)]_i^2 / [K^-1]_ii (Rasmussen & Williams 2006, Eq. 5.12),
  exceeds ``refit_guard`` times its mean over the other points, the hyperparameters are
  re-optimised at once. A ratio, so it neither fires on a model that is uniformly
  imperfect (step-like objectives) nor changes when the targets are rescaled. Such a
  re-optimisation before its turn may be capped lower (``guard_max_iter``): it starts
  from the last optimum, and the scheduled one continues with ``max_iter``.
* Prediction: the posterior mean and variance (Rasmussen & Williams 2006, Eqs. 2.25-2.26)
  are computed from the Cholesky factor cached at fit time, with the model's own kernel
  module, without forming a q x q covariance.
* Fallbacks, in order, each logged as a warning: (1) the fit as configured (BoTorch retries
  up to ``max_attempts`` times from prior samples); (2) a refit with the noise floor raised to
  max(100 x noise_floor, 1e-4); (3) the default hyperparameters at that floor without
  optimisation; (4) the RBF network (``rbf_fallback``), else :class:`SurrogateError`.
"""

from __future__ import annotations

import logging
import time
import warnings
from dataclasses import dataclass

import gpytorch
import numpy as np
import torch
from botorch.exceptions.errors import ModelFittingError
from botorch.exceptions.warnings import InputDataWarning, OptimizationWarning
from botorch.fit import fit_gpytorch_mll
from botorch.models import ModelListGP, SingleTaskGP
from botorch.models.transforms import Normalize
from botorch.models.utils.gpytorch_modules import get_covar_module_with_dim_scaled_prior
from botorch.optim.fit import fit_gpytorch_mll_scipy
from gpytorch.constraints import GreaterThan
from gpytorch.likelihoods import GaussianLikelihood
from gpytorch.mlls import ExactMarginalLogLikelihood, SumMarginalLogLikelihood
from gpytorch.priors import LogNormalPrior
from linear_operator.utils.cholesky import psd_safe_cholesky
from linear_operator.utils.warnings import NumericalWarning

from tmopt.surrogates.base import Surrogate, SurrogateError, torch_threads
from tmopt.surrogates.rbf import RBFSurrogate

log = logging.getLogger(__name__)

KERNELS = ("rbf", "matern52")
FIT_MODES = ("per_output", "batched", "model_list")
_DTYPE = torch.float64
#: Exact Cholesky algebra up to this many points (GPyTorch's default switches to CG at 800).
_CHOLESKY_LIMIT = 20000
#: BoTorch's noise prior, LogNormal(-4, 1) (Hvarfner et al. 2024).
_NOISE_LOC, _NOISE_SCALE = -4.0, 1.0
_FIT_ERRORS = (RuntimeError, ModelFittingError, ValueError)


@dataclass
class _Cache:
    """Per-part prediction cache (leading batch dim ``b`` = outputs of the part)."""

    part: SingleTaskGP
    Xn: torch.Tensor      # (b, n, d) normalised training inputs
    alpha: torch.Tensor   # (b, n, 1) (K + s^2 I)^-1 (y - c)
    Linv: torch.Tensor    # (b, n, n) inverse Cholesky factor of K + s^2 I
    const: torch.Tensor   # (b, 1) constant prior mean (standardised units)
    y_mean: torch.Tensor  # (b, 1) outcome standardisation
    y_std: torch.Tensor   # (b, 1)
    L: torch.Tensor       # (b, n, n) Cholesky factor of K + s^2 I


def _is_raw(key: str) -> bool:
    """State-dict keys of learned hyperparameters (raw_*), not priors or transform buffers."""
    return key.rsplit(".", 1)[-1].startswith("raw_")


def _check_int(name: str, value, low: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise ValueError(f"{name}={value!r} is invalid: must be an integer >= {low}")


class GPSurrogate(Surrogate):
    """Exact GP per output (BoTorch ``SingleTaskGP``), with warm start and fallbacks.

    Args:
        kernel: ``"rbf"`` (BoTorch default) or ``"matern52"``; both ARD, dimension-scaled prior.
        noise_floor: Lower bound of the noise variance, standardised units, in (0, 0.1].
        warm_start: Start each fit from the previous fit's hyperparameters.
        max_iter: Cap on L-BFGS-B iterations per fit (>= 1).
        refit_every: Re-optimise the hyperparameters on every k-th fit of this object; the
            fits in between keep the last learned hyperparameters and only condition on the
            new data (one Cholesky). 1 = optimise on every fit.
        refit_guard: With ``refit_every`` > 1: re-optimise before the k-th fit when the
            mean squared standardised leave-one-out error at the new points exceeds this
            multiple of the one at the other points, for some output (module docstring);
            None = no guard.
        max_attempts: BoTorch fit attempts (restarts from seeded prior samples), >= 1.
        fit_mode: ``"per_output"``, ``"batched"`` or ``"model_list"`` (module docstring).
        rbf_fallback: Fall back to :class:`RBFSurrogate` if every GP stage fails.
        seed: Seeds the restarts, so the same data and seed give the same model.
        num_threads: torch threads inside fit/predict (restored after); 0 = torch's setting.
        guard_max_iter: L-BFGS-B cap of a re-optimisation that the guard triggers before
            its turn (warm-started from the last optimum); None = ``max_iter``.
    """

    name = "gp"

    def __init__(self, *, kernel: str = "rbf", noise_floor: float = 1e-6, warm_start: bool = True,
                 max_iter: int = 200, refit_every: int = 5, max_attempts: int = 2,
                 fit_mode: str = "per_output",
                 rbf_fallback: bool = True, seed: int = 0, num_threads: int = 1,
                 refit_guard: float | None = 4.0, guard_max_iter: int | None = None) -> None:
        if kernel not in KERNELS:
            raise ValueError(f"kernel={kernel!r} is invalid: must be one of {KERNELS}")
        if fit_mode not in FIT_MODES:
            raise ValueError(f"fit_mode={fit_mode!r} is invalid: must be one of {FIT_MODES}")
        if not (isinstance(noise_floor, (int, float)) and 0.0 < noise_floor <= 0.1):
            raise ValueError(f"noise_floor={noise_floor!r} is invalid: must be in (0, 0.1]")
        _check_int("max_iter", max_iter, 1)
        _check_int("refit_every", refit_every, 1)
        _check_int("max_attempts", max_attempts, 1)
        _check_int("seed", seed, 0)
        _check_int("num_threads", num_threads, 0)
        if guard_max_iter is not None:
            _check_int("guard_max_iter", guard_max_iter, 1)
        self.guard_max_iter = guard_max_iter
        self._guard_fired = False  # the current fit re-optimises because the guard fired
        if refit_guard is not None and not (isinstance(refit_guard, (int, float))
                                            and 0.0 < refit_guard < float("inf")):
            raise ValueError(f"refit_guard={refit_guard!r} is invalid: must be None or a "
                             f"finite number > 0")
        self.refit_guard = None if refit_guard is None else float(refit_guard)
        self.kernel, self.noise_floor = kernel, float(noise_floor)
        self.warm_start, self.fit_mode, self.rbf_fallback = warm_start, fit_mode, rbf_fallback
        self.max_iter, self.refit_every, self.max_attempts = max_iter, refit_every, max_attempts
        self.seed, self.num_threads = seed, num_threads
        self._since_opt = 0  # fits with kept hyperparameters since the last optimised one
        self._model: SingleTaskGP | ModelListGP | None = None
        self._caches: list[_Cache] = []
        self._fallback: RBFSurrogate | None = None
        self._warm: dict[str, torch.Tensor] | None = None
        self._d: int | None = None
        self._X_fit: np.ndarray | None = None  # training inputs of the last fit (the guard)
        self._surprise_seen: float | None = None
        #: Diagnostics of the last fit: stage, L-BFGS-B iterations, warm start, seconds.
        self.fit_info: dict = {}

    # ---- public ------------------------------------------------------------------------
    @property
    def model(self) -> SingleTaskGP | ModelListGP:
        """The fitted BoTorch model (raw units in and out), e.g. for BoTorch acquisitions."""
        if self._model is None:
            reason = ("the last fit fell back to the RBF network" if self._fallback is not None
                      else "the model is not fitted")
            raise SurrogateError(f"no BoTorch model: {reason}")
        return self._model

    def fit(self, X: np.ndarray, Y: np.ndarray) -> GPSurrogate:
        X, Y = self.check_training_data(X, Y)
        with torch_threads(self.num_threads):
            self._fit(X, Y)
        return self

    def state(self) -> dict:
        """What the last fit left: enough for :meth:`restore` to rebuild it exactly."""
        if self._model is None:
            raise SurrogateError("no GP state to save: the model is not fitted or the last "
                                 "fit fell back to the RBF network")
        return {"hyperparameters": self._hyperparameters(), "fit_info": dict(self.fit_info),
                "warm": self._warm, "since_opt": self._since_opt}

    def restore(self, X: np.ndarray, Y: np.ndarray, state: dict) -> GPSurrogate:
        """The model that :meth:`fit` made of (X, Y), from its :meth:`state`, without fitting.

        Also restores the warm start and refit counter, so the next :meth:`fit` gives what
        it would have given after the original fit (a resumed run's checkpoint).
        """
        X, Y = self.check_training_data(X, Y)
        Xt, Yt = torch.as_tensor(X, dtype=_DTYPE), torch.as_tensor(Y, dtype=_DTYPE)
        self._model, self._caches, self._fallback, self._d = None, [], None, None
        with torch_threads(self.num_threads):
            self._fit_stage(Xt, Yt, float(state["fit_info"]["noise_floor"]), optimise=False,
                            warm=False, start=state["hyperparameters"])
        self.fit_info = dict(state["fit_info"])
        self._warm, self._since_opt, self._d = state["warm"], int(state["since_opt"]), X.shape[1]
        self._X_fit = X.copy()
        return self

    def _fit(self, X: np.ndarray, Y: np.ndarray) -> None:
        start = time.perf_counter()
        new = self._new_rows(X)
        self._model, self._caches, self._fallback, self._d = None, [], None, None
        Xt, Yt = torch.as_tensor(X, dtype=_DTYPE), torch.as_tensor(Y, dtype=_DTYPE)
        self._surprise_seen, self._guard_fired = None, False
        if not self._keep_hyperparameters(Xt, Yt, new):
            self._fit_stages(X, Y, Xt, Yt)
            if self._guard_fired:  # re-optimised before its turn (capped: guard_max_iter)
                self.fit_info["guard"] = True
        self._guard_fired = False
        self._d, self._X_fit = X.shape[1], X.copy()
        self.fit_info["seconds"] = time.perf_counter() - start
        if self._surprise_seen is not None:  # the guard's statistic, refit or not
            self.fit_info["surprise"] = self._surprise_seen

    def _new_rows(self, X: np.ndarray) -> np.ndarray | None:
        """Mask of the rows of X that the last fit did not see (None: no last fit)."""
        if self._X_fit is None or self._X_fit.shape[1] != X.shape[1]:
            return None
        seen = {row.tobytes() for row in self._X_fit}
        return np.array([row.tobytes() not in seen for row in X])

    def _surprise(self, new: np.ndarray) -> float:
        """Largest (over outputs) ratio of the mean squared standardised leave-one-out
        error at the ``new`` rows to that at the other rows, z_i = [K^-1 (y - c)]_i /
        sqrt([K^-1]_ii) (R&W 2006, Eq. 5.12): how much more the new data surprise the
        model than the data it was fitted on (about 1 when they are alike, whatever the
        model's misfit: the objectives of the stiffness problem are step-like, and the
        GP's own LOO z^2 there is ~3 at freshly optimised hyperparameters)."""
        worst = 0.0
        for c in self._caches:
            alpha = c.alpha.squeeze(-1)                               # (b, n)
            z2 = alpha ** 2 / (c.Linv ** 2).sum(dim=1)                # (b, n)
            old = z2[:, ~new].mean(dim=1) if (~new).any() else torch.ones(len(z2))
            worst = max(worst, float((z2[:, new].mean(dim=1) / old.clamp_min(1e-12)).max()))
        return worst

    def _keep_hyperparameters(self, X: torch.Tensor, Y: torch.Tensor,
                              new: np.ndarray | None = None) -> bool:
        """Between re-optimisations (``refit_every`` > 1): condition on the new data only,
        unless the guard finds the new rows surprising (then re-optimise at once)."""
        if self._warm is None or self._since_opt + 1 >= self.refit_every:
            return False
        try:
            self._fit_stage(X, Y, self.noise_floor, optimise=False, warm=True)
        except _FIT_ERRORS as exc:
            log.warning("GP update with kept hyperparameters failed (%s); re-optimising",
                        type(exc).__name__)
            return False
        if not self.fit_info["warm_started"]:  # d or m changed: the old values do not fit
            return False
        if self.refit_guard is not None and new is not None and new.any():
            surprise = self._surprise_seen = self._surprise(new)
            if surprise > self.refit_guard:
                log.info("GP refit before its turn: mean squared standardised LOO error "
                         "at the new points %.3g x that at the others > refit_guard %.3g",
                         surprise, self.refit_guard)
                self._guard_fired = True
                return False
        self._since_opt += 1
        self.fit_info.update(stage="kept_hypers", noise_floor=self.noise_floor)
        return True

    def _fit_stages(self, X: np.ndarray, Y: np.ndarray, Xt: torch.Tensor,
                    Yt: torch.Tensor) -> None:
        """The fallback chain of the module docstring."""
        raised = max(100.0 * self.noise_floor, 1e-4)
        stages = (("mll", self.noise_floor, True), ("noise_raised", raised, True),
                  ("default_hypers", raised, False))
        for stage, floor, optimise in stages:
            try:
                self._fit_stage(Xt, Yt, floor, optimise, warm=stage == "mll" and self.warm_start)
            except _FIT_ERRORS as exc:
                log.warning("GP fit stage %r failed (%s: %s); trying the next fallback",
                            stage, type(exc).__name__, str(exc).splitlines()[0][:200])
                continue
            self.fit_info.update(stage=stage, noise_floor=floor)
            if stage == "mll":
                self._warm = self._hyperparameters()
            self._since_opt = 0
            break
        else:
            self._fit_rbf(X, Y)

    def predict(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        X = self.check_query_data(X, self._d)
        if self._fallback is not None:
            return self._fallback.predict(X)
        with torch_threads(self.num_threads):
            means, stds = zip(*(self._predict_part(c, X, True) for c in self._caches))
        return np.concatenate(means, axis=1), np.concatenate(stds, axis=1)

    def predict_mean(self, X: np.ndarray) -> np.ndarray:
        X = self.check_query_data(X, self._d)
        if self._fallback is not None:
            return self._fallback.predict_mean(X)
        with torch_threads(self.num_threads):
            means = [self._predict_part(c, X, False)[0] for c in self._caches]
        return np.concatenate(means, axis=1)

    # ---- fitting -----------------------------------------------------------------------
    def _fit_stage(self, X: torch.Tensor, Y: torch.Tensor, floor: float, optimise: bool,
                   warm: bool, start: dict[str, torch.Tensor] | None = None) -> None:
        with gpytorch.settings.max_cholesky_size(_CHOLESKY_LIMIT), warnings.catch_warnings():
            # Expected on degenerate data (added jitter, unscaled-input checks) or a capped
            # L-BFGS-B run; real failures raise and are logged by the fallback chain.
            for category in (NumericalWarning, InputDataWarning, OptimizationWarning):
                warnings.simplefilter("ignore", category)
            model = self._build(X, Y, floor)
            warmed = warm and self._load_warm(model)
            if start is not None and not self._load_hyperparameters(model, start):
                raise SurrogateError("the saved GP state does not fit this model (another "
                                     "kernel, dimension or number of outputs)")
            self.fit_info = {"warm_started": warmed, "iterations": []}
            if optimise and self.fit_mode == "per_output" and Y.shape[1] > 1:
                self._optimise_per_output(model, X, Y, floor)
            elif optimise:
                self._optimise(model)
            model.eval()
            caches = [self._make_cache(p) for p in self._parts(model)]
        self._model, self._caches = model, caches

    def _build(self, X: torch.Tensor, Y: torch.Tensor, floor: float):
        if self.fit_mode != "model_list" or Y.shape[1] == 1:
            return self._single(X, Y, floor)
        return ModelListGP(*(self._single(X, Y[:, j:j + 1], floor) for j in range(Y.shape[1])))

    def _single(self, X: torch.Tensor, Y: torch.Tensor, floor: float) -> SingleTaskGP:
        d, m = X.shape[1], Y.shape[1]
        batch = torch.Size([m]) if m > 1 else torch.Size()
        prior = LogNormalPrior(_NOISE_LOC, _NOISE_SCALE)
        likelihood = GaussianLikelihood(
            noise_prior=prior, batch_shape=batch,
            noise_constraint=GreaterThan(floor, transform=None,
                                         initial_value=max(float(prior.mode), floor)))
        covar = get_covar_module_with_dim_scaled_prior(
            ard_num_dims=d, batch_shape=batch, use_rbf_kernel=self.kernel == "rbf")
        model = SingleTaskGP(X, Y, likelihood=likelihood, covar_module=covar,
                             input_transform=Normalize(d=d))
        # BoTorch sets this only for its default kernel; needed by Model.subset_output.
        model._subset_batch_dict = {"mean_module.raw_constant": -1,
                                    "covar_module.raw_lengthscale": -3,
                                    "likelihood.noise_covar.raw_noise": -2}
        return model

    def _optimise(self, model) -> None:
        iterations = self.fit_info["iterations"]

        def optimizer(mll, **kwargs):
            result = fit_gpytorch_mll_scipy(mll, **kwargs)
            iterations.append(int(result.step))
            return result

        if isinstance(model, ModelListGP):
            mll = SumMarginalLogLikelihood(model.likelihood, model)
        else:
            mll = ExactMarginalLogLikelihood(model.likelihood, model)
        with torch.random.fork_rng():  # seeded restarts, global RNG left untouched
            torch.manual_seed(self.seed)
            fit_gpytorch_mll(mll, optimizer=optimizer, max_attempts=self.max_attempts,
                             optimizer_kwargs={"options": {"maxiter": self._max_iter_now()}})

    def _max_iter_now(self) -> int:
        """The L-BFGS-B cap of this fit: ``guard_max_iter`` for a warm re-optimisation that
        the guard triggered before its turn, else ``max_iter``."""
        short = self._guard_fired and self.guard_max_iter is not None \
            and self.fit_info.get("warm_started")
        return self.guard_max_iter if short else self.max_iter

    def _optimise_per_output(self, model: SingleTaskGP, X: torch.Tensor, Y: torch.Tensor,
                             floor: float) -> None:
        """Fit output j alone (from the batched model's slice j) and copy the result back."""
        state = {k: v.clone() for k, v in model.state_dict().items() if _is_raw(k)}
        for j in range(Y.shape[1]):
            sub = self._single(X, Y[:, j:j + 1], floor)
            sub.load_state_dict({k: v[j] for k, v in state.items()}, strict=False)
            self._optimise(sub)
            for k, v in sub.state_dict().items():
                if _is_raw(k):
                    state[k][j] = v
        model.load_state_dict(state, strict=False)

    @staticmethod
    def _parts(model) -> list[SingleTaskGP]:
        return list(model.models) if isinstance(model, ModelListGP) else [model]

    def _hyperparameters(self) -> dict[str, torch.Tensor]:
        """The learned raw hyperparameters (not the transforms' data-dependent buffers)."""
        return {k: v.detach().clone() for k, v in self._model.state_dict().items()
                if _is_raw(k)}

    def _load_warm(self, model) -> bool:
        return self._warm is not None and self._load_hyperparameters(model, self._warm)

    @staticmethod
    def _load_hyperparameters(model, values: dict[str, torch.Tensor]) -> bool:
        """Load raw hyperparameters if they match the model's (else False: start cold)."""
        state = model.state_dict()
        if set(values) != {k for k in state if _is_raw(k)} \
                or any(state[k].shape != v.shape for k, v in values.items()):
            return False  # different d, m, kernel or layout
        model.load_state_dict(values, strict=False)
        return True

    def _fit_rbf(self, X: np.ndarray, Y: np.ndarray) -> None:
        if not self.rbf_fallback:
            raise SurrogateError("GP fit failed in every fallback stage and rbf_fallback=False")
        log.warning("GP fit failed in every stage; using the RBF network instead")
        self._fallback = RBFSurrogate(seed=self.seed, num_threads=self.num_threads).fit(X, Y)
        self.fit_info = {"stage": "rbf", "iterations": [], "warm_started": False}

    # ---- prediction --------------------------------------------------------------------
    @staticmethod
    def _make_cache(part: SingleTaskGP) -> _Cache:
        """Cholesky factor and weights of one part (R&W 2006, Algorithm 2.1)."""
        with torch.no_grad():
            Xn = part.train_inputs[0]  # normalised in eval mode
            y = part.train_targets
            if Xn.dim() == 2:  # single output: add the batch dim
                Xn, y = Xn.unsqueeze(0), y.unsqueeze(0)
            n = Xn.shape[-2]
            noise = part.likelihood.noise.reshape(-1, 1, 1)
            K = part.covar_module(Xn).to_dense().reshape(-1, n, n)
            L = psd_safe_cholesky(K + noise * torch.eye(n, dtype=_DTYPE))
            const = part.mean_module.constant.reshape(-1, 1)
            Linv = torch.linalg.solve_triangular(
                L, torch.eye(n, dtype=_DTYPE).expand_as(L), upper=False)
            alpha = torch.cholesky_solve((y - const).unsqueeze(-1), L)
            tf = part.outcome_transform
            cache = _Cache(part, Xn, alpha, Linv, const,
                           tf.means.reshape(-1, 1), tf.stdvs.reshape(-1, 1), L)
        if not all(torch.isfinite(t).all() for t in (alpha, Linv, const)):
            raise SurrogateError("non-finite GP weights (singular covariance)")
        return cache

    @staticmethod
    def _predict_part(c: _Cache, X: np.ndarray, with_std: bool):
        """Posterior mean and std of the latent f (R&W 2006, Eqs. 2.25-2.26), raw units."""
        b = c.Xn.shape[0]
        with torch.no_grad():
            xn = c.part.input_transform(torch.as_tensor(X, dtype=_DTYPE))
            xn = xn.expand(b, *xn.shape)
            covar = c.part.covar_module
            Ks = covar.forward(xn, c.Xn).reshape(b, len(X), -1)          # (b, q, n)
            mean = (c.const + (Ks @ c.alpha).squeeze(-1)) * c.y_std + c.y_mean
            if not with_std:
                return mean.T.numpy(), None
            v = Ks @ c.Linv.mT                                           # (b, q, n)
            prior_var = covar.forward(xn, xn, diag=True).reshape(b, -1)
            var = (prior_var - (v * v).sum(-1)).clamp_min(0.0)
            std = var.sqrt() * c.y_std
        return mean.T.numpy(), std.T.numpy()
