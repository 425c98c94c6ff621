"""Generator: truth kept apart, every effect changes the recording (and nothing at 0),
settings the tool has not seen, bad input -> errors naming the parameter."""

import hashlib
import json
import math

import numpy as np
import pytest
from scipy.signal import welch

from tmopt.mismatch.effects import EFFECT_NAMES, Injection
from tmopt.mismatch.effects.colored_noise import coloured_noise
from tmopt.mismatch.effects.glitch import glitch_interval_average
from tmopt.mismatch.generate import (
    CALIBRATION_CASES,
    MAGNITUDES,
    GenerationError,
    _clean_reference,
    calibrated_injection,
    calibration_table,
    detectability,
    generate_recording,
    main,
    residual_families,
    write_generated,
)
from tmopt.physics.recording import REQUIRED_CHANNELS, ROTATION_CHANNELS, read_recording
from tmopt.physics.scenario import Settings

SHORT = {"duration": 300.0}


@pytest.fixture(scope="module")
def clean_short():
    return generate_recording((), seed=7, **SHORT)[0]


@pytest.fixture(scope="module")
def clean_reference():
    """Residual families and noise PSDs of the calibration's clean runs (default settings)."""
    return _clean_reference(101, {})


def test_catalogue_is_complete():
    # every registered effect is calibrated (near/large magnitudes) on its calibration case
    assert set(EFFECT_NAMES) == set(MAGNITUDES) == set(CALIBRATION_CASES)
    assert len(EFFECT_NAMES) >= 13  # round one's catalogue


