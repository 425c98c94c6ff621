"""Measurement, actuation and spacecraft noise (Table 1 and Sec. 4.1).

All noises are zero-mean white Gaussian sequences, one value per sample (held over the
sampling interval where they act as forces).  One realisation is drawn per ``seed`` and
is *common to every design of a batch* (common random numbers): the objectives become a
deterministic function of the design, comparisons between designs are not blurred by
different noise draws, and design i gives bit-identical results alone or in any batch.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CHANNELS", "noise_sigmas", "standard_normals", "noise_realisation"]

#: Row order of the noise array (m = displacement measurement, acc = acceleration
#: measurement, ele = electrostatic actuation; fb = spacecraft acceleration, frame s).
CHANNELS: tuple[str, ...] = (
    "m_x1", "m_x2", "m_y1", "m_y2",
    "acc_x1", "acc_x2", "acc_y1", "acc_y2",
    "ele_x1", "ele_x2", "ele_y1", "ele_y2",
    "fb_xs", "fb_ys",
)  # fmt: skip


def noise_sigmas(
    sigma_m1: float, sigma_m2: float, sigma_acc: float, sigma_ele: float, sigma_fb: float
) -> np.ndarray:
    """Per-channel standard deviations in :data:`CHANNELS` order.

    Table 1: ``N_m1`` acts on the sensitive (x) displacement readouts, ``N_m2`` on the
    non-sensitive (y) ones, ``N_acc`` on the four acceleration readouts, ``N_ele`` on the
    four applied electrostatic forces; ``sigma_fb`` is our f_B noise (not in Table 1).
    """
    return np.array(
        [sigma_m1] * 2 + [sigma_m2] * 2 + [sigma_acc] * 4 + [sigma_ele] * 4 + [sigma_fb] * 2,
        dtype=np.float64,
    )


def standard_normals(seed: int, n_steps: int) -> np.ndarray:
    """Unit normals of shape ``(len(CHANNELS), n_steps)`` from ``numpy.random.PCG64(seed)``.

    Drawn in one fixed order, so the same seed gives the same numbers whatever the noise
    levels (runs of different length use different draws).
    """
    rng = np.random.Generator(np.random.PCG64(seed))
    return rng.standard_normal((len(CHANNELS), n_steps))


def noise_realisation(seed: int, n_steps: int, sigmas: np.ndarray) -> np.ndarray:
    """Scaled noise ``sigma[:, None] * standard_normals(seed, n_steps)``."""
    sigmas = np.asarray(sigmas, dtype=np.float64)
    if sigmas.shape != (len(CHANNELS),):
        raise ValueError(f"sigmas must have shape ({len(CHANNELS)},); got {sigmas.shape}")
    return np.ascontiguousarray(sigmas[:, None] * standard_normals(seed, n_steps))
