"""Measurement, actuation and spacecraft noise (Table 1 and Sec. 4.1).

All noises are zero-mean white Gaussian sequences, one value per sample (held over the
sampling interval where they act as forces).  One realisation is drawn per ``seed`` and
is *common to every design of a batch* (common random numbers): the objectives become a
deterministic function of the design, comparisons between designs are not blurred by
different noise draws, and design i gives bit-identical results alone or in any batch.
A batch may also give each design its own seed (designs x seeds in one simulator call).

**Seed spaces.**  Which seeds a search may use and which are kept for held-out scoring is
decided here, by integer ranges, so the two are disjoint by construction:

* ``[0, 2^50)`` -- seeds chosen by the user: the ``fixed`` noise seed and the K seeds
  ``noise_seed .. noise_seed + K - 1`` of ``average`` (:data:`USER_SEEDS`);
* ``[2^50, 2^52)`` -- ``fresh`` seeds, one per evaluation, hashed from (noise seed, run
  seed, archive row) by :func:`fresh_seeds` (:data:`FRESH_SEEDS`);
* ``[2^52, 2^52 + 2^32)`` -- held-out seeds, never drawn by a search
  (:func:`heldout_seeds`, :func:`check_heldout`).

Every seed stays below 2^53, so it survives a round trip through float64 (pymoo's outputs,
JSON) exactly.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CHANNELS", "noise_sigmas", "standard_normals", "noise_realisation", "USER_SEEDS",
           "FRESH_SEEDS", "HELDOUT_SEEDS", "fresh_seeds", "heldout_seeds", "check_heldout"]

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


#: Half-open integer ranges of the seed spaces (see the module docstring).
USER_SEEDS: tuple[int, int] = (0, 2**50)
FRESH_SEEDS: tuple[int, int] = (2**50, 2**52)
HELDOUT_SEEDS: tuple[int, int] = (2**52, 2**52 + 2**32)
_FRESH_TAG = 0x5EED_F8E5  # separates this hash from any other use of SeedSequence


def fresh_seeds(noise_seed: int, run_seed: int, rows: np.ndarray) -> np.ndarray:
    """The ``fresh`` noise seed of each archive row (int64, in :data:`FRESH_SEEDS`).

    A hash of (noise seed, run seed, row) by ``numpy.random.SeedSequence``: a new
    realisation for every evaluation, yet the same one whenever the same row of the same
    run is evaluated again (a resumed run's replay, or a re-evaluation after a failure).
    """
    lo, hi = FRESH_SEEDS
    out = np.empty(len(rows), dtype=np.int64)
    for j, row in enumerate(np.asarray(rows, dtype=np.int64).tolist()):
        state = np.random.SeedSequence([int(noise_seed), int(run_seed), row, _FRESH_TAG])
        word = int(state.generate_state(1, np.uint64)[0])
        out[j] = lo + word % (hi - lo)
    return out


def heldout_seeds(n: int) -> np.ndarray:
    """The first ``n`` held-out seeds, ``2^52 + 0 .. n-1`` (int64): common to every run, so
    held-out scores of different runs and algorithms are paired by seed."""
    lo, hi = HELDOUT_SEEDS
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 0 <= n <= hi - lo:
        raise ValueError(f"the number of held-out seeds must be an integer in [0, {hi - lo}]; "
                         f"got {n!r}")
    return lo + np.arange(int(n), dtype=np.int64)


def check_heldout(heldout: np.ndarray, used: np.ndarray) -> None:
    """Raise unless every held-out seed lies in :data:`HELDOUT_SEEDS` and none was ``used``
    (the seeds that scored a search's evaluations; -1 entries mean "none")."""
    heldout = np.asarray(heldout, dtype=np.int64)
    lo, hi = HELDOUT_SEEDS
    if heldout.size and (heldout.min() < lo or heldout.max() >= hi):
        raise ValueError(f"held-out seeds must lie in [{lo}, {hi}); got "
                         f"[{heldout.min()}, {heldout.max()}]")
    clash = np.intersect1d(heldout, np.asarray(used, dtype=np.int64).ravel())
    if clash.size:
        raise ValueError(f"held-out seed {int(clash[0])} also scored the search: held-out "
                         "scores would not be independent of the selection")
