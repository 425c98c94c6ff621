"""Reference motion: the multi-frequency sinusoid of Eq. 17, batched over designs."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["PERIOD_BOUNDS", "MultiSine", "sample_times", "ramp_window"]

#: (shortest, longest) period [s] of a design's sinusoids (Eq. 17; the paper gives no
#: bounds, docs/decisions.md "The stiffness problem"): the longest is the run length of
#: Sec. 4.1, the shortest keeps >= 600 samples per period at 10 Hz.
PERIOD_BOUNDS: tuple[float, float] = (60.0, 1200.0)


def sample_times(duration: float, sample_rate: float) -> np.ndarray:
    """Sampling instants ``t_n = n / f_s``, ``n = 0 .. N-1`` with ``N = round(duration f_s)``."""
    n = int(round(duration * sample_rate))
    return np.arange(n, dtype=np.float64) / sample_rate


def ramp_window(t: np.ndarray, ramp: float) -> np.ndarray:
    """Raised-cosine start ``w(t) = (1 - cos(pi t / ramp)) / 2`` for ``t < ramp``, then 1.

    Multiplying a reference by it makes the reference start with zero displacement,
    velocity and acceleration (``w(0) = w'(0) = 0``) and adds at most ``pi / (2 ramp)``
    times the reference's velocity and ``pi^2 / (2 ramp^2)`` times its displacement to the
    acceleration it demands.  ``ramp = 0`` gives ones.
    """
    t = np.asarray(t, dtype=np.float64)
    if ramp <= 0:
        return np.ones_like(t)
    s = np.clip(t / ramp, 0.0, 1.0)
    return 0.5 * (1.0 - np.cos(np.pi * s))


def _as_2d(name: str, value: object) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        arr = arr.reshape(1, 1)
    elif arr.ndim == 1:
        arr = arr.reshape(1, -1)
    elif arr.ndim != 2:
        raise ValueError(f"{name} must have shape (B, k), (k,) or be a scalar; got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN/inf); got {value!r}")
    return arr


class MultiSine:
    """Eq. 17: ``x(t) = sum_i A_i sin(w_i t + theta_i) + B_i`` with ``B_i = -A_i sin(theta_i)``.

    The bias makes every design start at the nominal position, ``x(0) = 0`` (Sec. 3.2.1).
    ``amplitude`` [m], ``omega`` [rad/s] and ``phase`` [rad] broadcast to shape ``(B, k)``:
    B designs with k sub-signals each.  A component with zero amplitude contributes nothing,
    so designs with fewer frequencies can share one batch.

    ``sample_rate`` (Hz), when given, checks ``omega < pi * sample_rate`` (Nyquist); the
    simulator checks it again against its own sampling rate.
    """

    def __init__(
        self,
        amplitude: object,
        omega: object,
        phase: object = 0.0,
        sample_rate: float | None = None,
    ) -> None:
        a, w, p = _as_2d("amplitude", amplitude), _as_2d("omega", omega), _as_2d("phase", phase)
        try:
            a, w, p = np.broadcast_arrays(a, w, p)
        except ValueError as exc:
            raise ValueError(
                f"amplitude, omega and phase must broadcast to (B, k); got shapes "
                f"{np.shape(amplitude)}, {np.shape(omega)}, {np.shape(phase)}"
            ) from exc
        if np.any(a < 0):
            raise ValueError(f"amplitude must be >= 0 m (in [0, inf)); got min {a.min()!r}")
        if np.any(w < 0):
            raise ValueError(f"omega must be in [0, pi*sample_rate) rad/s; got min {w.min()!r}")
        self.amplitude = np.ascontiguousarray(a)
        self.omega = np.ascontiguousarray(w)
        self.phase = np.ascontiguousarray(p)
        if sample_rate is not None:
            self.check_nyquist(sample_rate)

    @property
    def batch_size(self) -> int:
        return self.amplitude.shape[0]

    @property
    def n_components(self) -> int:
        return self.amplitude.shape[1]

    def check_nyquist(self, sample_rate: float) -> None:
        """Raise unless every ``omega < pi * sample_rate`` (the Nyquist angular frequency)."""
        nyq = math.pi * sample_rate
        if np.any(self.omega >= nyq):
            raise ValueError(
                f"omega must be in [0, {nyq:.6g}) rad/s (below Nyquist pi*sample_rate for "
                f"sample_rate={sample_rate} Hz); got max {self.omega.max()!r}"
            )

    def take(self, index: object) -> MultiSine:
        """Sub-batch of designs (keeps the 2-D shape)."""
        idx = np.atleast_1d(np.asarray(index))
        return MultiSine(self.amplitude[idx], self.omega[idx], self.phase[idx])

    def evaluate(self, t: np.ndarray) -> np.ndarray:
        """Eq. 17 at times ``t`` (shape (N,)) -> shape (B, N), exactly 0 at ``t = 0``."""
        t = np.asarray(t, dtype=np.float64)
        out = np.zeros((self.batch_size, t.size))
        for i in range(self.n_components):  # k is small; loop keeps memory at (B, N)
            a = self.amplitude[:, i : i + 1]
            arg = self.omega[:, i : i + 1] * t[None, :] + self.phase[:, i : i + 1]
            out += a * (np.sin(arg) - np.sin(self.phase[:, i : i + 1]))
        return out

    def max_abs(self, duration: float, sample_rate: float) -> np.ndarray:
        """``max_t |x(t)|`` over the sampling grid of the run (B,): the ``x_max`` of Eq. 20."""
        return np.abs(self.evaluate(sample_times(duration, sample_rate))).max(axis=1)

    def max_accel(self) -> np.ndarray:
        """``sum_i A_i w_i^2`` (B,): the acceleration bound used by Eq. 20."""
        return np.sum(self.amplitude * self.omega**2, axis=1)

    def __repr__(self) -> str:
        return f"MultiSine(B={self.batch_size}, k={self.n_components})"
