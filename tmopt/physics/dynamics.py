"""Per-axis test-mass dynamics (Eqs. 1-2) and their exact zero-order-hold discretisation.

Along one axis of a TM frame (rotation terms neglected, Sec. 2.2, as no spacecraft
attitude excitation is applied) Eqs. 1-2 read

    r'' = k r + f_e + f_D - f_B            (per unit mass)

with ``k`` the diagonal stiffness (k > 0 pushes the TM away from its nominal position),
``f_e`` the applied electrostatic acceleration, ``f_D`` the bias disturbance and ``f_B``
the spacecraft acceleration projected on that axis.  Between two samples every input is
held constant (zero-order hold), so one sampling step is exactly

    [r, v]_{n+1} = Phi [r, v]_n + Gamma a_n,   Phi = expm([[0, 1], [k, 0]] h).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

__all__ = ["zoh_coefficients", "zoh_step", "free_motion"]

# |k h^2| below this uses the power series, which avoids the catastrophic cancellation
# of cosh(w h) - 1 for the tiny stiffnesses of interest (k h^2 ~ 1e-9).
_SERIES_LIMIT = 0.1
_SERIES_TERMS = 12  # |z|^n / (2n)! < 1e-30 at n = 12 for |z| < 0.1


@nb.njit(cache=True)
def zoh_coefficients(k: float, h: float) -> tuple[float, float, float]:
    """Exact ZOH coefficients ``(C, S, G)`` of ``r'' = k r + a`` over a step ``h``.

    ``Phi = [[C, S], [k S, C]]`` and ``Gamma = [G, S]`` with, for ``w = sqrt|k|``,
    ``C = cosh(w h)``, ``S = sinh(w h)/w``, ``G = (cosh(w h) - 1)/k`` for k > 0, the
    cos/sin forms for k < 0 and ``C = 1, S = h, G = h^2/2`` at k = 0.  All three are the
    even power series ``sum z^n/(2n)!`` etc. in ``z = k h^2``, used for small ``|z|``.
    """
    z = k * h * h
    if abs(z) < _SERIES_LIMIT:
        c, s, g = 0.0, 0.0, 0.0
        term = 1.0  # z^n / (2n)!
        for n in range(_SERIES_TERMS):
            c += term
            term_s = term / (2 * n + 1)  # z^n / (2n+1)!
            s += term_s
            g += term_s / (2 * n + 2)  # z^n / (2n+2)!
            term = term * z / ((2 * n + 1) * (2 * n + 2))
        return c, s * h, g * h * h
    w = math.sqrt(abs(k))
    if k > 0:
        c = math.cosh(w * h)
        s = math.sinh(w * h) / w
    else:
        c = math.cos(w * h)
        s = math.sin(w * h) / w
    return c, s, (c - 1.0) / k


@nb.njit(cache=True)
def zoh_step(
    r: float, v: float, a: float, k: float, c: float, s: float, g: float
) -> tuple[float, float]:
    """One exact ZOH step given the coefficients of :func:`zoh_coefficients`."""
    return c * r + s * v + g * a, k * s * r + c * v + s * a


def free_motion(
    k: float, r0: float, v0: float, a: float, t: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form solution of ``r'' = k r + a`` (constant ``a``) at times ``t``.

    Written with cosh/sinh (k > 0), cos/sin (k < 0) or the polynomial (k = 0) directly,
    as an independent check of the discretisation.
    """
    t = np.asarray(t, dtype=np.float64)
    if k == 0:
        return r0 + v0 * t + 0.5 * a * t**2, v0 + a * t
    w = math.sqrt(abs(k))
    if k > 0:
        ch, sh = np.cosh(w * t), np.sinh(w * t)
        r = (r0 + a / k) * ch + v0 / w * sh - a / k
        v = (r0 + a / k) * w * sh + v0 * ch
    else:
        co, si = np.cos(w * t), np.sin(w * t)
        r = (r0 + a / k) * co + v0 / w * si - a / k
        v = -(r0 + a / k) * w * si + v0 * co
    return r, v
