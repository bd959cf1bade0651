"""Noise model value: TOML text, term checks, theoretical Allan variance, preset files."""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.allan.curves import deterministic_avar, gauss_markov_avar, sinusoid_avar
from analysis.allan.estimators import overlapping_allan_variance
from analysis.errors import InvalidTauError, ModelError
from analysis.models.terms import (
    TERM_NAMES,
    AngleRandomWalk,
    Bias,
    BiasInstability,
    BiasSteps,
    GaussMarkov,
    NoiseModel,
    Quantization,
    RateRamp,
    RateRandomWalk,
    Sinusoid,
    TemperatureBias,
)
from devices.model_files import load_noise_model, preset_names, save_noise_model

ALL_TERMS = (
    Quantization(Q_urad=0.5),
    AngleRandomWalk(N_deg_rt_h=0.01),
    BiasInstability(B_deg_h=0.1),
    RateRandomWalk(K_deg_h_1_5=0.2),
    RateRamp(R_deg_h2=-0.3),
    GaussMarkov(sigma_deg_h=0.4, tau_s=50.0),
    Sinusoid(amplitude_deg_h=0.5, period_s=300.0, phase_deg=30.0),
    Bias(value_deg_h=-3.0),
    TemperatureBias(
        coefficient_deg_s_per_c=1e-4,
        start_c=20.0,
        final_c=30.0,
        warmup_s=500.0,
        cycle_amplitude_c=2.0,
        cycle_period_s=3600.0,
    ),
    BiasSteps(rate_per_h=2.0, size_deg_h=0.7),
)
FULL = NoiseModel(terms=ALL_TERMS, name="full \"test\" model", source="tests, unicode: µrad")


# ------------------------------------------------------------------------------- TOML


def test_toml_round_trip_keeps_every_term_and_value():
    text = FULL.to_toml()
    assert NoiseModel.from_toml(text) == FULL
    for name in TERM_NAMES:
        assert f"[{name}]" in text


def test_interface_keys_of_the_issue_are_the_toml_keys():
    text = """
    [quantization]
    Q_urad = 1
    [arw]
    N_deg_rt_h = 2
    [bias_instability]
    B_deg_h = 3
    [rate_random_walk]
    K_deg_h_1_5 = 4
    [rate_ramp]
    R_deg_h2 = 5
    [gauss_markov]
    sigma_deg_h = 6
    tau_s = 7
    [sinusoid]
    amplitude_deg_h = 8
    period_s = 9
    [bias]
    value_deg_h = 10
    """
    model = NoiseModel.from_toml(text)
    assert model.term_names == ("quantization", "arw", "bias_instability", "rate_random_walk",
                                "rate_ramp", "gauss_markov", "sinusoid", "bias")
    assert model.get("gauss_markov") == GaussMarkov(sigma_deg_h=6.0, tau_s=7.0)
    assert model.get("sinusoid").phase_deg == 0.0


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("[arww]\nN_deg_rt_h = 1", "unknown noise term [arww]"),
        ("[arw]\nN_deg_rt_h = 1\nQ_urad = 2", "unknown key(s) Q_urad"),
        ("[gauss_markov]\nsigma_deg_h = 1", "needs key(s) sigma_deg_h, tau_s"),
        ("[arw]\nN_deg_rt_h = -1", "must be >= 0"),
        ("[gauss_markov]\nsigma_deg_h = 1\ntau_s = 0", "must be > 0"),
        ("[arw]\nN_deg_rt_h = true", "must be a number"),
        ("[arw]\nN_deg_rt_h = \"1\"", "must be a number"),
        ("[arw]\nN_deg_rt_h = nan", "must be finite"),
        ("arw = 1", "must be a table"),
        ("name = 3", "must be strings"),
        ("[arw\nN = 1", "not valid TOML"),
    ],
)
def test_bad_toml_is_refused_with_a_message_that_names_the_problem(text, fragment):
    with pytest.raises(ModelError) as info:
        NoiseModel.from_toml(text)
    assert fragment in str(info.value)


