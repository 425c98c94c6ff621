"""Motion-state optimisation for test-mass stiffness identification (paper Sec. 3.2.1).

Decision variables are the multi-sine reference motions of Eq. 17, per test mass and per
frequency ``i = 1..k``: amplitude ``A_i`` [m], angular frequency ``w_i`` [rad/s] and phase
``theta_i`` [rad] (the bias ``B_i = -A_i sin theta_i`` follows from them). The vector is
laid out per test mass as ``[A_1..A_k, w_1..w_k, theta_1..theta_k]``.

Schemes (paper Table 2):

====== ==================== =================== ==================
scheme decision variables   objectives          dimensions
====== ==================== =================== ==================
A      TM1 (3k)             TM1 (time, RMSE)    3k & 2
B      TM1 + TM2 (6k)       TM1 (time, RMSE)    6k & 2
C      TM1 + TM2 (6k)       TM1 + TM2           6k & 4
====== ==================== =================== ==================

In scheme A TM2 is held at its nominal position (zero reference); its constraints are
then satisfied by construction and are not part of the problem (paper Sec. 4.4).

Objectives: convergence time (Eq. 18) and convergence accuracy (Eq. 19) of the
identified sensitive-axis stiffness, computed by the batched simulator (:mod:`tmopt.physics`).
Constraints: Eq. 20 per test mass on the simulated run (``constraints="realised"``, the
default), normalised by their limits so both are O(1): ``g1 = max_t |u(t)| / (alpha1
F_max) - 1`` (largest commanded sensitive-axis force) and ``g2 = max_t |x(t)| / (alpha2 D)
- 1`` (largest true displacement, start-up transient included); ``constraints="reference"``
evaluates them on the reference instead (``sum_i A_i w_i^2`` and ``max_t |x_ref(t)|``, no
simulation needed).  They form one constraint group per test mass; the group of the key
test mass (TM1 by
default: the one whose stiffness is identified) has priority 0 — the "key individual
constraints" of MGSAEA-IPC. A design whose closed loop diverges is reported as failed
with the simulator's reason (the evaluator then treats it as infeasible).

Noise (``noise``, docs/noise.md): the objectives of one evaluation are a noise draw.
``fixed`` (the paper's protocol) scores every design on one realisation (``noise_seed``);
``fresh`` draws a new realisation for every evaluation (a seed hashed from the noise
seed, the run seed and the archive row, so a resumed run replays exactly); ``average``
scores each design by the mean over K realisations ``noise_seed .. noise_seed + K - 1``,
common to every design; ``information`` predicts the expected objectives from the RLS
information matrix of the design's noise-free realised motion and the known noise level
(:mod:`tmopt.physics.information`), with no draw at all.  Every evaluation returns the
seeds that scored it (``out["noise_seeds"]``, (n, K), -1 padded).  After a run, the chosen
design and the final front are re-scored on held-out seeds no search can draw
(:meth:`StiffnessProblem.heldout_report`), beside the physical floor
(:mod:`tmopt.physics.floor`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from tmopt.metrics.identification import metric_m_at_threshold
from tmopt.physics import information
from tmopt.physics import objectives as phys_obj
from tmopt.physics.control import ControllerSettings
from tmopt.physics.excitation import PERIOD_BOUNDS, MultiSine
from tmopt.physics.noise import USER_SEEDS, fresh_seeds, heldout_seeds
from tmopt.physics.scenario import config_at_rate
from tmopt.physics.simulator import SimulationConfig, SimulationResult, simulate
from tmopt.problems import heldout
from tmopt.problems.base import ConstraintGroup, ExpensiveProblem

SCHEMES = {
    # scheme: (test masses with decision variables, test masses with objectives)
    "A": ((1,), (1,)),
    "B": ((1, 2), (1,)),
    "C": ((1, 2), (1, 2)),
}
#: Convergence thresholds for the stricter M of Table 3.
STRICT_THRESHOLDS = (7e-11, 5e-11)
#: Where Eq. 20 is evaluated: on the simulated run or on the reference motion.
CONSTRAINT_MODES = ("realised", "reference")
#: How an evaluation meets the noise (module docstring, docs/noise.md).
NOISE_MODES = ("fixed", "fresh", "average", "information")
#: The run ``information`` checks the realised Eq. 20 on (constructor docstring).
INFORMATION_CONSTRAINTS = ("noise_free", "noise_seed", "noise_margin")
#: Noise-only runs whose largest peaks make ``noise_margin``'s back-off (docs/noise.md).
MARGIN_SEEDS = 32
#: Designs per noise-free run with every channel recorded (information mode): ~2 MB each.
_FULL_RECORD_CHUNK = 16


class StiffnessProblem(ExpensiveProblem):
    """Schemes A/B/C x ``n_freq`` frequencies of the stiffness-identification problem.

    Args:
        scheme: ``"A"``, ``"B"`` or ``"C"`` (paper Table 2).
        n_freq: Frequencies k per test mass, 1..8.
        amplitude_bounds: ``(low, high)`` of every ``A_i`` [m].
        period_bounds: ``(shortest, longest)`` period [s]; ``w_i = 2 pi / period``.
        phase_bounds: ``(low, high)`` of every ``theta_i`` [rad].
        key_tm: Test mass whose constraints have priority 0 (1 or 2).
        noise: ``"fixed"`` | ``"fresh"`` | ``"average"`` | ``"information"`` (module
            docstring).
        noise_seed: The ``fixed`` realisation, the first of ``average``'s K and the key of
            ``fresh``'s hash, and of ``noise_margin``'s runs; in
            [0, 2^50 - max(noise_samples, MARGIN_SEEDS)].
        noise_samples: K, the realisations ``average`` scores each design on (1..1000).
        heldout_seeds: Held-out realisations the chosen design and the final front are
            re-scored on after a run (0: none; >= 32 for a figure worth reporting).
        epsilon: Convergence threshold of Eq. 18 [s^-2].
        m_weights: Weights of Eq. 29 (time, accuracy).
        duration, sample_rate, controller, f_max, alpha1, gap, alpha2: simulator settings
            (Sec. 4.1, 4.4): run length [s], sampling [Hz] (Table 1 noise ASDs and the
            continuous PID gains kept at any rate: :func:`tmopt.physics.scenario.config_at_rate`),
            ``"frbf_pid"`` or ``"pid"``,
            F_max [m s^-2], alpha1, electrode gap D [m], alpha2.
        stiffness_1, stiffness_2: True (x, y) stiffness of TM1 and TM2 [s^-2] (Table 1).
        constraints: ``"realised"`` (Eq. 20 on the simulated motion and commanded force)
            or ``"reference"`` (on the reference motion, before simulating).
        information_constraints: With ``noise="information"`` and realised constraints,
            the run Eq. 20 is checked on: ``"noise_free"`` (the predicted objectives' own
            run; the noise's share of the force is not seen), ``"noise_seed"`` (the run at
            ``noise_seed``, as ``fixed`` checks it; one more simulation per design) or
            ``"noise_margin"`` (the noise-free run with the limits backed off by the
            largest peak force and displacement of ``MARGIN_SEEDS`` noise-only runs:
            no draw per design). docs/noise.md "Constraints under information".
        ramp_in: Seconds over which every reference is ramped in (raised cosine; 0: none).
        rls_columns: Identified theta columns: a name of ``RLS_COLUMN_SETS`` ("sensitive":
            k1xx, k2xx, R; "all": the five of Eq. 14) or a list of names; it must
            include the stiffness of every objective test mass.
        y_axes: Non-sensitive axes and spacecraft acceleration, a name of
            :data:`tmopt.physics.scenario.Y_AXES`
            ("drag_free": Table 1; "round1": the first round's f_B and slow y PID).
        jacobian: Plant-Jacobian sign of the FRBF-PID's learning law ("plus" | "online").
        chunk: Runs (designs x noise seeds) simulated per call (bounds memory; results
            do not depend on it).
        name: Problem name.
    """

    def __init__(
        self,
        *,
        scheme: str = "B",
        n_freq: int = 3,
        amplitude_bounds: Sequence[float] = (1e-6, 2e-4),
        period_bounds: Sequence[float] = PERIOD_BOUNDS,
        phase_bounds: Sequence[float] = (0.0, 2 * math.pi),
        key_tm: int = 1,
        noise: str = "fixed",
        noise_seed: int = 0,
        noise_samples: int = 8,
        heldout_seeds: int = 32,
        epsilon: float = phys_obj.EPSILON,
        m_weights: Sequence[float] = phys_obj.M_WEIGHTS,
        duration: float = SimulationConfig.duration,
        sample_rate: float = SimulationConfig.sample_rate,
        controller: str = "frbf_pid",
        f_max: float = SimulationConfig.f_max,
        alpha1: float = SimulationConfig.alpha1,
        gap: float = SimulationConfig.gap,
        alpha2: float = SimulationConfig.alpha2,
        stiffness_1: Sequence[float] = SimulationConfig.stiffness_1,
        stiffness_2: Sequence[float] = SimulationConfig.stiffness_2,
        constraints: str = "realised",
        information_constraints: str = "noise_free",
        ramp_in: float = SimulationConfig.ramp_in,
        rls_columns: str | Sequence[str] = "sensitive",
        y_axes: str = "drag_free",
        jacobian: str = "plus",
        chunk: int = 100,
        name: str = "stiffness",
    ) -> None:
        if scheme not in SCHEMES:
            raise ValueError(f"problem {name}: scheme must be one of {sorted(SCHEMES)}, "
                             f"got {scheme!r}")
        _check_int(name, "n_freq", n_freq, 1, 8)
        _check_int(name, "key_tm", key_tm, 1, 2)
        _check_int(name, "chunk", chunk, 1, 10_000)
        if noise not in NOISE_MODES:
            raise ValueError(f"problem {name}: noise must be one of {NOISE_MODES}, "
                             f"got {noise!r}")
        _check_int(name, "noise_samples", noise_samples, 1, 1000)
        _check_int(name, "noise_seed", noise_seed, USER_SEEDS[0],
                   USER_SEEDS[1] - max(int(noise_samples), MARGIN_SEEDS))
        _check_int(name, "heldout_seeds", heldout_seeds, 0, 100_000)
        self.scheme, self.n_freq, self.key_tm = scheme, int(n_freq), int(key_tm)
        self.noise_seed, self.chunk = int(noise_seed), int(chunk)
        self.noise, self.noise_samples = noise, int(noise_samples)
        self.n_heldout = int(heldout_seeds)
        self._fresh_rows = 0  # fresh draws without an evaluator: rows counted here
        self._margin: np.ndarray | None = None  # noise_margin's back-off, computed once
        self.epsilon = _positive(name, "epsilon", epsilon)
        self.m_weights = _weights(name, m_weights)
        if constraints not in CONSTRAINT_MODES:
            raise ValueError(f"problem {name}: constraints must be one of {CONSTRAINT_MODES}, "
                             f"got {constraints!r}")
        self.constraint_mode = constraints
        if information_constraints not in INFORMATION_CONSTRAINTS:
            raise ValueError(f"problem {name}: information_constraints must be one of "
                             f"{INFORMATION_CONSTRAINTS}, got {information_constraints!r}")
        self.information_constraints = information_constraints
        columns = rls_columns if isinstance(rls_columns, str) else tuple(rls_columns)
        try:  # the scenario's one route: sample-rate rule, named y axes, physics options
            self.config = config_at_rate(
                sample_rate, y_axes=y_axes, duration=duration, controller=controller,
                f_max=f_max, alpha1=alpha1, gap=gap, alpha2=alpha2, record="estimates",
                stiffness_1=tuple(float(v) for v in stiffness_1),
                stiffness_2=tuple(float(v) for v in stiffness_2), ramp_in=float(ramp_in),
                rls_columns=columns, control=ControllerSettings(jacobian=jacobian))
        except ValueError as exc:
            raise ValueError(f"problem {name}: {exc}") from None
        self.y_axes = y_axes
        self.decision_tms, self.objective_tms = SCHEMES[scheme]
        for tm in self.objective_tms:
            if f"k{tm}xx" not in self.config.rls_columns:
                raise ValueError(f"problem {name}: rls_columns must include k{tm}xx (an "
                                 f"objective of scheme {scheme}); got {rls_columns!r}")
        lo, hi = self._bounds(name, amplitude_bounds, period_bounds, phase_bounds)
        groups, cnames = self._constraint_layout()
        onames = [f"{q}_TM{tm}" for tm in self.objective_tms
                  for q in ("convergence_time", "convergence_accuracy")]
        super().__init__(n_var=len(lo), n_obj=len(onames), n_ieq_constr=len(cnames), xl=lo,
                         xu=hi, name=name, constraint_groups=groups, objective_names=onames,
                         constraint_names=cnames, requires_kwargs=True)

    # ---- layout ------------------------------------------------------------------------
    def _bounds(self, name, amplitude_bounds, period_bounds, phase_bounds):
        a = _interval(name, "amplitude_bounds", amplitude_bounds, minimum=0.0)
        p = _interval(name, "period_bounds", period_bounds, minimum=0.0)
        ph = _interval(name, "phase_bounds", phase_bounds)
        nyquist_period = 2.0 / self.config.sample_rate
        if p[0] <= nyquist_period:
            raise ValueError(f"problem {name}: period_bounds must start above the Nyquist "
                             f"period {nyquist_period:g} s, got {p[0]!r}")
        w = (2 * math.pi / p[1], 2 * math.pi / p[0])
        k = self.n_freq
        lo = np.concatenate([[a[0]] * k, [w[0]] * k, [ph[0]] * k] * len(self.decision_tms))
        hi = np.concatenate([[a[1]] * k, [w[1]] * k, [ph[1]] * k] * len(self.decision_tms))
        return lo, hi

    def _constraint_layout(self) -> tuple[list[ConstraintGroup], list[str]]:
        groups, names = [], []
        for j, tm in enumerate(self.decision_tms):
            names += [f"actuation_TM{tm}", f"displacement_TM{tm}"]
            groups.append(ConstraintGroup(f"TM{tm}", (2 * j, 2 * j + 1),
                                          priority=0 if tm == self.key_tm else 1))
        return groups, names

    def variable_names(self) -> list[str]:
        k = range(1, self.n_freq + 1)
        return [f"{q}{i}_TM{tm}" for tm in self.decision_tms for q in ("A", "w", "theta")
                for i in k]

    def references(self, X: np.ndarray) -> tuple[MultiSine, MultiSine]:
        """Reference motions of TM1 and TM2 for designs ``X (n, n_var)``."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        k = self.n_freq
        refs = {}
        for j, tm in enumerate(self.decision_tms):
            block = X[:, 3 * k * j: 3 * k * (j + 1)]
            refs[tm] = MultiSine(block[:, :k], block[:, k:2 * k], block[:, 2 * k:])
        if 2 not in refs:  # scheme A: TM2 held at nominal
            refs[2] = MultiSine(np.zeros((len(X), 1)), np.zeros((len(X), 1)))
        return refs[1], refs[2]

    # ---- evaluation --------------------------------------------------------------------
    def simulate_designs(self, X: np.ndarray, record: str = "estimates",
                         seed=None) -> SimulationResult:  # fmt: skip
        """Closed-loop simulation of designs ``X``: with the ``fixed`` realisation, or
        ``seed`` (one seed or one per design)."""
        ref1, ref2 = self.references(X)
        cfg = self.config if record == self.config.record else \
            replace(self.config, record=record)
        return simulate(ref1, ref2, cfg, seed=self.noise_seed if seed is None else seed)

    @property
    def seeds_per_evaluation(self) -> int:
        """Noise realisations that score one evaluation (``information``: 0, the one its
        constraints are checked on with ``information_constraints="noise_seed"``, or the
        ``MARGIN_SEEDS`` noise-only runs behind ``"noise_margin"``'s back-off)."""
        return {"fixed": 1, "fresh": 1, "average": self.noise_samples,
                "information": len(self._information_seeds())}[self.noise]  # fmt: skip

    def _information_seeds(self) -> np.ndarray:
        """The realisations ``information``'s constraints depend on (none if noise-free)."""
        if self.constraint_mode != "realised":
            return np.zeros(0, dtype=np.int64)
        n = {"noise_free": 0, "noise_seed": 1,
             "noise_margin": MARGIN_SEEDS}[self.information_constraints]  # fmt: skip
        return self.noise_seed + np.arange(n, dtype=np.int64)

    def noise_margin(self) -> np.ndarray:
        """``noise_margin``'s back-off, (4,) ``[u TM1, x TM1, u TM2, x TM2]`` in the units
        of :func:`tmopt.physics.objectives.eq20_realised`: per channel the largest peak
        over ``MARGIN_SEEDS`` runs of the controlled system with both references at
        rest (the noise alone). The closed loop is close to linear, so a design's noisy
        peak is at most its noise-free peak plus the noise's own (the triangle
        inequality; checked on the simulator by
        ``test_a_design_noise_margin_admits_at_the_force_limit_keeps_eq20_on_noisy_runs``).
        Computed once per problem."""
        if self._margin is None:
            seeds = self._information_seeds()
            rest = self.simulate_designs(np.zeros((len(seeds), self.n_var)), seed=seeds)
            x, u = rest.max_abs_position.max(axis=0), rest.max_abs_command.max(axis=0)
            self._margin = np.array([u[0], x[0], u[1], x[1]])
        return self._margin

    def noise_seeds(self, n: int, rows=None, run_seed: int = 0) -> np.ndarray:
        """Seeds scoring ``n`` evaluations, (n, K) int64: ``rows`` are their archive rows
        (``fresh``; without them the problem counts its own evaluations)."""
        if self.noise == "fresh":
            if rows is None:
                rows = np.arange(self._fresh_rows, self._fresh_rows + n)
                self._fresh_rows += n
            return fresh_seeds(self.noise_seed, run_seed, np.asarray(rows)).reshape(n, 1)
        base = self.noise_seed + np.arange(self.seeds_per_evaluation, dtype=np.int64)
        return np.tile(base, (n, 1))

    def _evaluate(self, X, out, *args, rows=None, run_seed: int = 0, **kwargs):
        seeds = self.noise_seeds(len(X), rows, run_seed)
        per_call = self.chunk if self.noise != "information" else \
            min(self.chunk, _FULL_RECORD_CHUNK)
        # information simulates each design once (plus at most its noise_seed draw),
        # whatever realisations its constraints depend on (noise_margin's are shared)
        draws = 1 if self.noise == "information" else seeds.shape[1]
        step = max(1, per_call // draws)
        F, G, reason = [], [], []
        for start in range(0, len(X), step):
            f, g, r = self._evaluate_chunk(X[start:start + step], seeds[start:start + step])
            F.append(f)
            G.append(g)
            reason += r
        out["F"] = np.vstack(F)
        out["G"] = np.vstack(G)
        out["reason"] = np.array(reason, dtype=object)
        out["noise_seeds"] = seeds

    def _evaluate_chunk(self, X: np.ndarray, seeds: np.ndarray):
        if self.noise == "information":
            return self._predicted_chunk(X)
        k = seeds.shape[1]
        result = self.simulate_designs(np.repeat(X, k, axis=0), seed=seeds.ravel())
        cols = []
        for tm in self.objective_tms:
            obj = phys_obj.evaluate(result, idx=tm - 1, eps=self.epsilon, weights=self.m_weights)
            cols += [obj["convergence_time"], obj["convergence_accuracy"]]
        F = np.stack(cols, axis=1).reshape(len(X), k, -1).mean(axis=1)
        reason = [next((r for r in result.reason[i * k:(i + 1) * k] if r), "")
                  for i in range(len(X))]
        if self.constraint_mode == "realised":  # the worst of the K runs
            g = self._normalised(phys_obj.eq20_realised(result))
            g = g.reshape(len(X), k, -1).max(axis=1)
        else:
            g = self.reference_constraints(X)
        return F, g, reason

    def _predicted_chunk(self, X: np.ndarray):
        """``information``: expected objectives of the noise-free realised run."""
        result = self._noise_free(X)
        sigma_e = information.equation_noise_sigma(self.config)
        cols = []
        for tm in self.objective_tms:
            pred = information.predict(result, sigma_e, idx=tm - 1, eps=self.epsilon,
                                       weights=self.m_weights)
            cols += [pred["convergence_time"], pred["convergence_accuracy"]]
        reason = [r if d else "" for r, d in zip(result.reason, result.diverged)]
        if self.constraint_mode == "realised" and self.information_constraints == "noise_seed":
            drawn = self.simulate_designs(X)  # the noise's share of the commanded force
            g = self._normalised(phys_obj.eq20_realised(drawn))
            reason = [r or (d_r if d else "") for r, d_r, d in
                      zip(reason, drawn.reason, drawn.diverged)]
        elif self.constraint_mode == "realised" and \
                self.information_constraints == "noise_margin":
            g = self._normalised(phys_obj.eq20_realised(result) + self.noise_margin())
        elif self.constraint_mode == "realised":
            g = self._normalised(phys_obj.eq20_realised(result))
        else:
            g = self.reference_constraints(X)
        return np.stack(cols, axis=1), g, reason

    def _noise_free(self, X: np.ndarray) -> SimulationResult:
        ref1, ref2 = self.references(X)
        cfg = replace(information.noise_free(self.config), record="full")
        return simulate(ref1, ref2, cfg, seed=0)

    def constraints(self, X: np.ndarray) -> np.ndarray:
        """The problem's Eq. 20 values of designs ``X`` (n, n_constr), ``<= 0`` feasible:
        on the simulated run (``constraints="realised"``, simulates) or the reference."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if self.constraint_mode == "reference":
            return self.reference_constraints(X)
        return np.vstack([self._normalised(phys_obj.eq20_realised(self.simulate_designs(
            X[i:i + self.chunk]))) for i in range(0, len(X), self.chunk)])

    def reference_constraints(self, X: np.ndarray) -> np.ndarray:
        """Eq. 20 on the references (no simulation), normalised like :meth:`constraints`."""
        ref1, ref2 = self.references(X)
        return self._normalised(phys_obj.eq20_constraints(ref1, ref2, self.config))

    def _normalised(self, raw: np.ndarray) -> np.ndarray:
        """(n, 4) [g1 TM1, g2 TM1, g1 TM2, g2 TM2] -> ``value / limit - 1`` of the
        decision test masses."""
        cfg = self.config
        limits = np.array([cfg.alpha1 * cfg.f_max, cfg.alpha2 * cfg.gap] * 2)
        norm = raw / limits  # = value/limit - 1
        cols = [c for tm in self.decision_tms for c in (2 * (tm - 1), 2 * (tm - 1) + 1)]
        return norm[:, cols]

    # ---- reporting ---------------------------------------------------------------------
    def identification_report(self, x: np.ndarray, seeds=None) -> dict:
        """Table 3 numbers of one design as the search scored it: times, accuracies, M at
        several thresholds, final accuracy.

        ``seeds``: the realisations that scored it (an archive row's ``noise_seeds``;
        default: the ``fixed``/``average`` seeds) -- the mean over them, as the
        objectives were; ``information``: the predicted (expected) numbers.
        """
        x = np.atleast_2d(x)
        if self.noise == "information":
            return self._predicted_report(x)
        if seeds is None:
            seeds = self.noise_seeds(1)[0] if self.noise != "fresh" else [self.noise_seed]
        seeds = np.asarray([s for s in np.ravel(seeds) if s >= 0], dtype=np.int64)
        result = self.simulate_designs(np.repeat(x, len(seeds), axis=0), seed=seeds)
        report = {"diverged": bool(result.diverged.any()),
                  "reason": next((r for r in result.reason if r), None)}
        report.update(self._motion_report(result))
        w1, w2 = self.m_weights
        for tm in self.objective_tms:
            idx = tm - 1
            truth = float(self.config.theta_true[idx])
            curves = result.theta_hat[:, :, idx]
            tag = f"TM{tm}"
            report[f"final_accuracy_{tag}"] = float(np.mean(np.abs(curves[:, -1] - truth)))
            for eps in (self.epsilon, *STRICT_THRESHOLDS):
                m = metric_m_at_threshold(curves, truth, eps, self.config.sample_rate, w1, w2)
                suffix = "" if eps == self.epsilon else f"@{eps:g}"
                report[f"convergence_time_{tag}{suffix}"] = float(m["convergence_time"].mean())
                report[f"convergence_accuracy_{tag}{suffix}"] = \
                    float(m["convergence_accuracy"].mean())
                report[f"M_{tag}{suffix}"] = float(m["M"].mean())
        return report

    @staticmethod
    def _motion_report(result: SimulationResult) -> dict:
        report = {}
        for tm in (1, 2):
            report[f"max_abs_x_TM{tm}"] = float(result.max_abs_position[:, tm - 1].max())
            report[f"max_abs_force_TM{tm}"] = float(result.max_abs_command[:, tm - 1].max())
            report[f"max_tracking_error_TM{tm}"] = \
                float(result.max_tracking_error[:, tm - 1].max())
        return report

    def _predicted_report(self, x: np.ndarray) -> dict:
        result = self._noise_free(x)
        sigma_e = information.equation_noise_sigma(self.config)
        report = {"diverged": bool(result.diverged[0]), "reason": result.reason[0] or None}
        report.update(self._motion_report(result))
        for tm in self.objective_tms:
            tag = f"TM{tm}"
            for eps in (self.epsilon, *STRICT_THRESHOLDS):
                pred = information.predict(result, sigma_e, idx=tm - 1, eps=eps,
                                           weights=self.m_weights)
                suffix = "" if eps == self.epsilon else f"@{eps:g}"
                for q in ("convergence_time", "convergence_accuracy", "M"):
                    report[f"{q}_{tag}{suffix}" if q != "M" else f"M_{tag}{suffix}"] = \
                        float(pred[q][0])
                if eps == self.epsilon:
                    report[f"final_accuracy_{tag}"] = float(pred["final_accuracy"][0])
        return report

    def heldout_report(self, X: np.ndarray, n_seeds: int | None = None) -> dict:
        """Every design of ``X`` on the first ``n_seeds`` held-out seeds (default
        ``heldout_seeds``): arrays (n, S) per quantity (:func:`tmopt.problems.heldout.scores`)."""
        seeds = heldout_seeds(self.n_heldout if n_seeds is None else n_seeds)
        return {"seeds": seeds, **heldout.scores(self, X, seeds)}

    def extra_metrics(self, problem, data, pareto, best: int) -> dict:
        """Runner hook: the chosen design's Table 3 numbers as the search scored it
        (re-simulated, not counted), its and the final front's held-out scores, and the
        physical floor with every reported number below it flagged."""
        if best < 0:
            return {}
        used = getattr(data, "noise_seeds", None)
        row_seeds = used[best] if used is not None and len(used) else None
        ident = self.identification_report(data.X[best], seeds=row_seeds)
        out = {"identification": ident, "scheme": self.scheme, "n_freq": self.n_freq,
               "variable_names": self.variable_names(), "noise": self.noise}
        block = None
        if self.n_heldout:
            out.update(heldout.heldout_metrics(self, data.X, best, np.asarray(pareto, int),
                                               used_seeds=used))  # fmt: skip
            block = out["heldout"]
        out["floor"] = heldout.floor_block(self, block, ident)
        return out


def _check_int(problem: str, label: str, value, lo: int, hi: int) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) \
            or not lo <= value <= hi:
        raise ValueError(f"problem {problem}: {label} must be an integer in [{lo}, {hi}], "
                         f"got {value!r}")


def _positive(problem: str, label: str, value) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"problem {problem}: {label} must be a finite number > 0, "
                         f"got {value!r}")
    return value


def _weights(problem: str, pair) -> tuple[float, float]:
    """Eq. 29's weights (time, accuracy): two finite numbers > 0."""
    vals = tuple(float(v) for v in pair) if isinstance(pair, (list, tuple)) else ()
    if len(vals) != 2 or not all(math.isfinite(v) and v > 0 for v in vals):
        raise ValueError(f"problem {problem}: m_weights must be two finite numbers > 0, "
                         f"got {pair!r}")
    return vals


def _interval(problem: str, label: str, pair, minimum: float | None = None):
    vals = [float(v) for v in pair]
    if len(vals) != 2 or not all(math.isfinite(v) for v in vals) or vals[0] >= vals[1]:
        raise ValueError(f"problem {problem}: {label} must be two finite numbers low < high, "
                         f"got {list(pair)!r}")
    if minimum is not None and vals[0] < minimum:
        raise ValueError(f"problem {problem}: {label} must be >= {minimum}, got {vals}")
    return vals
