"""qLogNEHVI: Bayesian optimisation with BoTorch's constrained log noisy expected HVI.

Tags: expensive, constrained, multi-objective, surrogate-assisted (Gaussian processes),
batch Bayesian optimisation. Not in the seed paper; the modern BO baseline it lacks.

Implements
    S. Ament, S. Daulton, D. Eriksson, M. Balandat, E. Bakshy, "Unexpected improvements to
    expected improvement for Bayesian optimization", NeurIPS 2023 (the LogEI family), on
    qNEHVI of S. Daulton, M. Balandat, E. Bakshy, "Parallel Bayesian optimization of
    multiple noisy objectives with expected hypervolume improvement", NeurIPS 2021. Outcome
    constraints as BoTorch implements them: each posterior sample's hypervolume
    improvement is weighted, per constraint, by a fat-tailed sigmoid of -g~_k / eta
    (BoTorch's ``log_fatmoid``, Ament et al. 2023), a smooth feasibility indicator.
    BoTorch's ``qLogNoisyExpectedHypervolumeImprovement`` and ``optimize_acqf`` do the
    work; nothing of the acquisition is written here.

Parameters (keyword arguments; defaults: the constructor's signature). The defaults are the
fast settings of docs/speed.md (~10x less CPU per run); ``algorithm=qlognehvi_reference``
pins the earlier ones, which reproduce earlier runs bit for bit:
    n_init: size of the scrambled Sobol initial sample; None = 2 (D + 1), BoTorch's
        tutorial rule (11 D - 1 would spend 197 of 300 evaluations at D = 18).
    q: designs per iteration (batch size), the same as MGSAEA's mu.
    num_restarts, raw_samples: multi-start L-BFGS-B of the acquisition, from
        the best of ``raw_samples`` Sobol points.
    acq_maxiter: L-BFGS-B iterations per restart. Measured on the stiffness problem at 300
        designs: the fast setting's batch has 0.96x the joint expected improvement of the
        earlier 128 raw samples x 100 iterations for 0.3x its cost (docs/speed.md).
    mc_samples: quasi-Monte-Carlo samples of the joint posterior (seeded Sobol).
    ref_offset: reference point = nadir + ref_offset in objectives normalised to
        [0, 1] over the data (rule below).
    ref_point: whose nadir: "all" = the worst value per objective over every
        design (1 + ref_offset in normalised units); "feasible" = over the feasible designs;
        "front" = over their non-dominated set (the rule before 2026-11-21). The tighter
        rules confine the front: see reference_nadir and
        ``experiments/qlognehvi_reference_point.py``.
    eta: temperature of the (fat-tailed) sigmoid feasibility weight, applied
        to constraints divided by their largest observed magnitude.
    gp_max_iter: L-BFGS-B iterations per GP hyperparameter fit (warm-started from the last
        fit, so capped fits continue where the last one stopped).
    gp_guard_max_iter: L-BFGS-B iterations of a re-optimisation that the refit guard
        triggers before its turn (warm-started from the last optimum); None = gp_max_iter.
        On the stiffness problem the guard fires at most iterations (docs/speed.md), so
        this cap, not ``refit_every``, sets what the fits cost there. Measured on a Table 3
        run's archive at 150, 400 and 650 designs: 5 iterations reach the marginal
        likelihood of 50 within 0.3 % and predict the next 25 designs as well, for 0.15-0.2x
        the time; ~1.8x less CPU per Table 3 run. The default since 2026-11-25 (end-to-end
        check on MW3 against the reference, 10 paired seeds, docs/speed.md); runs made
        before it ran with None, which ``qlognehvi_reference`` pins and which keeps their
        config hash.
    kernel: GP kernel, "rbf" or "matern52" (:class:`tmopt.surrogates.gp.GPSurrogate`).
    max_baseline: at most this many observed designs as qLogNEHVI's baseline
        X_baseline: BoTorch's own pruning keeps every design with a positive posterior
        probability of being Pareto optimal (~230 of 530 on the stiffness problem, where
        the GPs are unsure). Through GPyTorch the joint posterior over that baseline was
        nearly all of an iteration's cost (~n_baseline x n^2 per acquisition evaluation);
        with ``cached_posterior`` it no longer is, so the cap (docs/results.md's Table 3
        used 64) is only a modelling choice now. With a cap, BoTorch's
        ``prune_inferior_points_multi_objective`` keeps the ``max_baseline`` most probable
        ones. None = BoTorch's default (no cap).
    max_iter: BO iterations (of q evaluations) after the initial sample, after which
        the algorithm stops proposing; None = until the budget is spent. The GPs are exact,
        so budgets of thousands of evaluations (the ``paper`` preset's 10 000) need a cap:
        max_iter = 100 stops after 2 (D + 1) + 500 evaluations, like MGSAEA's.
    threads: torch intra-op threads while fitting and optimising (restored afterwards);
        None = torch's setting. The tensors here are small (a few hundred points), so
        one thread is faster than the OpenMP hand-off, by ~6x on a loaded two-core machine.
    cached_posterior: the acquisition sees the GPs through
        :class:`tmopt.surrogates.gp_posterior.CachedJointGP`, the same exact posterior
        that reuses the baseline's rows instead of recomputing the joint posterior over
        baseline and candidate at every evaluation (tested equal to BoTorch's values and
        gradients).
    init_batch_limit: raw samples scored per call when choosing the restarts (None =
        num_restarts at a time, 32 calls at 128 raw samples; one call scores the same).
    refit_every, refit_guard: the GP hyperparameters are
        re-optimised at every ``refit_every``-th iteration; in between the GPs keep them
        and are conditioned on the new designs (one Cholesky), unless the new designs'
        mean squared standardised leave-one-out error exceeds ``refit_guard`` for some
        output (:class:`GPSurrogate`'s guard), which re-optimises at once.
    prune_samples: posterior samples (None = BoTorch's 2048) with which the
        baseline is pruned to the designs with a positive probability of being Pareto
        optimal (``prune_inferior_points_multi_objective``); sampling all n designs
        jointly is O(samples x n^2) per output: 1.0 s CPU at 500 designs with 2048
        samples, 0.32 s with 512, baselines of 11-12 designs either way (docs/speed.md).
    sequential: True = ``optimize_acqf``'s sequential greedy batch (q L-BFGS-B runs over
        D variables, each design conditioned on those before it as pending points);
        False = one joint L-BFGS-B run over the q x D variables of the whole batch.
    acq_ftol: L-BFGS-B's relative tolerance on the acquisition's value (SciPy's
        ``ftol``), an early stop of the inner optimisation once an iteration improves
        the restarts' summed log-acquisition by less than this fraction; None = SciPy's
        default (2.2e-9, i.e. nearly always ``acq_maxiter`` iterations).

One iteration (every design evaluated for real so far, failed ones left out):

1. Inputs are mapped to the unit cube u = (x - xl) / (xu - xl); objectives to
   f~ = (f - min f) / (max f - min f) per objective over the data, negated because
   BoTorch maximises; constraints to g~_k = g_k / max |g_k| (g~ <= 0 still means
   feasible, and the sigmoid's eta acts on a unit scale whatever the physical units).
2. One GP per output (BoTorch ``SingleTaskGP`` batched over the M + K outputs, fitted per
   output with warm start, re-optimised every ``refit_every`` iterations;
   :class:`tmopt.surrogates.gp.GPSurrogate`), float64.
3. Reference point, in minimisation terms: r = max_{p in P} f~_p + ref_offset, where P is
   every observation, i.e. r = 1 + ref_offset (``ref_point="feasible"``: the feasible
   observations; ``"front"``: their non-dominated set; both fall back to all observations
   while none is feasible). (BoTorch's ``infer_reference_point`` uses the
   front's own range, which degenerates to the point itself for a one-point front and,
   like any front-based nadir, credits no improvement beyond the front's current extent.)
4. qLogNEHVI with X_baseline = the observed inputs (pruned to likely Pareto-optimal
   points; at most ``max_baseline`` of them, the most probable, when it is set), the
   objectives as outcomes and one constraint callable per g~_k, maximised by
   ``optimize_acqf`` with sequential greedy batch selection (q candidates one after the
   other, each conditioned on the previous as pending points).

Reproducibility: the Sobol sample, the QMC sampler, the raw samples and the restart
choice of ``optimize_acqf`` and the pruning of the baseline are all seeded from the run's
seed (torch's global generator is forked, so other code is not disturbed). An iteration
leaves only its fitted GP hyperparameters (the next fit's warm start) and one seed draw in
the state, so a resumed run takes the archived designs instead of re-optimising the
acquisition (:meth:`Algorithm.replayed`) and the last fit's GPs from the run folder's
checkpoint (``algorithm_state.pt``, written after every fit) instead of refitting: the
same result, seconds not hours to catch up. Without a usable checkpoint (an older run, a
damaged file) the resume refits every replayed iteration's GPs, as exact but slower.
"""