def test_model_keeps_one_term_per_kind_in_canonical_order():
    model = NoiseModel(terms=(Bias(value_deg_h=1.0), AngleRandomWalk(N_deg_rt_h=1.0)))
    assert model.term_names == ("arw", "bias")
    with pytest.raises(ModelError, match="repeated: arw"):
        NoiseModel(terms=(AngleRandomWalk(N_deg_rt_h=1.0), AngleRandomWalk(N_deg_rt_h=2.0)))
    bigger = model.with_term(AngleRandomWalk(N_deg_rt_h=3.0)).with_term(Quantization(Q_urad=1.0))
    assert bigger.term_names == ("quantization", "arw", "bias")
    assert bigger.get("arw").N_deg_rt_h == 3.0
    assert "bias" not in bigger.without_term("bias")
    assert bigger.get("sinusoid") is None


# ------------------------------------------------------------------ theoretical curves


def test_five_term_sum_is_lv2015_eq3_in_data_sheet_units():
    q, n, b, k, r = 0.0712, 0.00104, 0.0028, 0.0162, 0.0080  # urad, deg/sqrt(h), deg/h, ...
    model = NoiseModel(terms=(Quantization(Q_urad=q), AngleRandomWalk(N_deg_rt_h=n),
                              BiasInstability(B_deg_h=b), RateRandomWalk(K_deg_h_1_5=k),
                              RateRamp(R_deg_h2=r)))
    tau_h = np.array([1e-4, 1e-2, 1.0, 10.0])
    q_deg = q * 1e-6 * 180 / math.pi
    eq3_deg_h = (3 * (q_deg / tau_h) ** 2 + n**2 / tau_h + (0.664 * b) ** 2
                 + k**2 * tau_h / 3 + r**2 * tau_h**2 / 2)
    got_deg_h = model.avar(tau_h * 3600.0) * 3600.0**2
    # 0.664 is sqrt(2 ln2 / pi) = 0.66428 rounded, hence rtol 1e-3 where B dominates
    np.testing.assert_allclose(got_deg_h, eq3_deg_h, rtol=1e-3)
    assert math.isclose(BiasInstability(B_deg_h=1.0).adev(1.0)[()] * 3600, 0.6643, rel_tol=1e-4)


def test_gauss_markov_closed_form_has_its_limits_and_no_seam_at_the_series_switch():
    sigma, t = 2.0, 10.0
    small = np.array([1e-6, 1e-4]) * t
    np.testing.assert_allclose(
        gauss_markov_avar(small, sigma, t), 2 * sigma**2 * small / (3 * t), rtol=1e-3
    )
    large = np.array([1e4, 1e6]) * t
    np.testing.assert_allclose(
        gauss_markov_avar(large, sigma, t), 2 * sigma**2 * t / large, rtol=1e-3
    )
    around = np.array([0.01 * (1 - 1e-9), 0.01 * (1 + 1e-9)]) * t
    a, b = gauss_markov_avar(around, sigma, t)
    assert abs(a / b - 1) < 1e-8


def _numeric_avar(signal_fn, tau_s, duration_s, dt=0.02):
    """Overlapping Allan variance of a finely sampled deterministic signal (independent check)."""
    t = np.arange(int(round(duration_s / dt))) * dt + dt / 2
    res = overlapping_allan_variance(signal_fn(t), 1 / dt, taus=tau_s)
    return res.avar


def test_deterministic_avar_matches_a_brute_force_estimate_of_the_signal():
    a, w, c, p, phi = 0.3, 40.0, 0.2, 25.0, 70.0
    tau = np.array([0.5, 3.0, 12.5, 40.0, 90.0])
    duration = 200.0

    def fn(t):
        return a * np.exp(-t / w) + c * np.sin(2 * np.pi * t / p + np.radians(phi))

    want = _numeric_avar(fn, tau, duration)
    got = deterministic_avar(tau, duration_s=duration, warmup_amplitude=a, warmup_s=w,
                             cycle_amplitude=c, period_s=p, phase_deg=phi)
    np.testing.assert_allclose(got, want, rtol=5e-3)


