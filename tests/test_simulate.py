"""Streaming simulation: seams, seeds, shapes, memory, and each term's Allan variance by Monte
Carlo."""

from __future__ import annotations

import math
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from analysis.allan.curves import FLICKER_AVAR_FACTOR
from analysis.allan.estimators import overlapping_allan_variance
from analysis.errors import InvalidSampleRateError
from analysis.models.noise import flicker_bank, flicker_rate_noise
from analysis.models.simulation import GyroSimulator, SimulatedChunk, simulate
from analysis.models.terms import (
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
from devices.model_files import load_noise_model
from devices.sim.signal import SignalSource

FS = 10.0
EVERYTHING = NoiseModel(
    terms=(
        Quantization(Q_urad=50.0),
        AngleRandomWalk(N_deg_rt_h=0.5),
        BiasInstability(B_deg_h=20.0),
        RateRandomWalk(K_deg_h_1_5=30.0),
        RateRamp(R_deg_h2=100.0),
        GaussMarkov(sigma_deg_h=10.0, tau_s=5.0),
        Sinusoid(amplitude_deg_h=10.0, period_s=13.0, phase_deg=10.0),
        Bias(value_deg_h=36.0),
        TemperatureBias(
            coefficient_deg_s_per_c=1e-3,
            start_c=15.0,
            final_c=30.0,
            warmup_s=60.0,
            cycle_amplitude_c=1.0,
            cycle_period_s=100.0,
        ),
        BiasSteps(rate_per_h=360.0, size_deg_h=20.0),
    )
)

ROOT = Path(__file__).resolve().parents[1]


def _read_in_pieces(sim: GyroSimulator, sizes: list[int]) -> SimulatedChunk:
    chunks = [sim.read(n) for n in sizes]
    return SimulatedChunk(
        t_s=np.concatenate([c.t_s for c in chunks]),
        rate_deg_s=np.vstack([c.rate_deg_s for c in chunks]),
        temperature_c=np.concatenate([c.temperature_c for c in chunks]),
    )


# ----------------------------------------------------------------- seams, seeds, shapes


def test_chunks_join_without_seams_whatever_the_cut():
    one_shot = GyroSimulator(EVERYTHING, FS, n_axes=3, seed=11).read(3000)
    pieces = _read_in_pieces(GyroSimulator(EVERYTHING, FS, n_axes=3, seed=11), [1, 0, 999, 7, 1993])
    np.testing.assert_allclose(pieces.rate_deg_s, one_shot.rate_deg_s, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(pieces.t_s, one_shot.t_s)
    np.testing.assert_allclose(pieces.temperature_c, one_shot.temperature_c, rtol=1e-12)
    assert np.allclose(
        simulate(EVERYTHING, 300.0, FS, n_axes=3, seed=11).rate_deg_s,
        one_shot.rate_deg_s,
        rtol=1e-12,
        atol=1e-15,
    )


def test_a_devices_short_reads_give_the_samples_of_scipys_filter_bit_for_bit():
    """A simulated device's simulator (``short_reads``: the Gauss-Markov recursions stepped
    in numpy, 4096 samples a block) gives the samples of the offline one (scipy's lfilter
    pole by pole) exactly, over reads of every size, a block and one past it, and two
    blocks and more (a starved simulator booking its late samples lost) included."""
    cuts = [1, 0, 57, 4096, 4097, 3, 1200, 9000]
    offline = _read_in_pieces(GyroSimulator(EVERYTHING, FS, n_axes=3, seed=4), cuts)
    device = _read_in_pieces(GyroSimulator(EVERYTHING, FS, n_axes=3, seed=4, short_reads=True),
                             cuts)
    np.testing.assert_array_equal(device.rate_deg_s, offline.rate_deg_s)
    np.testing.assert_array_equal(device.temperature_c, offline.temperature_c)


def test_a_devices_long_read_imports_no_scipy() -> None:
    """A simulated device's read of 9000 samples at once (a simulator two seconds behind at
    4 kHz) steps its recursions in numpy: importing scipy.signal in a device's process is
    over a second of CPU that starves the other units on the host."""
    code = ("import sys\nfrom devices.sim.signal import SignalSource\n"
            "SignalSource('DSP-1750', 4000.0, seed=1).read(9000)\n"
            "print(sorted(m for m in sys.modules if m.startswith('scipy')))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT).stdout
    assert out.strip() == "[]"


def test_a_devices_signal_is_the_same_however_it_is_read() -> None:
    """The device signal (drawn 256 samples ahead at least, and handed out as asked) gives
    the numbers of one read of the whole run, rates, temperatures and an IMU's
    accelerations, over reads of 0, 1, 3, 255, 256, 257 and 5000 samples."""
    whole = SignalSource("DSP-1750", 2000.0, seed=2, n_accel_axes=3).read(12_000)
    source = SignalSource("DSP-1750", 2000.0, seed=2, n_accel_axes=3)
    parts, got = [], 0
    for k in [0, 1, 3, 255, 256, 257, 5000] * 3:
        k = min(k, 12_000 - got)
        chunk = source.read(k)
        assert chunk.rate_deg_s.shape == (k, 3) and chunk.temperature_c.shape == (k,)
        parts.append(chunk)
        got += k
    rest = source.read(12_000 - got)
    parts.append(rest)
    for name in ("rate_deg_s", "temperature_c", "accel_m_s2"):
        np.testing.assert_array_equal(np.concatenate([getattr(p, name) for p in parts]),
                                      getattr(whole, name))


def test_a_seed_reproduces_a_run_and_terms_keep_their_draws_when_others_are_added():
    base = NoiseModel(
        terms=(AngleRandomWalk(N_deg_rt_h=1.0), GaussMarkov(sigma_deg_h=5.0, tau_s=3.0))
    )
    a = simulate(base, 100.0, FS, n_axes=2, seed=5).rate_deg_s
    assert np.array_equal(a, simulate(base, 100.0, FS, n_axes=2, seed=5).rate_deg_s)
    assert not np.allclose(a, simulate(base, 100.0, FS, n_axes=2, seed=6).rate_deg_s)
    assert not np.allclose(a[:, 0], a[:, 1])
    sine = Sinusoid(amplitude_deg_h=7.0, period_s=9.0)
    with_sine = simulate(base.with_term(sine), 100.0, FS, n_axes=2, seed=5).rate_deg_s
    sine_only = simulate(NoiseModel(terms=(sine,)), 100.0, FS, n_axes=2, seed=99).rate_deg_s
    np.testing.assert_allclose(with_sine, a + sine_only, rtol=1e-12, atol=1e-15)


def test_chunk_fields_and_argument_checks():
    sim = GyroSimulator(
        NoiseModel(terms=(AngleRandomWalk(N_deg_rt_h=1.0),)), 50.0, n_axes=2, seed=1
    )
    assert not sim.has_temperature
    first = sim.read(5)
    assert first.rate_deg_s.shape == (5, 2) and first.temperature_c is None
    empty = sim.read(0)
    assert empty.rate_deg_s.shape == (0, 2) and empty.start_index == 5
    nxt = sim.read(3)
    np.testing.assert_allclose(nxt.t_s, np.arange(5, 8) / 50.0)
    assert nxt.start_index == 5 and sim.samples_read == 8
    assert [c.n_samples for c in sim.chunks(10, chunk_samples=4)] == [4, 4, 2]
    with pytest.raises(ValueError):
        sim.read(-1)
    with pytest.raises(ValueError):
        GyroSimulator(EVERYTHING, FS, n_axes=0)
    with pytest.raises(InvalidSampleRateError):
        GyroSimulator(EVERYTHING, 0.0)
    with pytest.raises(TypeError):
        GyroSimulator("VG951", FS)  # a model value, not a name: files are read in devices/


def test_temperature_channel_drives_the_bias_linearly():
    term = TemperatureBias(
        coefficient_deg_s_per_c=2e-3,
        reference_c=20.0,
        start_c=10.0,
        final_c=30.0,
        warmup_s=30.0,
        cycle_amplitude_c=0.5,
        cycle_period_s=50.0,
    )
    run = simulate(NoiseModel(terms=(term,)), 300.0, FS, n_axes=2)
    assert run.temperature_c[0] == pytest.approx(10.0, abs=0.5)
    assert run.temperature_c[-1] == pytest.approx(30.0, abs=0.6)
    np.testing.assert_allclose(run.rate_deg_s[:, 1], 2e-3 * (run.temperature_c - 20.0))


def test_bias_steps_rate_and_size_follow_the_poisson_model():
    term = BiasSteps(rate_per_h=3600.0, size_deg_h=3600.0)  # one step per s of 1 deg/s
    duration = 2000.0
    rate = simulate(NoiseModel(terms=(term,)), duration, FS, n_axes=8, seed=3).rate_deg_s
    # a step of size s at a uniform place inside sample k shows as the differences s f and
    # s (1 - f) around k: E sum(diff^2) = (2/3) lambda L s^2, whether steps share samples or not
    energy = np.sum(np.diff(rate, axis=0) ** 2, axis=0)
    assert energy.mean() == pytest.approx(2.0 / 3.0 * duration, rel=0.06)
    level_changes = rate[-1] - rate[0]
    assert np.var(level_changes) == pytest.approx(duration, rel=0.9)


def test_streaming_memory_is_bounded_by_the_chunk():
    model = NoiseModel(terms=(AngleRandomWalk(N_deg_rt_h=1.0), BiasInstability(B_deg_h=1.0)))
    sim = GyroSimulator(model, 1000.0, seed=2)
    n_total, chunk = 300_000, 8192  # the run would be 2.4 MB of float64, a chunk is 66 kB
    tracemalloc.start()
    total = 0.0
    for part in sim.chunks(n_total, chunk_samples=chunk):
        total += float(part.rate_deg_s.sum())
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert math.isfinite(total) and sim.samples_read == n_total
    assert peak < 1_000_000  # about 0.55 MB: a few chunk-sized temporaries


# -------------------------------------------------------------- Monte Carlo vs theory

N_SAMPLES = 4096
SEEDS = (1, 2, 3, 4)
AXES = 16


def _monte_carlo(model: NoiseModel, fs: float = FS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean overlapping Allan variance over SEEDS x AXES runs, its standard error, and tau."""
    curves = []
    for seed in SEEDS:
        run = GyroSimulator(model, fs, n_axes=AXES, seed=seed).read(N_SAMPLES)
        res = overlapping_allan_variance(run.rate_deg_s, fs, taus="octave")
        curves.append(res.avar.T)
    curves = np.vstack(curves)
    n = curves.shape[0]
    return curves.mean(axis=0), curves.std(axis=0, ddof=1) / math.sqrt(n), res.tau_s


STOCHASTIC = [
    Quantization(Q_urad=100.0),
    AngleRandomWalk(N_deg_rt_h=1.0),
    BiasInstability(B_deg_h=10.0),
    RateRandomWalk(K_deg_h_1_5=100.0),
    GaussMarkov(sigma_deg_h=10.0, tau_s=2.0),
    GaussMarkov(sigma_deg_h=10.0, tau_s=0.03),  # shorter than a sample: exact discretization
    BiasSteps(rate_per_h=3600.0, size_deg_h=10.0),
]


@pytest.mark.parametrize("term", STOCHASTIC, ids=lambda t: f"{t.name}")
def test_each_stochastic_term_matches_its_theoretical_allan_variance(term):
    model = NoiseModel(terms=(term,))
    mean, se, tau = _monte_carlo(model)
    theory = model.avar(tau)
    z = (mean - theory) / se  # every tau of the octave grid, up to half the record
    assert np.all(np.abs(z) < 4.0), dict(zip(tau, np.round(z, 2), strict=True))
    keep = tau <= N_SAMPLES / FS / 8  # at least 8 clusters: a usable standard error
    # and the band is tight enough to mean something: 4 SE is under 12 % of the curve at
    # the shortest tau and under 40 % at the longest kept one
    rel = se[keep] / theory[keep]
    assert rel[0] < 0.03 and np.all(rel < 0.1), rel


@pytest.mark.parametrize(
    "term",
    [RateRamp(R_deg_h2=1000.0), Sinusoid(amplitude_deg_h=10.0, period_s=7.0, phase_deg=40.0),
     TemperatureBias(coefficient_deg_s_per_c=1e-3, start_c=10.0, final_c=30.0, warmup_s=100.0,
                     cycle_amplitude_c=2.0, cycle_period_s=60.0)],
    ids=lambda t: t.name,
)
def test_each_deterministic_term_matches_its_exact_allan_variance(term):
    model = NoiseModel(terms=(term,))
    run = simulate(model, N_SAMPLES / FS, FS)
    res = overlapping_allan_variance(run.rate_deg_s[:, 0], FS, taus="octave")
    # the estimator sums over sample starts, the closed form integrates: 0.1 % apart
    np.testing.assert_allclose(
        res.avar, model.avar(res.tau_s, duration_s=N_SAMPLES / FS), rtol=2e-3
    )


def test_constant_bias_has_no_allan_variance():
    run = simulate(NoiseModel(terms=(Bias(value_deg_h=3600.0),)), 100.0, FS)
    assert np.all(run.rate_deg_s == 1.0)


def test_flicker_bank_plateau_is_flat_over_the_whole_band():
    for fs in (1.0, 100.0, 1000.0):
        bank = flicker_bank(1.0, fs)
        tau = np.logspace(math.log10(1 / fs), 6, 400)
        ratio = bank.avar(tau) / FLICKER_AVAR_FACTOR
        assert np.all(np.abs(ratio - 1) < 1e-3), (fs, ratio.min(), ratio.max())
    coarse = flicker_bank(1.0, 10.0, poles_per_decade=0.5).avar(np.logspace(-1, 5, 200))
    assert np.ptp(coarse / FLICKER_AVAR_FACTOR) > 0.05  # a sparse bank ripples: the check can fail


def test_streamed_flicker_has_the_plateau_and_the_curve_of_the_one_shot_kasdin_generator():
    b_deg_s = 10.0 / 3600.0
    model = NoiseModel(terms=(BiasInstability(B_deg_h=10.0),))
    mean, se, tau = _monte_carlo(model)
    plateau = mean / (FLICKER_AVAR_FACTOR * b_deg_s**2)
    keep = tau <= N_SAMPLES / FS / 8
    assert np.all(np.abs(plateau[keep] - 1) < 4 * se[keep] / mean[keep])
    rng = np.random.default_rng(7)
    kasdin = []
    for _ in SEEDS:
        one_shot = flicker_rate_noise(b_deg_s, N_SAMPLES, FS, rng, n_axes=AXES)
        kasdin.append(overlapping_allan_variance(one_shot, FS, taus="octave").avar.T)
    kasdin = np.vstack(kasdin)
    k_mean, k_se = kasdin.mean(axis=0), kasdin.std(axis=0, ddof=1) / math.sqrt(len(kasdin))
    mid = keep & (tau >= 16 / FS)  # Kasdin's discrete filter is above 1/f near Nyquist
    z = (mean[mid] - k_mean[mid]) / np.hypot(se[mid], k_se[mid])
    assert np.all(np.abs(z) < 4.0), z


def test_a_stream_joined_from_chunks_stays_in_the_confidence_band_of_the_preset_curves():
    """0.1 s sampling as in Lv 2015 (1 h here), streamed in 100 s chunks, per preset."""
    for name in ("zhang2015-fog", "CRG20", "mems-typical"):
        model = load_noise_model(name)
        sim = GyroSimulator(model, FS, seed=12)
        rate = np.vstack([c.rate_deg_s for c in sim.chunks(36000, chunk_samples=1000)])
        res = overlapping_allan_variance(rate[:, 0], FS, taus="log", confidence=0.95)
        theory = model.avar(res.tau_s, duration_s=3600.0)
        inside = (res.ci_low <= theory) & (theory <= res.ci_high)
        assert inside.mean() >= 0.85, (name, inside.mean())
        # the band discriminates: an ARW 30 % off leaves it at the short taus
        wrong = model.with_term(AngleRandomWalk(N_deg_rt_h=1.3 * model.get("arw").N_deg_rt_h))
        wrong_theory = wrong.avar(res.tau_s, duration_s=3600.0)
        short = res.tau_s < 1.0
        assert not np.any(
            (res.ci_low[short] <= wrong_theory[short]) & (wrong_theory[short] <= res.ci_high[short])
        )
