"""Geometry of the non-coaxial (V-shaped) test-mass layout (Sec. 2.1, Eqs. 5-7, 11).

Frames (all right-handed, z along the solar-panel normal, so every frame change is a
rotation about z):

* ``s``: spacecraft body, origin at the centre of mass, ``y_s`` along the symmetry axis
  between the two interferometer arms;
* ``a``: TM1, ``x_a`` along arm 1 at the angle ``phi1 = angle(x_s, x_a)``;
* ``b``: TM2, ``x_b`` along arm 2 at the angle ``phi2 = angle(x_s, x_b)``.

The breathing angle is ``alpha = phi2 - phi1`` (angle between the two MOSAs).  ``W_ij``
maps components in frame ``i`` to components in frame ``j`` (``v^j = W_ij v^i``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Geometry", "rotation_z", "null_vector_coefficients"]


def rotation_z(angle: float) -> np.ndarray:
    """Frame change for a frame rotated by ``angle`` about z (Eqs. 5-7).

    ``[[cos, sin, 0], [-sin, cos, 0], [0, 0, 1]]``: the minus signs were lost in the
    paper's text extraction; this is the only sign choice that makes ``W`` map components
    of a fixed vector into the rotated frame.
    """
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class Geometry:
    """Nominal layout of Sec. 4.1: TM1, TM2 and the arms' meeting point form an
    equilateral triangle of side ``separation`` (0.4 m); arms at +-30 deg about ``y_s``.

    With ``phi1 = 60 deg``, ``phi2 = 120 deg`` the arm lines through the TM centres meet
    0.4 m from both, and the TM centres lie on ``x_s`` symmetric about the centre of mass.
    """

    phi1: float = math.radians(60.0)
    phi2: float = math.radians(120.0)
    separation: float = 0.4

    def __post_init__(self) -> None:
        for name in ("phi1", "phi2", "separation"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)!r}")
        if self.separation <= 0:
            raise ValueError(f"separation must be > 0 m, got {self.separation!r}")
        if abs(math.sin(self.alpha)) < 1e-6:
            raise ValueError(
                "phi2 - phi1 (breathing angle alpha) must not be a multiple of pi: the "
                f"coaxial layout has no f_B-cancelling combination; got alpha={self.alpha!r}"
            )

    @property
    def alpha(self) -> float:
        """Breathing angle, the angle between the two arms (Fig. 1)."""
        return self.phi2 - self.phi1

    @property
    def w_sa(self) -> np.ndarray:
        """Eq. 6: frame s -> frame a."""
        return rotation_z(self.phi1)

    @property
    def w_sb(self) -> np.ndarray:
        """Eq. 7: frame s -> frame b."""
        return rotation_z(self.phi2)

    @property
    def w_ab(self) -> np.ndarray:
        """Eq. 5: frame a -> frame b (rotation by alpha); ``W_ba`` is its transpose."""
        return rotation_z(self.alpha)

    @property
    def r01_s(self) -> np.ndarray:
        """Spacecraft CoM -> TM1 centre, frame s (TM1 on +x_s, its arm leaning outward)."""
        return np.array([0.5 * self.separation, 0.0, 0.0])

    @property
    def r02_s(self) -> np.ndarray:
        """Spacecraft CoM -> TM2 centre, frame s."""
        return np.array([-0.5 * self.separation, 0.0, 0.0])

    @property
    def r12_s(self) -> np.ndarray:
        """TM1 -> TM2 centre vector, frame s (along x_s, as Sec. 2.2 assumes)."""
        return self.r02_s - self.r01_s

    def coefficients(self) -> np.ndarray:
        """Eq. 11: ``K`` acting on ``[x1'', x2'', y1'', y2'']``.

        ``K = [sin(phi1)cos(alpha) - sin(phi2), sin(phi2)cos(alpha) - sin(phi1),
        sin(phi1)sin(alpha), -sin(phi2)sin(alpha)]`` -- the signs, lost in extraction,
        are those that cancel f_B (checked against :func:`null_vector_coefficients`).
        """
        s1, s2 = math.sin(self.phi1), math.sin(self.phi2)
        ca, sa = math.cos(self.alpha), math.sin(self.alpha)
        return np.array([s1 * ca - s2, s2 * ca - s1, s1 * sa, -s2 * sa])


def null_vector_coefficients(geometry: Geometry) -> np.ndarray:
    """Derive K of Eq. 11 from the frames alone, as the null vector of three conditions.

    A combination ``K . [x1'', x2'', y1'', y2'']`` must be blind to (i) both in-plane
    components of any spacecraft acceleration ``f_B^s`` (it enters TM1 through ``W_sa``
    and TM2 through ``W_sb``) and (ii) the rigid-body rotation term of ``r12`` that is
    perpendicular to ``r12`` in the plane (the angular-acceleration term
    ``r12 x omega_dot`` of Eqs. 3-4, the "major" one since ``|r12| >> |r|``).  Three
    linear conditions on four unknowns leave one direction; it is scaled to match the
    closed form's sign and norm so the two can be compared element-wise.
    """
    w_sa, w_sb = geometry.w_sa[:2, :2], geometry.w_sb[:2, :2]
    # Rows act on [x1'', x2'', y1'', y2''] = [(W_sa v)_x, (W_sb v)_x, (W_sa v)_y, (W_sb v)_y].
    rows = []
    for v in np.eye(2):  # f_B along x_s and along y_s: the same vector for both TMs
        a, b = w_sa @ v, w_sb @ v
        rows.append([a[0], b[0], a[1], b[1]])
    r12 = geometry.r12_s[:2]
    perp = np.array([-r12[1], r12[0]]) / np.linalg.norm(r12)  # z x r12: omega_dot term
    b = w_sb @ perp  # the r12 term acts on TM2 only (TM1's common part is like f_B)
    rows.append([0.0, b[0], 0.0, b[1]])
    _, _, vt = np.linalg.svd(np.asarray(rows))
    k = vt[-1]
    closed = geometry.coefficients()
    return k * (np.linalg.norm(closed) / np.linalg.norm(k)) * np.sign(k @ closed)