def test_truth_is_written_apart_and_the_recording_reveals_nothing(tmp_path):
    rec, truth = generate_recording([("actuation_gain", 0.01, "x2")], seed=3, **SHORT)
    clean, clean_truth = generate_recording((), seed=3, **SHORT)
    path, tpath = write_generated(rec, truth, tmp_path / "rec", truth_dir=tmp_path / "truth")
    assert path.parent.name == "rec" and tpath.parent.name == "truth"
    assert "actuation" not in path.name and path.name.startswith("rec-")
    back = read_recording(path)
    assert sorted(back.channels) == sorted(clean.channels)  # same channels with or without
    assert back.attrs == clean.attrs
    assert "actuation" not in path.read_bytes().decode("latin-1")
    t = json.loads(tpath.read_text())
    assert t["recording"] == path.name
    assert t["recording_sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    assert t["format"] == "tmopt-truth" and t["seed"] == 3 and not t["clean"]
    (eff,) = t["effects"]
    assert (eff["name"], eff["channel"], eff["parameters"]["g"]) == ("actuation_gain", "x2", 0.01)
    assert t["nominal"]["k1xx"] == 1e-7 and t["nominal"]["alpha"] == pytest.approx(math.pi / 3)
    assert clean_truth["clean"] and clean_truth["effects"] == []


@pytest.mark.parametrize("name", EFFECT_NAMES)
def test_zero_magnitude_changes_no_bit(name, clean_short):
    channel, options = CALIBRATION_CASES[name]
    rec, truth = generate_recording([Injection(name, 0.0, channel, options=options)], seed=7,
                                    **SHORT)  # fmt: skip
    for c in clean_short.channels:
        np.testing.assert_array_equal(rec[c], clean_short[c], err_msg=f"{name}: {c}")
    assert rec.attrs == clean_short.attrs and truth["effects"][0]["magnitude"] == 0.0


@pytest.mark.parametrize("name", EFFECT_NAMES)
def test_every_effect_is_seen_at_its_calibrated_magnitudes(name, clean_reference):
    # same seed as the clean control: the difference is the effect, not the noise
    near = detectability(calibrated_injection(name, "near"), 101, {}, clean_reference)
    large = detectability(calibrated_injection(name, "large"), 101, {}, clean_reference)
    assert near["snr"] == pytest.approx(MAGNITUDES[name]["snr_near"], abs=0.051)
    assert large["snr"] == pytest.approx(MAGNITUDES[name]["snr_large"], abs=0.051)
    assert 4 <= near["snr"] <= 6.5 and 40 <= large["snr"] <= 65


def test_witnesses_zero_without_rotation_and_exact_with_it():
    clean, _ = generate_recording((), seed=1, **SHORT)
    assert all(np.all(clean[c] == 0) for c in ROTATION_CHANNELS)
    bare, _ = generate_recording((), seed=1, witnesses=False, **SHORT)
    assert not bare.has_rotation and set(bare.channels) == set(REQUIRED_CHANNELS) | {
        "ref_x1", "ref_x2"}
    for profile in ("slew", "jitter"):
        rec, truth = generate_recording([Injection("rotation_coupling", 1e-6, "omega_z",
                                                   options={"profile": profile})], seed=1,
                                        **SHORT)  # fmt: skip
        w, wd = rec["sc_omega_z"], rec["sc_omega_dot_z"]
        assert np.abs(w).max() == pytest.approx(1e-6, rel=1e-3)
        assert np.all(rec["sc_omega_x"] == 0) and np.all(rec["sc_omega_dot_y"] == 0)
        # w' is the derivative of w: trapezoid integral of w' reproduces w
        integral = np.concatenate([[0], np.cumsum(0.5 * (wd[1:] + wd[:-1]) / 10.0)])
        np.testing.assert_allclose(integral + w[0], w, atol=2e-4 * np.abs(w).max())
        assert truth["effects"][0]["parameters"]["r12_s"] == [-0.4, 0.0, 0.0]


def test_geometry_error_keeps_nominal_attributes_and_reports_true_angles():
    rec, truth = generate_recording([("geometry_error", 0.01, "phi1")], seed=2, **SHORT)
    assert rec.attrs["phi1"] == pytest.approx(math.pi / 3)
    p = truth["effects"][0]["parameters"]
    assert p["d_phi1"] == 0.01 and p["d_alpha"] == -0.01
    assert truth["true_geometry"]["phi1"] == pytest.approx(math.pi / 3 + 0.01)


@pytest.mark.parametrize("name,param", [("sensing_cross_talk", "c"), ("readout_scale", "e")])
def test_accelerometer_variants_transform_the_recorded_channel_exactly(name, param,
                                                                       clean_short):  # fmt: skip
    opts = {"sensor": "acc"} | ({"source": "x2"} if name == "sensing_cross_talk" else {})
    rec, truth = generate_recording([Injection(name, 0.02, "x1", options=opts)], seed=7,
                                    **SHORT)  # fmt: skip
    acc = clean_short["acc_x1"]
    # the documented formulas: acc_a + c acc_b (cross-talk), (1 + e) acc_a (scale)
    expected = (acc + 0.02 * clean_short["acc_x2"] if name == "sensing_cross_talk"
                else (1 + 0.02) * acc)  # fmt: skip
    np.testing.assert_array_equal(rec["acc_x1"], expected)
    for c in set(rec.channels) - {"acc_x1"}:  # the loop never sees the accelerometer
        np.testing.assert_array_equal(rec[c], clean_short[c])
    assert truth["effects"][0]["parameters"][param] == 0.02


def test_glitch_template_keeps_the_impulse_exact():
    t = np.arange(3000) / 10.0
    for shape in ("shapelet", "exp"):
        avg = glitch_interval_average(t, 0.1, 12.34, 2.0, shape)
        assert avg.sum() * 0.1 == pytest.approx(1.0, rel=1e-9)  # unit area -> dv exactly
        assert np.all(avg[t + 0.1 <= 12.34] == 0) and np.all(avg >= 0)


def test_coloured_noise_has_the_requested_spectrum():
    fs, n = 10.0, 2**17
    x = coloured_noise(n, fs, 1e-12, 1.0, 1e-3, np.random.default_rng(0))
    f, s = welch(x, fs, nperseg=2**14)
    band = (f > 5e-3) & (f < 5e-2)
    # PSD (1e-12)^2 (1e-3 / f): compare the mean of S f over the band (Welch bias < 5 %)
    ratio = np.mean(s[band] * f[band]) / (1e-24 * 1e-3)
    assert 0.85 < ratio < 1.15


def test_bias_drift_force_is_the_exact_interval_average():
    # ramp from t = 20 s to 40 s then held: per-sample force averages (the extra force
    # is seen, noise-free, through the recorded acceleration minus the clean one)
    rec, _ = generate_recording([Injection("bias_drift", 1e-12, "y2", onset=20.0,
                                           duration=20.0)], seed=4, duration=60.0,
                                noise_scale=0.0, excitation="none")  # fmt: skip
    clean, _ = generate_recording((), seed=4, duration=60.0, noise_scale=0.0,
                                  excitation="none")  # fmt: skip
    t = rec.time
    expected = 1e-12 * np.clip(t + 0.05 - 20.0, 0, 20.0)  # midpoint = average of a ramp
    force = rec["acc_y2"] - rec["force_y2"] - (clean["acc_y2"] - clean["force_y2"])
    # acc also contains k y2 and the loop's response: remove k y2 (k = 1e-7) before
    force -= 1e-7 * (rec["y2"] - clean["y2"])
    np.testing.assert_allclose(force[(t < 19.9) | (t > 20.0) & (t < 39.9) | (t > 40)],
                               expected[(t < 19.9) | (t > 20.0) & (t < 39.9) | (t > 40)],
                               rtol=1e-6, atol=1e-22)  # fmt: skip


def test_combinations_carry_both_truths(clean_short):
    pair = [calibrated_injection("glitch", "large"), calibrated_injection("actuation_gain",
                                                                          "large")]  # fmt: skip
    rec, truth = generate_recording(pair, seed=7, **SHORT)
    assert [e["name"] for e in truth["effects"]] == ["glitch", "actuation_gain"]
    assert [e["level"] for e in truth["effects"]] == ["large", "large"]
    single, _ = generate_recording(pair[:1], seed=7, **SHORT)
    assert not np.array_equal(rec["acc_x1"], single["acc_x1"])
    assert not np.array_equal(single["acc_x1"], clean_short["acc_x1"])


@pytest.mark.parametrize("settings", [
    {"sample_rate": 4.0, "duration": 300.0},
    {"sample_rate": 20.0, "duration": 150.0},
    {"duration": 200.0, "noise_scale": 3.0, "controller": "pid"},
    {"duration": 300.0, "excitation": "multisine:4e-5@200@0.3,1e-6@37;2e-5@450"},
    {"duration": 300.0, "excitation": "chirp:1e-5,0.001,0.01;5e-6,0.002,0.015"},
    {"duration": 600.0, "excitation": "steps:3e-5,150;2e-5,200,120"},
    {"duration": 100.0, "excitation": "none"},
])  # fmt: skip
def test_unseen_settings_give_valid_recordings(settings):
    rec, truth = generate_recording([calibrated_injection("glitch", "large")], seed=5,
                                    **settings)  # fmt: skip
    fs = settings.get("sample_rate", 10.0)
    assert rec.sample_rate == fs and rec.n_samples == round(settings["duration"] * fs)
    assert rec.valid.all() and truth["settings"]["sample_rate"] == fs
    assert truth["settings"]["excitation"]["spec"] == settings.get("excitation", "paper")
    ref = rec["ref_x1"]
    if settings.get("excitation") == "none":
        assert not ref.any()
    else:  # the loop tracks the reference once the start-up transient has decayed
        late = rec.time >= rec.duration / 2
        assert np.abs(rec["x1"] - ref)[late].max() < 0.05 * np.abs(ref).max()


def test_noise_scale_scales_the_noise():
    # the f_B-free equation residual is N_acc + N_ele (linear in the noise, whatever the
    # loop does); y saturation at higher noise is reported in the truth
    std = {}
    for scale in (1.0, 2.0):
        rec, truth = generate_recording((), seed=9, duration=300.0, noise_scale=scale)
        std[scale] = np.std(residual_families(rec)["eq"])
        assert set(truth["saturation"]) == {"x1", "x2", "y1", "y2"}
    assert std[2.0] / std[1.0] == pytest.approx(2.0, rel=0.02)


@pytest.mark.parametrize("effects,settings,match", [
    ([("warp_drive", 1.0)], {}, "unknown effect 'warp_drive'"),
    ([("actuation_gain", 0.9)], {}, r"actuation_gain: magnitude \(g\) must be in \[-0.5, 0.5\]"),
    ([("actuation_delay", -0.1)], {}, r"actuation_delay: magnitude \(tau\) must be in \[0, 10\]"),
    ([("actuation_gain", 0.01, "z1")], {}, "actuation_gain: channel must be one of"),
    ([("glitch", float("nan"))], {}, "glitch: magnitude"),
    ([Injection("glitch", 1e-10, options={"width": 3})], {}, "unknown option"),
    ([Injection("glitch", 1e-10, onset=999.0)], SHORT, r"onset must be in \[0, 300\)"),
    ([Injection("cubic_stiffness", 1.0, onset=5.0)], {}, "not meaningful"),
    ([Injection("stiffness_cross_coupling", 1e-8, "x1", options={"source": "x1"})], {},
     "option 'source'"),
    ([Injection("colored_noise", 1e-12, options={"exponent": 7})], {}, "option 'exponent'"),
    ([("glitch", 1e-10), ("glitch", 2e-10, "x1")], {}, "same effect twice"),
    ([], {"sample_rate": 1.0, "duration": 200.0, "excitation": "multisine:1e-9@1.5;1e-9@300"},
     "Nyquist"),
    ([], {"sample_rate": 0.5, "duration": 2000.0}, r"sample_rate must be finite and in \[1, inf\)"),
    ([], {"noise_scale": -1.0}, "noise_scale"),
    ([], {"duration": 2.0}, "64 samples"),
])  # fmt: skip
def test_bad_input_names_the_parameter(effects, settings, match):
    with pytest.raises(ValueError, match=match):
        generate_recording(effects, seed=0, **settings)


def test_divergence_is_a_generation_error():
    with pytest.raises(GenerationError, match="diverged"):
        generate_recording([("cubic_stiffness", 1e8, "x1")], seed=0, duration=300.0)


def test_cli_writes_recording_and_truth(tmp_path, capsys):
    assert main(["--effect", "glitch", "--magnitude", "large", "--effect", "bias_drift",
                 "--magnitude", "2e-15", "--channel", "default", "--channel", "x2",
                 "--option", "glitch.beta=8", "--seed", "4", "--duration", "300",
                 "--out", str(tmp_path), "--name", "combo", "--format", "csv"]) == 0
    truth = json.loads((tmp_path / "combo.truth.json").read_text())
    assert [(e["name"], e["channel"]) for e in truth["effects"]] == [("glitch", "x1"),
                                                                     ("bias_drift", "x2")]
    assert truth["effects"][0]["parameters"]["decay_s"] == 8.0
    assert read_recording(tmp_path / "combo.csv").n_samples == 3000
    assert main(["--effect", "none", "--seed", "4", "--duration", "300", "--out",
                 str(tmp_path)]) == 0
    assert main(["--effect", "glitch", "--magnitude", "1.0", "--out", str(tmp_path)]) == 2
    assert "glitch: magnitude (dv) must be in" in capsys.readouterr().err
    with pytest.raises(SystemExit, match="one --magnitude per --effect"):
        main(["--effect", "glitch", "--effect", "bias_drift", "--magnitude", "1e-10",
              "--out", str(tmp_path)])


def test_settings_reject_bad_values():
    with pytest.raises(ValueError, match="stiffness"):
        Settings(stiffness=(1e-7, 1e-7))
    with pytest.raises(ValueError, match="seed"):
        generate_recording((), seed=-1)


@pytest.mark.slow
def test_calibration_table_is_reproduced():
    # the whole study behind MAGNITUDES (about 2 minutes on 2 cores)
    for row in calibration_table():
        cal = MAGNITUDES[row["effect"]]
        for key in ("channel", "options", "near", "large", "snr_near", "snr_large", "family"):
            assert row[key] == cal[key], (row["effect"], key)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [201, 303, 405])
def test_near_magnitudes_stay_near_the_limit_at_other_seeds(seed):
    clean = _clean_reference(seed, {})
    for name in EFFECT_NAMES:
        got = detectability(calibrated_injection(name, "near"), seed, {}, clean)["snr"]
        assert 3.0 < got < 8.0, (name, got)
