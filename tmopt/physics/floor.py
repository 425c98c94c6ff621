"""The physical floor of stiffness identification: how well *any* admissible motion can do.

Eq. 10 is a linear regression ``y_n = psi_n' theta + e_n`` with white equation noise of
standard deviation ``sigma_e`` (:func:`tmopt.physics.information.equation_noise_sigma`;
Table 1 through K of Eq. 11: 1.73e-12 m s^-2 per sample at 10 Hz).  For an unbiased
estimate of ``k_jj`` after n samples the Cramer-Rao bound (here the least-squares
covariance, Gaussian noise) is ``sigma_e^2 [I_n^-1]_jj`` with ``I_n = sum psi psi'``;
leaving the other columns (``k_2xx``, ``R``) out of the model can only shrink it, so

    Var(k_hat_n) >= sigma_e^2 / (K_j^2 sum_{m <= n} x_m^2).

Eq. 20 bounds the motion: ``|x| <= alpha2 D`` and the commanded force ``|u| <=
alpha1 F_max``; the test mass starts at rest at the centre (Sec. 3.2.1), so with ``|x''|
<= a = alpha1 F_max + |k| alpha2 D + |f_D|`` (the force plus what the stiffness and the
bias add) ``|x(t)| <= min(alpha2 D, a t^2 / 2)``.  Putting that envelope into the sum
gives a floor no admissible motion can beat (docs/noise.md derives it):

* ``final``: the standard deviation of the last estimate (the root-mean-square of the
  final accuracy); the mean ``E|err|`` of a Gaussian error is ``sqrt(2/pi)`` of it;
* ``convergence_accuracy(t0)``: Eq. 19 after a convergence time t0,
  ``sqrt(mean_{n >= n0} Var_floor(n))`` for its root mean square, and ``sqrt(2/pi)``
  of that for its mean (``E||v|| >= sqrt(2/pi) sqrt(E||v||^2)`` for any Gaussian vector:
  ``E sqrt(sum l_i Z_i^2)`` is concave in the eigenvalues ``l``, least at one of them);
* ``m_floor``: the least ``w1 t0 + w2 E[obj2]`` over t0 (Eq. 29 at its own best
  convergence time; the steps of Eq. 18 are not bounded).  A bound for a convergence
  time fixed in advance; Eq. 18's n* is random and chosen by the run, and the mean of a
  minimum can lie below the minimum of the means, a selection this does not bound.

With the intercept R fitted (as the RLS does) the information is ``K^2 sum (x - mean
x)^2 / sigma_e^2``: :meth:`StiffnessFloor.intercept_bound` bounds it tighter while the
motion is young (4/9 of the envelope's before ``x_max`` can be reached), and
:meth:`StiffnessFloor.expected_scores` applies Eq. 18's step law to any information
trajectory (an estimate; docs/noise.md "How far below 5.99 can any motion go").

With ``constraints="reference"`` Eq. 20 bounds the reference, not the commanded force;
the actuator's hard limit ``F_max`` is then the acceleration bound.

How tight the floor is: :func:`near_optimal_motion` builds an admissible motion (rise to
``+alpha2 D``, hold, cross to ``-alpha2 D``, hold, with raised-cosine transitions at 90 %
of the force limit) whose own bound is within a few per cent of the floor; the simulator
run on it over many seeds lands on that bound (tests/physics/test_floor.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import cumulative_trapezoid

from tmopt.physics.information import convergence_law, equation_noise_sigma, expected_rms_after
from tmopt.physics.objectives import EPSILON, M_WEIGHTS, PARAMETERS

__all__ = ["StiffnessFloor", "stiffness_floor", "near_optimal_motion", "cycloid_transitions",
           "knot_motion"]

_MEAN_OF_ABS = math.sqrt(2 / math.pi)  # E|Z| / sqrt(E Z^2) for a Gaussian


@dataclass(frozen=True)
class StiffnessFloor:
    """The floor of one identified stiffness ``k_jj`` (j = ``idx``) for one problem.

    Attributes: ``sigma_e`` equation noise per sample [m s^-2]; ``coefficient`` |K_j|;
    ``x_max`` the motion limit alpha2 D [m]; ``accel_max`` the acceleration bound [m s^-2];
    ``sample_rate`` [Hz]; ``n_steps`` N; ``prior_info`` the RLS prior's information on
    k_jj [s^4] (negligible, kept so the floor stays a bound on the RLS itself);
    ``force_limit`` the commanded-force limit of Eq. 20 [m s^-2]; ``prior_r_info`` the
    prior's information on the intercept R [s^4 m^-2] (:meth:`motion_information`).
    """

    idx: int
    sigma_e: float
    coefficient: float
    x_max: float
    accel_max: float
    sample_rate: float
    n_steps: int
    prior_info: float
    force_limit: float
    prior_r_info: float = 0.0

    def envelope(self) -> np.ndarray:
        """``min(x_max, a t_n^2 / 2)`` at every sample (N,) [m]: no admissible |x_n| exceeds it."""
        t = np.arange(self.n_steps) / self.sample_rate
        return np.minimum(self.x_max, 0.5 * self.accel_max * t**2)

    def variance(self) -> np.ndarray:
        """Least variance of the estimate after each sample (N,) [s^-4]."""
        info = self.prior_info + np.cumsum((self.coefficient * self.envelope()
                                            / self.sigma_e) ** 2)  # fmt: skip
        return 1.0 / info

    @property
    def final(self) -> float:
        """Least root-mean-square error of the final estimate [s^-2]."""
        return float(math.sqrt(self.variance()[-1]))

    @property
    def final_mean(self) -> float:
        """Least mean absolute error of the final estimate [s^-2] (``sqrt(2/pi)`` final)."""
        return _MEAN_OF_ABS * self.final

    def convergence_accuracy(self, t0, statistic: str = "rms",
                             info: np.ndarray | None = None) -> np.ndarray | float:
        """Least Eq. 19 after convergence time(s) ``t0`` [s]: ``"rms"`` (root mean square
        over noise draws) or ``"mean"``; a float for a scalar t0.  ``info`` (N,) [s^4]: the
        same rule on another information trajectory (default: the envelope's, the floor)."""
        if statistic not in ("rms", "mean"):
            raise ValueError(f"statistic must be 'rms' or 'mean'; got {statistic!r}")
        var = self.variance() if info is None else 1.0 / np.asarray(info, float)
        tail = np.cumsum(var[::-1])[::-1] / (self.n_steps - np.arange(self.n_steps))
        n0 = np.clip(np.round(np.asarray(t0, float) * self.sample_rate).astype(int), 0,
                     self.n_steps - 1)  # fmt: skip
        out = np.sqrt(tail[n0]) * (_MEAN_OF_ABS if statistic == "mean" else 1.0)
        return float(out) if np.ndim(out) == 0 else out

    def m_floor(self, weights: tuple[float, float] = M_WEIGHTS,
                info: np.ndarray | None = None) -> tuple[float, float]:
        """``(M, t0)``: the least ``w1 t0 + w2 E[obj2](t0)`` (Eq. 29) and where it is, on
        the envelope's information or on ``info`` (N,) [s^4]."""
        t0 = np.arange(self.n_steps) / self.sample_rate
        m = weights[0] * t0 + weights[1] * self.convergence_accuracy(t0, "mean", info)
        best = int(np.argmin(m))
        return float(m[best]), float(t0[best])

    def motion_information(self, x, intercept: bool = True) -> np.ndarray:
        """Information on ``k_jj`` after each sample [s^4], (B, N), of perfectly tracked
        motions ``x`` (B, N) or (N,) [m]: the prior plus ``sum (K_j x / sigma_e)^2`` or,
        with the intercept R of Eq. 14 fitted (``intercept``, as the RLS does), the Schur
        complement ``A - B^2 / C`` of the (k, R) information matrix (R's regressor is 1,
        its prior the RLS's ``1 / (sigma_e^2 P0)``).  The other identified column (the
        resting test mass's stiffness) is left out: it can only lower the information."""
        x = np.atleast_2d(np.asarray(x, float))
        z = self.coefficient * x / self.sigma_e
        a = self.prior_info + np.cumsum(z**2, axis=1)
        if not intercept:
            return a
        b = np.cumsum(z, axis=1) / self.sigma_e
        c = self.prior_r_info + np.arange(1, x.shape[1] + 1) / self.sigma_e**2
        return a - b**2 / c

    def intercept_bound(self) -> np.ndarray:
        """Most information on ``k_jj`` [s^4] any admissible motion gives after each sample
        with the intercept R fitted (as the RLS does), (N,): a bound tighter than the
        envelope's while the motion is young.

        With R fitted the information is ``K^2 sum_m (x_m - mean x)^2 / sigma_e^2`` (plus
        the priors), and ``sum_{m <= n} (x_m - mean x)^2 = sum_{i, j <= n} (x_i - x_j)^2 /
        (2 n)``.  From rest with ``|x''| <= a``, ``|x'(r)| <= min(a r, v_max)`` (``v_max =
        2 sqrt(a x_max)``: faster, it could not stop within the wall), so ``|x_i - x_j| <=
        min(|P(t_i) - P(t_j)|, 2 x_max)``, ``P(t) = int_0^t min(a r, v_max) dr``.  Never above
        the envelope's (``sum (x - mean)^2 <= sum x^2``).  Until ``x_max`` can be reached the
        constant acceleration ``x = a t^2 / 2`` attains it: 4/9 of the envelope (1/45 against
        1/20 of ``a^2 t^4``).  R's prior adds at most ``1 / (n P0)`` of the envelope's.
        """
        a, fs, n_all = self.accel_max, self.sample_rate, self.n_steps
        t = np.arange(n_all) / fs
        v_max = 2 * math.sqrt(a * self.x_max)
        t_v = v_max / a
        p = np.where(t <= t_v, 0.5 * a * t**2, 0.5 * a * t_v**2 + v_max * (t - t_v))
        # row n of sum_ij D_ij^2 over j < n: p increases, so D = 2 x_max for j < j0(n)
        # and p_n - p_j after: prefix sums of p and p^2 make each row O(1)
        idx = np.arange(n_all)
        j0 = np.minimum(np.searchsorted(p, p - 2 * self.x_max, side="right"), idx)
        c1 = np.concatenate([[0.0], np.cumsum(p)])
        c2 = np.concatenate([[0.0], np.cumsum(p**2)])
        near = idx - j0
        row = (j0 * 4 * self.x_max**2 + near * p**2 - 2 * p * (c1[idx] - c1[j0])
               + (c2[idx] - c2[j0]))  # fmt: skip
        pairs = np.cumsum(2.0 * np.maximum(row, 0.0))
        count = np.arange(1, n_all + 1)
        envelope = self.motion_information(self.envelope(), intercept=False)[0]
        scale = (self.coefficient / self.sigma_e) ** 2
        prior_r = envelope * self.prior_r_info * self.sigma_e**2 / count
        return np.minimum(self.prior_info + scale * pairs / (2 * count) + prior_r, envelope)

    def expected_scores(self, info, eps: float = EPSILON,
                        weights: tuple[float, float] = M_WEIGHTS) -> dict:  # fmt: skip
        """Eqs. 18, 19 and 29 expected for information trajectories ``info`` (B, N) [s^4]
        with no bias: :func:`tmopt.physics.information.predict`'s law (independent
        Gaussian RLS steps of variance ``v_{n-1} - v_n``, ``v = 1 / info``; Eq. 19 by the
        gamma law of its mean square) with zero noise-free error.  Arrays (B,):
        ``convergence_time`` [s], ``convergence_accuracy`` [s^-2], ``M``."""
        var = 1.0 / np.atleast_2d(np.asarray(info, float))
        prev = np.concatenate([np.full((var.shape[0], 1), 1.0 / self.prior_info),
                               var[:, :-1]], axis=1)  # fmt: skip
        sd = np.sqrt(np.maximum(prev - var, 0.0))
        law = convergence_law(np.zeros_like(var), sd, eps)
        t0 = law @ np.arange(var.shape[1] + 1) / self.sample_rate
        rms = expected_rms_after(np.zeros_like(var), var)
        obj2 = np.sum(law * np.concatenate([rms, rms[:, -1:]], axis=1), axis=1)
        return {"convergence_time": t0, "convergence_accuracy": obj2,
                "M": weights[0] * t0 + weights[1] * obj2}  # fmt: skip

    def step_law_m(self, eps: float = EPSILON,
                   weights: tuple[float, float] = M_WEIGHTS) -> dict[str, float]:  # fmt: skip
        """Eq. 18's step law on the envelope's information (:meth:`expected_scores` of
        ``prior + cumsum (K envelope / sigma_e)^2``): the convergence time the floor's
        own information trajectory implies, instead of :meth:`m_floor`'s free choice.
        An *estimate*, not a bound: the step law is not monotone in the information
        (a larger increment makes a larger step), and the envelope is not one motion."""
        info = self.motion_information(self.envelope(), intercept=False)
        return {k: float(v[0]) for k, v in self.expected_scores(info, eps, weights).items()}

    def as_dict(self, t0: float | None = None,
                weights: tuple[float, float] = M_WEIGHTS) -> dict:  # fmt: skip
        """The numbers a run reports (metrics.json ``floor``); ``t0`` adds Eq. 19's floor at
        that convergence time."""
        m, t_m = self.m_floor(weights)
        out = {"parameter": PARAMETERS[self.idx], "sigma_e": self.sigma_e,
               "x_max": self.x_max, "accel_max": self.accel_max,
               "duration": self.n_steps / self.sample_rate, "sample_rate": self.sample_rate,
               "final_accuracy_rms": self.final, "final_accuracy_mean": self.final_mean,
               "M": m, "M_at_convergence_time": t_m}  # fmt: skip
        if t0 is not None:
            out["convergence_time"] = float(t0)
            out["convergence_accuracy_rms"] = self.convergence_accuracy(t0, "rms")
            out["convergence_accuracy_mean"] = self.convergence_accuracy(t0, "mean")
        return out


def stiffness_floor(config, idx: int, constraints: str) -> StiffnessFloor:
    """The floor of ``k_jj`` (``idx`` 0: k1xx, 1: k2xx) for a simulator configuration.

    ``config``: the problem's :class:`~tmopt.physics.simulator.SimulationConfig` (noise,
    duration, rate, limits, truths); ``constraints``: where the problem evaluates Eq. 20
    (its ``constraint_mode``): ``"realised"`` (the commanded force, ``alpha1 F_max``) or
    ``"reference"`` (the actuator's ``F_max``).
    """
    if idx not in (0, 1):
        raise ValueError(f"idx must be 0 (k1xx) or 1 (k2xx); got {idx!r}")
    if constraints not in ("realised", "reference"):
        raise ValueError(f"constraints must be 'realised' or 'reference'; got {constraints!r}")
    x_max = config.alpha2 * config.gap
    force = config.alpha1 * config.f_max if constraints == "realised" else config.f_max
    stiffness = abs(float(config.theta_true[idx]))
    bias = abs((config.bias_1, config.bias_2)[idx][0])
    sigma_e = equation_noise_sigma(config)
    if sigma_e <= 0:
        raise ValueError("the floor needs noise: every noise sigma of the config is 0")
    coefficient = abs(float(config.coefficients[idx]))
    sx = config.rls_scales[0]
    prior_info = sx**2 / (sigma_e**2 * config.rls_p0)  # P0 in the RLS's scaled units
    return StiffnessFloor(idx=idx, sigma_e=sigma_e, coefficient=coefficient, x_max=x_max,
                          accel_max=force + stiffness * x_max + bias,
                          sample_rate=float(config.sample_rate), n_steps=config.n_steps,
                          prior_info=prior_info, force_limit=force,
                          prior_r_info=1.0 / (sigma_e**2 * config.rls_p0))  # fmt: skip


def cycloid_transitions(floor: StiffnessFloor, levels, waits, margin: float = 0.8,
                        shape: str = "cycloid") -> np.ndarray:  # fmt: skip
    """A reference (N,) [m] that moves from rest at 0 through ``levels`` [m], one cycloid
    transition each, holding in between.

    Transition i starts ``waits[i]`` s after the previous one ended (``waits[0]`` after
    t = 0; a negative wait starts it early, overlapping the previous one, whose
    acceleration then adds to its own -- but never before the previous one's start) and
    moves by ``h = levels[i] - levels[i-1]`` as ``h (s - sin(2 pi s) /
    (2 pi))``, ``s = (t - start) / tau``: zero velocity and acceleration at both ends, peak
    acceleration ``2 pi |h| / tau^2 = margin`` times the force limit (the rest is room for
    the controller's tracking). Levels are clipped to ``x_max`` less 1e-4 of it (room for
    the tracking error, ~10 nm); a transition the run ends in is cut there.
    ``shape="bang"``: rest-to-rest at constant ``+-margin`` x the force limit instead
    (``h phi(s)``, ``phi = 2 s^2`` then ``1 - 2 (1 - s)^2``, ``tau = 2 sqrt(|h| / a)``: the
    fastest transition, too abrupt for the controller; for bounds and estimates).
    ``margin`` may reach ``accel_max / force_limit`` (what the stiffness and the bias
    add).  Admissible
    by construction without overlaps, up to the controller's tracking (Eq. 20 on the
    realised run is the caller's check).  ``levels`` and ``waits`` (same length) are 1-D.
    """
    levels, waits = np.atleast_1d(np.asarray(levels, float)), np.atleast_1d(
        np.asarray(waits, float))
    if levels.ndim != 1 or levels.shape != waits.shape:
        raise ValueError(f"levels and waits must be 1-D of one length; got {levels.shape} "
                         f"and {waits.shape}")
    if not 0 < margin <= floor.accel_max / floor.force_limit:
        raise ValueError(f"margin must be in (0, {floor.accel_max / floor.force_limit:.4g}]; "
                         f"got {margin!r}")
    if shape not in ("cycloid", "bang"):
        raise ValueError(f"shape must be 'cycloid' or 'bang'; got {shape!r}")
    if not np.all(np.isfinite(waits)):
        raise ValueError("waits must be finite [s]")
    t = np.arange(floor.n_steps) / floor.sample_rate
    a = margin * floor.force_limit
    room = floor.x_max * (1 - 1e-4)
    x = np.zeros_like(t)
    here, end, start = 0.0, 0.0, 0.0
    for level, wait in zip(np.clip(levels, -room, room), waits):
        h = level - here
        start = max(start, end + wait)
        tau = math.sqrt((2 * math.pi if shape == "cycloid" else 4.0) * abs(h) / a)
        if tau > 0:
            s = np.clip((t - start) / tau, 0.0, 1.0)
            x += h * (s - np.sin(2 * math.pi * s) / (2 * math.pi) if shape == "cycloid" else
                      np.where(s <= 0.5, 2 * s**2, 1 - 2 * (1 - s) ** 2))
        here, end = level, start + tau
    return x


def knot_motion(floor: StiffnessFloor, accel, knots=None) -> np.ndarray:
    """A reference (N,) [m] from rest whose acceleration is piecewise linear through
    ``accel`` (K,) (in units of the force limit) at the times ``knots`` (K,) [s],
    increasing and > 0 (default: K knots spread evenly over the run), zero at t = 0 and
    held at its last value after the last knot, integrated twice (trapezoids).  A
    free-form family: the position limit is not built in (the caller checks ``|x| <=
    x_max``); the acceleration limit is ``max |accel|`` times the force limit."""
    accel = np.asarray(accel, float)
    if accel.ndim != 1 or accel.size < 1:
        raise ValueError(f"accel must be 1-D with >= 1 knot; got shape {accel.shape}")
    dt = 1.0 / floor.sample_rate
    t = np.arange(floor.n_steps) * dt
    knots = np.linspace(0.0, t[-1], accel.size + 1)[1:] if knots is None else \
        np.asarray(knots, float)
    if knots.shape != accel.shape or knots[0] <= 0 or np.any(np.diff(knots) <= 0):
        raise ValueError("knots must be increasing times > 0 s, one per accel value")
    acc = floor.force_limit * np.interp(t, np.concatenate([[0.0], knots]),
                                        np.concatenate([[0.0], accel]))  # fmt: skip
    vel = cumulative_trapezoid(acc, dx=dt, initial=0.0)
    return cumulative_trapezoid(vel, dx=dt, initial=0.0)


def near_optimal_motion(floor: StiffnessFloor, margin: float = 0.8,
                        switch: float | None = None) -> np.ndarray:  # fmt: skip
    """An admissible reference (N,) [m] that comes close to the floor.

    Rise from 0 to ``+x_max``, hold, cross to ``-x_max``, hold
    (:func:`cycloid_transitions`, peak acceleration ``margin`` times the force limit).  It
    starts at rest by itself, so it is meant to be simulated without a ramp-in
    (``ramp_in=0``; a ramp would only add acceleration).  ``switch`` [s] is the start of
    the crossing (before the rise ends, the two overlap); by default the one that
    maximises ``sum (x - mean x)^2`` (the information on k with the intercept R fitted).
    """
    if not 0 < margin <= 1:
        raise ValueError(f"margin must be in (0, 1]; got {margin!r}")
    a = margin * floor.force_limit
    x = floor.x_max * (1 - 1e-4)
    rise = math.sqrt(2 * math.pi * x / a)
    cross = math.sqrt(2 * math.pi * 2 * x / a)
    end = (floor.n_steps - 1) / floor.sample_rate

    def motion(ts: float) -> np.ndarray:
        return cycloid_transitions(floor, [x, -x], [0.0, ts - rise], margin)

    if switch is None:
        grid = np.arange(rise, max(rise, end - cross) + 1.0, 1.0)
        spread = [np.var(motion(ts)) for ts in grid]
        switch = float(grid[int(np.argmax(spread))])
    if not 0 <= switch:
        raise ValueError(f"switch must be >= 0 s; got {switch!r}")
    return motion(switch)