def test_sinusoid_and_temperature_curves():
    s = Sinusoid(amplitude_deg_h=3600.0, period_s=10.0)
    assert s.avar([10.0, 20.0]) == pytest.approx([0.0, 0.0], abs=1e-25)
    assert s.avar(5.0)[()] == pytest.approx(1.0 / (np.pi / 2) ** 2)
    temp = TemperatureBias(coefficient_deg_s_per_c=0.01, cycle_amplitude_c=3.0, cycle_period_s=60.0,
                           start_c=10.0, final_c=30.0)
    np.testing.assert_allclose(temp.avar([1.0, 7.0]), sinusoid_avar([1.0, 7.0], 0.03, 60.0))
    assert np.all(temp.avar([1.0, 7.0], duration_s=3600.0) > 0)
    assert temp.avar(2000.0, duration_s=3600.0)[()] == 0.0  # no two clusters fit


def test_bias_steps_have_the_second_moments_of_a_rate_random_walk():
    steps = BiasSteps(rate_per_h=4.0, size_deg_h=0.5)
    rrw = RateRandomWalk(K_deg_h_1_5=math.sqrt(4.0) * 0.5)
    np.testing.assert_allclose(steps.avar([1.0, 100.0]), rrw.avar([1.0, 100.0]))
    assert np.all(Bias(value_deg_h=5.0).avar([1.0, 2.0]) == 0)


def test_model_curve_is_the_sum_of_its_terms_and_taus_are_checked():
    tau = np.logspace(-1, 4, 30)
    parts = FULL.term_avars(tau, duration_s=1e5)
    np.testing.assert_allclose(FULL.avar(tau, duration_s=1e5), sum(parts.values()))
    assert set(parts) == set(FULL.term_names)
    for bad in ([0.0], [-1.0], [np.nan]):
        with pytest.raises(InvalidTauError):
            FULL.avar(bad)


# -------------------------------------------------------------------------- presets


def test_presets_hold_the_papers_tables():
    assert {"SRS2000", "VG951", "CRG20", "zhang2015-fog", "mems-typical"} <= set(preset_names())
    table = {
        "SRS2000": (6.870e-03, 8.587e-05, 6.773e-03),
        "VG951": (7.555e-02, 7.636e-03, 1.246e-01),
        "CRG20": (1.868e01, 1.492, 2.079e01),
    }
    for name, (q, n, b) in table.items():
        model = load_noise_model(name.lower())
        assert model.term_names == ("quantization", "arw", "bias_instability")
        assert (model.get("quantization").Q_urad, model.get("arw").N_deg_rt_h,
                model.get("bias_instability").B_deg_h) == (q, n, b)
        assert "table" in model.source
    zhang = load_noise_model("zhang2015-fog")
    assert zhang.term_names[:5] == (
        "quantization",
        "arw",
        "bias_instability",
        "rate_random_walk",
        "rate_ramp",
    )
    assert zhang.get("quantization").q_deg == pytest.approx(4.0794263e-6, rel=1e-8)
    assert zhang.get("rate_ramp").R_deg_h2 == 0.0080067654


def test_model_files_load_paths_and_save(tmp_path):
    path = save_noise_model(FULL, tmp_path / "m.toml", comment="written by a test\nsecond line")
    assert path.read_text(encoding="utf-8").startswith("# written by a test\n# second line\n")
    assert load_noise_model(path) == FULL
    assert load_noise_model(str(path)) == FULL
    with pytest.raises(ModelError, match="presets: .*VG951"):
        load_noise_model("no-such-gyro")
    with pytest.raises(ModelError, match="no model file"):
        load_noise_model(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[arw]\nN = 1\n", encoding="utf-8")
    with pytest.raises(ModelError, match=r"bad\.toml: \[arw\] unknown key"):
        load_noise_model(bad)
