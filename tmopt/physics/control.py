"""Controllers of Sec. 3.3: incremental PID and the FRBF-PID (Eqs. 22-28).

The step functions (``pid_increment``, ``frbf_forward``, ``frbf_learn``) live in
:mod:`tmopt.physics._closed_loop`, where numba compiles them into the batched simulator;
called from Python they run as plain Python.  This module holds their settings and the
documented choices the paper leaves open (see docs/decisions.md, "Physics and control").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tmopt.physics._closed_loop import (
    filtered_pid_increment,
    frbf_forward,
    frbf_learn,
    pid_increment,
)

__all__ = [
    "ControllerSettings",
    "CONTROLLERS",
    "JACOBIANS",
    "pid_increment",
    "filtered_pid_increment",
    "frbf_forward",
    "frbf_learn",
    "closed_loop_poles",
    "derivative_filter_pole",
    "rate_scaled_gains",
    "PAPER_RATE",
]

#: Sampling rate of the paper's simulation (Sec. 4.1) [Hz]: per-sample gains are given at it.
PAPER_RATE = 10.0

#: Controllers of the sensitive axes; the non-sensitive axes always use a fixed-gain PID.
CONTROLLERS: tuple[str, ...] = ("frbf_pid", "pid")
#: Plant-Jacobian sign in the FRBF-PID's learning law: constant +1, or the classic online
#: estimate ``sign((y_n - y_{n-1}) (u_n - u_{n-1}))`` (docs/decisions.md, "Control").
JACOBIANS: tuple[str, ...] = ("plus", "online")


def _check_finite(name: str, values: tuple[float, ...]) -> None:
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"{name} must be finite; got {values!r}")


@dataclass(frozen=True)
class ControllerSettings:
    """Settings of both controllers (Sec. 4.2 values as defaults).

    * ``base_gains`` -- ``[Kp, Ki, Kd]`` of the incremental PID, SI with the increments of
      Eq. 28 taken per sample (e in m, u in m s^-2): equivalent continuous gains are
      ``P = Kp``, ``I = Ki/dt``, ``D = Kd dt`` (0.5 s^-2, 0.1 s^-3, 1 s^-1 at 10 Hz).
    * FRBF-PID: gains ``= base_gains * clip(1 + f4, *gain_bounds)``; network weights start
      at 0, so the FRBF-PID starts as the PID and learns a correction.
    * ``error_scale`` [m] and ``error_rate_scale`` [m/s] map ``e`` and ``de/dt`` onto the
      centres' range [-1, 1] (inputs are clipped there); the learning law works on
      ``e / error_scale`` and ``u / F_max``.
    * ``centres`` ``c_ij(0)``, ``width`` ``b_ij(0)``, ``learning_rate`` ``eta_net``,
      ``momentum`` ``alpha_net`` (Eqs. 26-27); ``width_min`` keeps ``b > 0``;
      ``jacobian`` one of :data:`JACOBIANS`.
    * ``y_gains`` -- gains of the PID holding the non-sensitive axes at nominal, and
      ``y_derivative_filter`` -- the time constant [s] of its derivative filter (0: none,
      Eq. 28's plain difference).  Defaults: the fastest well-damped loop whose readout
      noise force stays below F_max / 6 (docs/decisions.md, "Non-sensitive axes").
    """

    base_gains: tuple[float, float, float] = (0.5, 0.01, 10.0)
    y_gains: tuple[float, float, float] = (0.245, 0.00343, 7.0)
    y_derivative_filter: float = 0.5
    centres: tuple[float, ...] = (-1.0, -0.5, -0.2, 0.0, 0.2, 0.5, 1.0)
    width: float = 0.2
    learning_rate: float = 0.1
    momentum: float = 0.01
    error_scale: float = 1e-5
    error_rate_scale: float = 1e-6
    gain_bounds: tuple[float, float] = (0.0, 10.0)
    width_min: float = 1e-2
    jacobian: str = "plus"

    def __post_init__(self) -> None:
        for name in ("base_gains", "y_gains"):
            gains = tuple(getattr(self, name))
            _check_finite(name, gains)
            if len(gains) != 3 or min(gains) < 0:
                raise ValueError(f"{name} must be 3 gains [Kp, Ki, Kd] >= 0; got {gains!r}")
        if len(self.centres) != 7:
            raise ValueError(f"centres must hold 7 values (7 memberships); got {self.centres!r}")
        _check_finite("centres", tuple(self.centres))
        scalars = ("width", "learning_rate", "momentum", "error_scale", "error_rate_scale",
                   "width_min")  # fmt: skip
        for name in scalars:
            v = getattr(self, name)
            if not math.isfinite(v) or v < 0 or (v == 0 and name not in ("learning_rate",
                                                                          "momentum")):
                raise ValueError(f"{name} must be finite and > 0 (>= 0 for rates); got {v!r}")
        v = self.y_derivative_filter
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
            raise ValueError(f"y_derivative_filter must be finite and in [0, inf) s; got {v!r}")
        if self.jacobian not in JACOBIANS:
            raise ValueError(f"jacobian must be one of {JACOBIANS}; got {self.jacobian!r}")
        if self.momentum >= 1:
            raise ValueError(f"momentum must be in [0, 1); got {self.momentum!r}")
        lo, hi = self.gain_bounds
        _check_finite("gain_bounds", (lo, hi))
        if not 0 <= lo < 1 < hi:
            raise ValueError(f"gain_bounds must satisfy 0 <= lo < 1 < hi; got {self.gain_bounds}")


def rate_scaled_gains(
    gains: tuple[float, float, float], sample_rate: float
) -> tuple[float, float, float]:
    """Per-sample ``[Kp, Ki, Kd]`` given at :data:`PAPER_RATE` -> the same continuous gains
    ``P = Kp``, ``I = Ki / dt``, ``D = Kd dt`` at ``sample_rate`` (identity at 10 Hz)."""
    r = PAPER_RATE / sample_rate  # dt / dt_paper
    return (gains[0], gains[1] * r, gains[2] / r)


def derivative_filter_pole(tau: float, dt: float) -> float:
    """``a = exp(-dt / tau)`` of the first-order derivative filter (0 for ``tau = 0``)."""
    return math.exp(-dt / tau) if tau > 0 else 0.0


def closed_loop_poles(
    gains: tuple[float, float, float], dt: float, filter_tau: float = 0.0
) -> np.ndarray:
    """Poles (z-plane) of the incremental PID on a pure double integrator with ZOH.

    Plant ``x_{n+1} - 2x_n + x_{n-1} = dt^2/2 (u_n + u_{n-1})``; controller
    ``(1 - z^-1)(1 - a z^-1) u = [(Kp (1 - z^-1) + Ki)(1 - a z^-1) + (1 - a) Kd
    (1 - z^-1)^2] e`` with the derivative-filter pole ``a`` (:func:`filtered_pid_increment`;
    ``a = 0``: Eq. 28).  All ``|z| < 1`` means the loop is stable (u_n is computed from
    x_n and held over [t_n, t_{n+1})).
    """
    kp, ki, kd = gains
    a = derivative_filter_pole(filter_tau, dt)
    h2 = 0.5 * dt * dt
    # polynomials in z^-1, coefficients of z^0, z^-1, ...
    plant_den = np.array([1.0, -2.0, 1.0])
    plant_num = h2 * np.array([0.0, 1.0, 1.0])
    ctrl_num = np.polyadd(np.convolve([kp + ki, -kp], [1.0, -a]),
                          (1.0 - a) * kd * np.array([1.0, -2.0, 1.0]))  # fmt: skip
    ctrl_den = np.convolve([1.0, -1.0], [1.0, -a])
    char = np.polyadd(np.convolve(plant_den, ctrl_den), np.convolve(plant_num, ctrl_num))
    return np.roots(np.trim_zeros(char, "b"))
