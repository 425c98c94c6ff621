"""Recordings of an Euler integrator (docs/mismatch.md 9.26).

A hand-written simulator may take one Euler step per sample with the acceleration at the
step's start and record that acceleration: its readout's second difference is exactly
``h^2 a_n`` (``symplectic``: ``v += h a; r += h v``) or ``h^2 a_{n-1}`` (``explicit``),
half a step from every ZOH relation (tests/mismatch/test_realistic.py checks the relations
against the foreign simulator's Euler steps).  Before stop 50 every clean such recording
left unexplained readouts; here the tool reads the convention from the data and stays
silent, never reads a ZOH recording as Euler, and does not take one axis's readout
timing for it.  Development seeds (< 20000), 1200 s at 2 Hz.
"""

from __future__ import annotations

from dataclasses import replace

import pytest

import tmopt.mismatch.fit as fit
from tmopt.mismatch.diagnose import diagnose
from tmopt.mismatch.fit import data_from_recording
from tmopt.mismatch.realistic import draw_scenario, make_ooc, realistic_recording
from tmopt.mismatch.report import build_report

STIFFNESS = (1.8e-6, -1.6e-6, 1.2e-6, -1.5e-6)


def _scenario(seed: int, recorded: str):
    sc = replace(draw_scenario(seed, "foreign"), duration=1200.0, sample_rate=2.0,
                 stiffness=STIFFNESS, gaps=())  # fmt: skip
    if recorded in ("symplectic", "explicit"):
        return replace(sc, acc_convention="held", integrator=recorded)
    return replace(sc, acc_convention=recorded)


def _recording(seed: int, recorded: str, ooc=()):
    sc = _scenario(seed, recorded)
    return realistic_recording(sc, (), ooc, seed=seed, backend="foreign")[0]


def _said(rec) -> tuple[str, list[str], list[str]]:
    rep = build_report(diagnose(data_from_recording(rec)))
    names = [e["name"] for e in rep["effects"] + rep["ambiguous"]]
    unexplained = rep["unexplained_at"].get("channels", []) if rep["unexplained"] else []
    return rep["data_used"]["acc_convention"], names, unexplained


@pytest.mark.parametrize("recorded", ["symplectic", "explicit"])
def test_a_clean_euler_recording_is_read_with_its_convention_and_is_silent(recorded):
    assert _said(_recording(16201, recorded)) == (recorded, [], [])


def test_without_the_euler_conventions_it_raises_readout_mismatches(monkeypatch):
    """The failure this stop fixes (the survey of docs/mismatch.md 9.26 counts it)."""
    monkeypatch.setattr(fit, "EULER_CONVENTIONS", ())
    conv, _, unexplained = _said(_recording(16201, "symplectic"))
    assert conv in fit.ACC_CONVENTIONS and any("readout" in c for c in unexplained)


@pytest.mark.parametrize("recorded", ["held", "mean", "end"])
def test_zoh_recordings_are_not_read_as_euler(recorded):
    """Each axis's half-step coefficient stays near the ZOH relations' 0, Euler's being
    +-1: ``held`` and ``end`` keep their stiffness term, which at a tone looks like
    ``beta = -+k/omega^2`` (-0.0115 on x1 of 16201: k 1.8e-6 s^-2, a 504 s tone)."""
    for seed in (16201, 16213):
        conv, info = fit._euler_convention(data_from_recording(_recording(seed, recorded)))
        assert conv is None, (seed, info)
        assert all(abs(info[a]["beta"]) < 0.05 for a in ("x1", "x2")), (seed, info)


def test_one_axis_stamped_half_a_step_late_is_not_an_euler_recording():
    """A readout timing of h/2 on x1 alone gives beta = -1 there and 0 on x2: no Euler
    convention fits every excited axis.  On both x axes it is the explicit relation
    exactly (physically the same recording, so read as such)."""
    sc = _scenario(16201, "held")
    late = 0.5 / sc.sample_rate
    one = [make_ooc("readout_timing", late, "x1", 16201, sc)]
    conv, info = fit._euler_convention(data_from_recording(_recording(16201, "held", one)))
    assert conv is None and info["x1"]["beta"] < -0.8 and abs(info["x2"]["beta"]) < 0.1, info
    both = one + [make_ooc("readout_timing", late, "x2", 16201, sc)]
    assert fit._euler_convention(data_from_recording(_recording(16201, "held", both)))[0] \
        == "explicit"  # fmt: skip


def test_the_sideband_standard_error_matches_the_spread_over_noise_draws():
    """``sideband_se`` against the scatter of the same projection over noise draws: a
    coloured (blue) residual whose white mean square would overstate it ~30-fold at
    low-frequency tones."""
    import numpy as np

    rng = np.random.default_rng(3)
    t = np.arange(4000) * 0.5
    z = np.sin(2 * np.pi * 0.004 * t) + 0.5 * np.cos(2 * np.pi * 0.011 * t)
    draws, ses = [], []
    for _ in range(300):
        res = np.diff(rng.standard_normal(t.size + 2), 2)  # blue: second difference
        draws.append(float(z @ res))
        ses.append(fit.sideband_se(z, res, t))
    spread, se = float(np.std(draws)), float(np.median(ses))
    assert 0.75 < se / spread < 1.33, (se, spread)
    white = float(np.sqrt(np.mean(res**2) * (z @ z)))
    assert white > 10 * spread


def test_bad_integrator_settings_are_one_clear_line_before_any_work():
    sc = _scenario(16201, "held")
    with pytest.raises(ValueError, match=r"integrator must be one of \('rk4'"):
        realistic_recording(replace(sc, integrator="rk2"), seed=1, backend="foreign")
    with pytest.raises(ValueError, match="needs backend 'foreign'"):
        realistic_recording(replace(sc, integrator="symplectic"), seed=1, backend="kernel")
    with pytest.raises(ValueError, match="acc_convention must be 'held'"):
        realistic_recording(replace(sc, integrator="explicit", acc_convention="mean"), seed=1,
                            backend="foreign")  # fmt: skip
    with pytest.raises(ValueError, match=r"acc_convention must be one of"):
        realistic_recording(replace(sc, acc_convention="symplectic"), seed=1, backend="foreign")


def test_the_read_sets_scenarios_are_written_as_before():
    """``integrator`` is left out of an RK4 scenario's record, so the truths (and the
    recording names made from them) of every set read before stop 50 are unchanged."""
    assert "integrator" not in draw_scenario(16201, "foreign").as_dict()
    assert _scenario(16201, "symplectic").as_dict()["integrator"] == "symplectic"