from __future__ import annotations

import logging
import time
import warnings

import numpy as np
import torch
from botorch.acquisition.multi_objective.logei import qLogNoisyExpectedHypervolumeImprovement
from botorch.acquisition.multi_objective.objective import IdentityMCMultiOutputObjective
from botorch.acquisition.multi_objective.utils import prune_inferior_points_multi_objective
from botorch.optim import optimize_acqf
from botorch.sampling import SobolQMCNormalSampler
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting
from scipy.stats import qmc

from tmopt.algorithms.base import (
    Algorithm,
    AlgorithmConfigError,
    check_choice,
    check_int,
    check_number,
)
from tmopt.evaluation.evaluator import EvaluatedBatch
from tmopt.problems.base import ExpensiveProblem
from tmopt.surrogates.gp import KERNELS, GPSurrogate
from tmopt.surrogates.gp_posterior import CachedJointGP

log = logging.getLogger(__name__)

_DTYPE = torch.float64


class QLogNEHVI(Algorithm):
    """qLogNEHVI (see the module docstring for parameters and the algorithm)."""

    name = "qlognehvi"

    def __init__(self, *, n_init: int | None = None, q: int = 5, num_restarts: int = 4,
                 raw_samples: int = 256, acq_maxiter: int = 30, mc_samples: int = 64,
                 ref_offset: float = 0.1, ref_point: str = "all",
                 eta: float = 1e-3, gp_max_iter: int = 50, kernel: str = "rbf",
                 max_baseline: int | None = None, max_iter: int | None = None,
                 threads: int | None = 1, cached_posterior: bool = True,
                 init_batch_limit: int | None = 256, refit_every: int = 5,
                 refit_guard: float | None = 4.0, prune_samples: int | None = 512,
                 gp_guard_max_iter: int | None = 5, sequential: bool = True,
                 acq_ftol: float | None = None) -> None:
        n = self.name
        self.q = check_int(n, "q", q, 1)
        super().__init__(pop_size=max(self.q, 2))  # the batch is all the "population" it has
        self.n_init = None if n_init is None else check_int(n, "n_init", n_init, 2)
        self.num_restarts = check_int(n, "num_restarts", num_restarts, 1)
        self.raw_samples = check_int(n, "raw_samples", raw_samples, 1)
        self.acq_maxiter = check_int(n, "acq_maxiter", acq_maxiter, 1)
        self.mc_samples = check_int(n, "mc_samples", mc_samples, 1)
        self.ref_offset = check_number(n, "ref_offset", ref_offset, 0.0, low_open=True)
        self.ref_point = check_choice(n, "ref_point", ref_point, REFERENCE_RULES)
        self.eta = check_number(n, "eta", eta, 0.0, low_open=True)
        self.gp_max_iter = check_int(n, "gp_max_iter", gp_max_iter, 1)
        self.kernel = check_choice(n, "kernel", kernel, KERNELS)
        self.max_baseline = None if max_baseline is None else check_int(
            n, "max_baseline", max_baseline, 1)
        self.max_iter = None if max_iter is None else check_int(n, "max_iter", max_iter, 0)
        self.threads = None if threads is None else check_int(n, "threads", threads, 1)
        self.cached_posterior = bool(cached_posterior)
        self.init_batch_limit = None if init_batch_limit is None else check_int(
            n, "init_batch_limit", init_batch_limit, 1)
        self.refit_every = check_int(n, "refit_every", refit_every, 1)
        self.refit_guard = None if refit_guard is None else check_number(
            n, "refit_guard", refit_guard, 0.0, low_open=True)
        self.prune_samples = None if prune_samples is None else check_int(
            n, "prune_samples", prune_samples, 1)
        self.gp_guard_max_iter = None if gp_guard_max_iter is None else check_int(
            n, "gp_guard_max_iter", gp_guard_max_iter, 1)
        self.sequential = bool(sequential)
        self.acq_ftol = None if acq_ftol is None else check_number(
            n, "acq_ftol", acq_ftol, 0.0, 1.0, low_open=True)

    # ---- framework hooks --------------------------------------------------------------------
    def initial_sample_size(self, problem: ExpensiveProblem) -> int:
        """2 (D + 1) scrambled Sobol points unless ``n_init`` is given."""
        return self.n_init if self.n_init is not None else 2 * (int(problem.n_var) + 1)

    def _setup(self) -> None:
        p = self.problem
        if p.n_obj < 2:
            raise AlgorithmConfigError(f"algorithm {self.name}: needs at least 2 objectives, "
                                       f"problem {p.name} has {p.n_obj}")
        self.U = np.zeros((0, p.n_var))
        self.F = np.zeros((0, p.n_obj))
        self.G = np.zeros((0, p.n_ieq_constr))
        self.gp = GPSurrogate(kernel=self.kernel, max_iter=self.gp_max_iter, warm_start=True,
                              refit_every=self.refit_every, refit_guard=self.refit_guard,
                              guard_max_iter=self.gp_guard_max_iter,
                              rbf_fallback=False, seed=self.seed)
        self.iteration = 0
        self.timing: dict[str, float] = {}
        minutes = self.expected_minutes()
        if minutes >= LONG_RUN_MINUTES:  # say so before a long run starts
            log.warning("%s: %d evaluations at D = %d: expect roughly %.0f min of one core "
                        "for the GP fits and acquisitions (docs/speed.md); one progress "
                        "line per iteration follows", self.name, self.budget, p.n_var, minutes)

    def expected_minutes(self) -> float:
        """Rough CPU minutes of this run's BO iterations on one core of the benchmark
        machine: the per-iteration costs that ``experiments/bench_speed.py`` measured on
        the stiffness problem (D = 18, 6 GP outputs), interpolated at each iteration's
        number of designs; other problems differ by their dimension and outputs."""
        table = COST_DEFAULT if self.cached_posterior else COST_REFERENCE
        n0 = self.initial_sample_size(self.problem)
        sizes = np.arange(n0, self.budget, self.q)
        if self.max_iter is not None:
            sizes = sizes[: self.max_iter]
        xs = sorted(table)
        return float(np.interp(sizes, xs, [table[x] for x in xs]).sum()) / 60.0

    def has_next(self) -> bool:
        """False once ``max_iter`` BO iterations followed the initial sample."""
        return self.max_iter is None or self.iteration <= self.max_iter

    def info(self) -> dict:
        out: dict = {"iteration": self.iteration}
        out.update({k: f"{v:.1f}s" for k, v in self.timing.items()})
        fit = getattr(self, "gp", None) and self.gp.fit_info
        if fit:  # how the GPs were made: optimised ("mll"...) or kept, and the guard's value
            out["gp"] = f"{fit.get('stage')}{'_guard' if fit.get('guard') else ''}"
            if "surprise" in fit:
                out["surprise"] = f"{fit['surprise']:.2f}"
        return out

    # ---- ask ----------------------------------------------------------------------------------
    def _infill(self) -> np.ndarray:
        p = self.problem
        replayed = None
        if self.iteration == 0:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # n need not be a power of 2 here
                U = qmc.Sobol(p.n_var, scramble=True, seed=self.rng).random(
                    self.initial_sample_size(p))
        else:
            replayed = self.replayed(self.q)
            U = self._propose(maximise=replayed is None)
        self.iteration += 1
        return replayed if replayed is not None else p.xl + U * (p.xu - p.xl)

    def _propose(self, maximise: bool = True) -> np.ndarray | None:
        """q new points in the unit cube: fit the GPs, then maximise qLogNEHVI.

        ``maximise=False`` (a resume replaying archived designs) fits the GPs (or takes
        them from the checkpoint) and draws the iteration's seed, the only state an
        iteration leaves, and skips the acquisition.
        """
        before = torch.get_num_threads()
        if self.threads is not None:
            torch.set_num_threads(self.threads)
        try:
            return self._fit_and_maximise(maximise)
        finally:
            torch.set_num_threads(before)

    def _fit_and_maximise(self, maximise: bool = True) -> np.ndarray | None:
        Y, ref = self._training_targets()
        start = time.perf_counter()
        self._fit_or_restore(Y, replaying=not maximise)
        self.timing["fit"] = time.perf_counter() - start
        start = time.perf_counter()
        seed = int(self.rng.integers(2**31 - 1))
        if not maximise:
            self.timing["acq"] = 0.0
            return None
        candidates = self._maximise(ref, seed)
        self.timing["acq"] = time.perf_counter() - start
        return candidates

    def _maximise(self, ref: np.ndarray, seed: int) -> np.ndarray:
        """The q designs (unit cube, ``(q, D)``) maximising qLogNEHVI under the fitted GPs;
        ``seed`` seeds the MC sampler, the baseline pruning and the restarts."""
        # The same exact posterior; CachedJointGP only skips recomputing the baseline rows
        model = CachedJointGP(self.gp) if self.cached_posterior else self.gp.model
        with torch.random.fork_rng(), warnings.catch_warnings():
            torch.manual_seed(seed)  # Boltzmann restart choice and baseline pruning
            warnings.simplefilter("ignore")
            acq = self.acquisition(model, ref, seed, self.mc_samples)
            bounds = torch.stack([torch.zeros(self.problem.n_var, dtype=_DTYPE),
                                  torch.ones(self.problem.n_var, dtype=_DTYPE)])
            candidates, _ = optimize_acqf(
                acq, bounds=bounds, q=self.q, num_restarts=self.num_restarts,
                raw_samples=self.raw_samples, sequential=self.sequential,
                options=self._acq_options(seed))
        return np.clip(candidates.detach().numpy(), 0.0, 1.0)

    def acquisition(self, model, ref: np.ndarray, seed: int, mc_samples: int):
        """qLogNEHVI over the observed designs (pruned), ``mc_samples`` seeded Sobol samples
        of the joint posterior; the pruning draws from torch's global generator."""
        m, k = self.problem.n_obj, self.problem.n_ieq_constr
        objective = IdentityMCMultiOutputObjective(outcomes=list(range(m)))
        constraints = [_column(m + j) for j in range(k)] or None
        baseline = torch.as_tensor(self.U, dtype=_DTYPE)
        capped = self.max_baseline is not None and len(baseline) > self.max_baseline
        prune_here = capped or self.prune_samples is not None
        if prune_here:  # else inside the acquisition, BoTorch's defaults (the same call)
            options = {} if self.prune_samples is None else {
                "num_samples": self.prune_samples}
            if capped:  # the max_baseline designs most likely Pareto optimal
                options["max_frac"] = (self.max_baseline - 0.5) / len(baseline)  # ceil
            baseline = prune_inferior_points_multi_objective(
                model, baseline, ref_point=torch.as_tensor(ref, dtype=_DTYPE),
                objective=objective, constraints=constraints, **options)
        return qLogNoisyExpectedHypervolumeImprovement(
            model=model, ref_point=ref.tolist(), X_baseline=baseline,
            sampler=SobolQMCNormalSampler(torch.Size([mc_samples]), seed=seed),
            objective=objective, constraints=constraints,
            eta=self.eta, prune_baseline=not prune_here)

    def _acq_options(self, seed: int) -> dict:
        """``optimize_acqf``'s options: restarts in one batch, L-BFGS-B's limits."""
        options = {"batch_limit": self.num_restarts, "maxiter": self.acq_maxiter,
                   "init_batch_limit": self.init_batch_limit or self.num_restarts,
                   "seed": seed}
        if self.acq_ftol is not None:  # BoTorch's batched L-BFGS-B takes ftol or factr
            options.update(ftol=self.acq_ftol, factr=None)
        return options

    def _fit_or_restore(self, Y: np.ndarray, replaying: bool) -> None:
        """Fit the GPs and checkpoint them, or, on a resume, take them from the checkpoint.

        The checkpoint holds the fit of iteration i (its warm start is every earlier fit), so
        a resume skips the fits of the replayed iterations before i and restores i's.
        """
        saved = self.resume_state
        if saved is not None and self.iteration <= saved["iteration"]:
            if self.iteration == saved["iteration"]:
                self.gp.restore(self.U, Y, saved["gp"])
            elif not replaying:  # the archive vouched for every design before iteration i
                raise RuntimeError(f"algorithm {self.name}: the checkpoint of iteration "
                                   f"{saved['iteration']} was matched to the archive, but "
                                   f"iteration {self.iteration} is not in it")
            return
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # BoTorch's input-scaling notices on unit data
            self.gp.fit(self.U, Y)
        self._write_checkpoint({"iteration": self.iteration, "gp": self.gp.state()})

    def _training_targets(self) -> tuple[np.ndarray, np.ndarray]:
        """GP targets [-f~, g~] and the reference point (maximisation) for the data."""
        lo, span = self.F.min(axis=0), np.ptp(self.F, axis=0)
        Fn = (self.F - lo) / np.where(span > 0.0, span, 1.0)
        scale = np.max(np.abs(self.G), axis=0) if self.G.shape[1] else np.ones(0)
        Gn = self.G / np.where(scale > 0.0, scale, 1.0)
        ref = -(reference_nadir(Fn, self.G, self.ref_point) + self.ref_offset)
        return np.hstack([-Fn, Gn]), ref

    # ---- tell ---------------------------------------------------------------------------------
    def _advance(self, batch: EvaluatedBatch) -> None:
        ok = ~np.asarray(batch.failed, dtype=bool)  # penalties are not data for the GPs
        p = self.problem
        self.U = np.vstack([self.U, (batch.X[ok] - p.xl) / (p.xu - p.xl)])
        self.F = np.vstack([self.F, batch.F[ok]])
        self.G = np.vstack([self.G, batch.G[ok]])
        if len(self.U) < 2 and self.n_evals >= self.initial_sample_size(p):
            raise AlgorithmConfigError(
                f"algorithm {self.name}: only {len(self.U)} of {self.n_evals} designs "
                f"evaluated without failure on problem {p.name}; the GPs need at least 2")


