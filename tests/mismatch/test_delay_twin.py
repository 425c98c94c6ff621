"""actuation_delay's kinematic twin (issue 26): a delay switches the force inside the step,
which the positions see and the step-mean accelerometer does not."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from tmopt.mismatch.diagnose import diagnose, effect_parameters, prepare
from tmopt.mismatch.effects import Injection
from tmopt.mismatch.fit import data_from_recording, kinematic_target, switch_series
from tmopt.mismatch.realistic import draw_scenario, realistic_recording, scale_to_snr

SEED = 16001  # development seed (the benchmark's are 40000+): x2, 'previous' force stamps


def _short(seed: int):
    sc = draw_scenario(seed, "foreign")
    return replace(sc, duration=1200.0, sample_rate=2.0, gaps=(), glitches=())


def test_the_switch_series_is_the_foreign_simulators_kinematic_change():
    """Same scenario and noise with and without a delay: the change of the exact ZOH
    kinematic residual is ``(tau/h)(1 - tau/h)`` x the switch series, to rounding, and
    nothing on the other axes (an independent RK4 integrator split at the switch)."""
    sc = _short(SEED)
    tau = 0.011
    clean, _ = realistic_recording(sc, (), (), SEED, "foreign", gaps=False)
    late, _ = realistic_recording(sc, [Injection("actuation_delay", tau, "x2")], (), SEED,
                                  "foreign", gaps=False)  # fmt: skip
    d1, _ = prepare(data_from_recording(late))
    d0, _ = prepare(data_from_recording(clean))
    d0.stiffness, d0.acc_convention = d1.stiffness, d1.acc_convention
    change = kinematic_target(d1) - kinematic_target(d0)
    c = tau / d1.dt
    pred = c * (1 - c) * switch_series(d1, 1)
    # row 0 needs the command before the record (the series leaves it 0)
    np.testing.assert_allclose(change[1, 1:], pred[1:], rtol=0,
                               atol=1e-6 * np.abs(pred).max())  # fmt: skip
    assert np.abs(pred).max() > 1e3 * np.abs(change[[0, 2, 3]]).max()


def test_a_foreign_delay_at_snr_40_gets_its_name_and_no_other():
    """Before the twin, the delay's kinematic signature (SNR far above the scaler's) was
    fitted as a displacement readout scale beside it (r6: foreign 40036/40037)."""
    sc = _short(SEED)
    inj, snr = scale_to_snr(sc, Injection("actuation_delay", 3.3e-4, "x2"), 40.0, SEED,
                            "foreign")  # fmt: skip
    assert 35 < snr < 45
    rec, _ = realistic_recording(sc, [inj], (), SEED, "foreign")
    dg = diagnose(data_from_recording(rec))
    assert [ev.candidate.key for ev, _ in dg.selected] == ["actuation_delay[x2]"]
    tau, sigma = effect_parameters(dg.after, dg.selected[0][0].candidate)["tau"]
    assert abs(tau - inj.magnitude) < 5 * sigma


def test_a_clean_foreign_recording_gains_no_delay_name():
    for seed in (SEED, 16009):
        rec, _ = realistic_recording(_short(seed), (), (), seed, "foreign")
        dg = diagnose(data_from_recording(rec))
        assert not [ev for ev, _ in dg.selected if ev.candidate.effect == "actuation_delay"]
        assert not dg.selected