#: A run expected to take longer (CPU minutes) says so when it starts.
LONG_RUN_MINUTES = 5.0
#: CPU seconds per iteration at n designs (stiffness problem, D = 18; docs/speed.md):
#: the default settings (the acquisition measured by experiments/bench_speed.py on a Table
#: 3 run's archive plus the mix of kept, guard-capped and scheduled GP fits of such a run:
#: 14.1-14.6 min per run, docs/speed.md "Round four") and the reference preset (Table 3's
#: runs, docs/results.md "qLogNEHVI's cost").
COST_DEFAULT = {150: 4.3, 400: 5.5, 650: 11.0}
COST_REFERENCE = {50: 5.0, 200: 15.0, 300: 60.0, 500: 240.0, 697: 420.0}

#: Where the reference point's nadir is taken (see :func:`reference_nadir`).
REFERENCE_RULES = ("feasible", "front", "all")


def reference_nadir(Fn: np.ndarray, G: np.ndarray, rule: str = "all") -> np.ndarray:
    """Worst value per objective over the designs that ``rule`` names.

    ``rule="feasible"``: over every feasible design (over all while none is feasible, as
    for "front"). ``rule="front"``: over their
    non-dominated set only — tighter, but the hypervolume improvement is then zero beyond
    the current front's extent + ``ref_offset``, so a front found at one end can grow by
    at most ``ref_offset`` per iteration. ``rule="all"``: over every design, feasible or
    not (1 in these normalised units), the loosest. Measured on MW3 (D = 6, 120
    evaluations, seeds 0 and 1, ``experiments/qlognehvi_reference_point.py``): IGD 0.50
    ("feasible") and 0.71 ("front") with fronts within f1 <= 0.18, against 0.042 ("all")
    with fronts over the whole f1 in [0, 1]: the first feasible designs lay at one end,
    and a nadir taken over them credits nothing beyond it.

    Args:
        Fn: Normalised objectives ``(n, m)`` (minimisation).
        G: Constraints ``(n, k)``, ``<= 0`` feasible.
        rule: ``"feasible"``, ``"front"`` or ``"all"``.
    """
    feasible = np.all(G <= 0.0, axis=1) if G.shape[1] else np.ones(len(Fn), dtype=bool)
    pool = Fn[feasible] if feasible.any() and rule != "all" else Fn
    if rule == "front":
        pool = pool[NonDominatedSorting().do(pool, only_non_dominated_front=True)]
    return pool.max(axis=0)


def _column(j: int):
    """Constraint callable for BoTorch: samples ``(..., q, outputs) -> (..., q)``, <= 0 ok."""
    def constraint(Z: torch.Tensor) -> torch.Tensor:
        return Z[..., j]
    return constraint
