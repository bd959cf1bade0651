"""DAVAR (Zhang 2015, eq. 6): three implementations, the precision trap, results, streaming."""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from analysis.allan import kernels
from analysis.allan.estimators import chi2_interval, overlapping_allan_variance
from analysis.davar.estimators import (
    DavarResult,
    davar_plain,
    davar_recursive,
    dynamic_allan_variance,
    dynamic_allan_variance_slices,
    dynamic_allan_variance_stream,
)
from analysis.errors import InvalidWindowError, NonFiniteSamplesError, TooFewSamplesError

BACKENDS = ["numpy", "numba"]  # the numpy fallback and the compiled kernels, each forced


def max_rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a / b - 1.0)))


@pytest.fixture(scope="module")
def random_record() -> np.ndarray:
    rng = np.random.default_rng(20)
    white = rng.standard_normal((4000, 2))
    walk = 0.02 * np.cumsum(rng.standard_normal((4000, 2)), axis=0)
    return 3.0 + white + walk


STEP_ONE = dict(window_s=40.0, step_s=0.1)  # fs 10 Hz: Nw = 400 samples, step 1 sample


@pytest.fixture(scope="module")
def references(random_record: np.ndarray) -> tuple[DavarResult, DavarResult]:
    part = random_record[:1500]
    return davar_plain(part, 10.0, **STEP_ONE), davar_recursive(part, 10.0, **STEP_ONE)


def test_recursive_agrees_with_plain_at_every_step(
    references: tuple[DavarResult, DavarResult],
) -> None:
    plain, recursive = references
    assert plain.avar.shape == (1101, len(plain.tau_s), 2)
    assert max_rel(recursive.avar, plain.avar) < 1e-9
    np.testing.assert_array_equal(recursive.t_s, plain.t_s)


@pytest.mark.parametrize("backend", BACKENDS)
def test_fast_agrees_with_plain_at_every_step(
    random_record: np.ndarray, references: tuple[DavarResult, DavarResult], backend: str
) -> None:
    plain, _ = references
    fast = dynamic_allan_variance(random_record[:1500], 10.0, backend=backend, **STEP_ONE)
    assert max_rel(fast.avar, plain.avar) < 1e-9
    np.testing.assert_array_equal(fast.t_s, plain.t_s)
    np.testing.assert_array_equal(fast.edf, plain.edf)


def loud_start_record(n: int, rng: np.random.Generator) -> np.ndarray:
    """White noise whose first fifth is 1000 times louder: a warm-up taken to extremes."""
    rate = rng.standard_normal(n)
    rate[: n // 5] *= 1e3
    return rate


def test_precision_trap_at_short_windows_of_a_long_record() -> None:
    """m near Nw/2 leaves L = Nw + 1 - 2m = 1..3 terms: one running sum would lose it."""
    n, window = 24_000, 2_000
    rate = loud_start_record(n, np.random.default_rng(4))
    taus = np.array([1.0, 10.0, 999.0, 1000.0])  # fs 1 Hz; m = 1000 = Nw/2 gives L = 1
    kw = dict(window_s=window, step_s=997, taus=taus)
    plain = davar_plain(rate, 1.0, **kw)
    recursive = davar_recursive(rate, 1.0, **kw)
    fast = [dynamic_allan_variance(rate, 1.0, backend=b, **kw) for b in BACKENDS]
    assert max_rel(recursive.avar, plain.avar) < 1e-9
    for result in fast:
        assert max_rel(result.avar, plain.avar) < 1e-9
    # The trap itself: window sums as differences of one float64 cumulative sum.
    theta = np.r_[0.0, np.cumsum(rate - rate.mean())]
    starts = np.arange(0, n - window + 1, 997)
    m = 1000
    running = np.r_[0.0, np.cumsum(kernels.second_difference_squares(theta, m))]
    naive = running[starts + 1] - running[starts]
    exact = plain.avar[:, -1] * 2.0 * m**2 * 1
    assert max_rel(np.abs(naive) + 1e-300, exact) > 1e-9


def test_window_equals_the_overlapping_allan_variance_of_its_samples(
    random_record: np.ndarray,
) -> None:
    fs = 10.0
    result = dynamic_allan_variance(random_record, fs, window_s=100.0, step_s=25.0)
    assert isinstance(result, DavarResult)
    assert result.window_samples == 1000 and result.step_samples == 250
    np.testing.assert_allclose(result.t_s, (np.arange(13) * 250 + 500) / fs)
    j = 5
    alone = overlapping_allan_variance(
        random_record[j * 250 : j * 250 + 1000], fs, taus=result.tau_s
    )
    np.testing.assert_allclose(result.avar[j], alone.avar, rtol=1e-11)
    np.testing.assert_array_equal(result.n_terms, alone.n_terms)
    # default grid: Zhang 2015 eq. 20 over one window, at least 9 clusters
    assert result.m[0] == 1 and result.m[-1] <= 1000 // 9
    assert np.all(np.diff(result.m) > 0)


def test_confidence_intervals_per_cell(random_record: np.ndarray) -> None:
    result = dynamic_allan_variance(random_record, 10.0, window_s=100.0, confidence=0.9)
    assert result.edf.shape == result.avar.shape
    assert np.all(result.ci_low < result.avar) and np.all(result.avar < result.ci_high)
    low, high = chi2_interval(result.avar, result.edf, 0.9)
    np.testing.assert_allclose(result.ci_low, low, rtol=1e-12)
    np.testing.assert_allclose(result.ci_high, high, rtol=1e-12)
    # longer tau, fewer degrees of freedom, wider interval
    width = np.log(result.ci_high / result.ci_low)[0, :, 0]
    assert width[-1] > 3 * width[0]
    np.testing.assert_allclose(result.adev_ci_low ** 2, result.ci_low)


def test_axes_and_single_axis_shapes(random_record: np.ndarray) -> None:
    both = dynamic_allan_variance(random_record, 10.0, window_s=100.0)
    y = dynamic_allan_variance(random_record[:, 1], 10.0, window_s=100.0)
    assert both.n_axes == 2 and y.n_axes == 1 and y.avar.ndim == 2
    np.testing.assert_allclose(both.axis(1).avar, y.avar, rtol=1e-12)
    np.testing.assert_array_equal(both.axis(1).noise_alpha, y.noise_alpha)
    with pytest.raises(IndexError):
        y.axis(1)


def test_white_noise_level_and_a_noise_step_show_up() -> None:
    rng = np.random.default_rng(9)
    fs = 100.0
    rate = rng.standard_normal(200_000)
    rate[100_000:] *= 2.0  # noise doubles halfway
    result = dynamic_allan_variance(rate, fs, window_s=100.0)
    tau0 = result.tau_s[0]
    first = result.avar[result.t_s < 900, 0]
    last = result.avar[result.t_s > 1100, 0]
    # white rate noise of std s at fs: AVAR(tau = 1/fs) = s^2 (Zhang 2015 eq. 8 with C^2 = s^2/fs)
    assert tau0 == pytest.approx(0.01)
    assert np.median(first) == pytest.approx(1.0, rel=0.03)
    assert np.median(last) == pytest.approx(4.0, rel=0.03)


def test_stream_of_irregular_chunks_matches_in_memory(random_record: np.ndarray) -> None:
    whole = dynamic_allan_variance(random_record, 10.0, window_s=50.0, step_s=3.0)
    rng = np.random.default_rng(1)
    cuts = np.unique(np.r_[0, rng.integers(1, 4000, 40), 4000])
    chunks = (random_record[a:b] for a, b in zip(cuts[:-1], cuts[1:], strict=True))
    streamed = dynamic_allan_variance_stream(chunks, 10.0, window_s=50.0, step_s=3.0,
                                             block_samples=600)
    np.testing.assert_array_equal(streamed.t_s, whole.t_s)
    assert max_rel(streamed.avar, whole.avar) < 1e-10


def test_step_longer_than_window_skips_samples(random_record: np.ndarray) -> None:
    result = dynamic_allan_variance_stream(
        (random_record[a : a + 128] for a in range(0, 4000, 128)),
        10.0,
        window_s=20.0,
        step_s=70.0,
        block_samples=300,
    )
    np.testing.assert_allclose(result.window_start_s, [0.0, 70.0, 140.0, 210.0, 280.0, 350.0])
    alone = overlapping_allan_variance(random_record[2100:2300], 10.0, taus=result.tau_s)
    np.testing.assert_allclose(result.avar[3], alone.avar, rtol=1e-11)


def test_slices_of_a_memmap_in_bounded_memory(tmp_path: Path) -> None:
    n, fs = 1_500_000, 1000.0
    path = tmp_path / "rate.npy"
    rng = np.random.default_rng(2)
    mm = np.lib.format.open_memmap(path, mode="w+", dtype=np.float64, shape=(n, 1))
    for a in range(0, n, 500_000):
        mm[a : a + 500_000, 0] = rng.standard_normal(500_000)
    mm.flush()
    del mm
    record = np.load(path, mmap_mode="r")
    block = 1 << 15
    kw = dict(window_s=5.0, step_s=1.0, block_samples=block)
    tracemalloc.start()
    try:
        result = dynamic_allan_variance_slices(lambda a, b: record[a:b], n, fs,
                                               chunk_samples=1 << 13, **kw)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert result.avar.shape == (1496, len(result.tau_s), 1)
    output = sum(a.nbytes for a in (result.avar, result.edf, result.ci_low, result.ci_high))
    assert peak < 0.5 * n * 8, f"peak {peak / 1e6:.1f} MB for a {n * 8 / 1e6:.0f} MB record"
    # besides the output (held twice while it is scaled), the work space is a few blocks
    work = peak - 2 * output
    assert work < 16 * block * 8, f"work space {work / 1e6:.1f} MB, output {output / 1e6:.1f} MB"
    in_memory = dynamic_allan_variance(np.asarray(record), fs, **kw)
    assert max_rel(result.avar, in_memory.avar) < 1e-10


def test_input_errors(random_record: np.ndarray) -> None:
    with pytest.raises(TooFewSamplesError, match="fewer than one window"):
        dynamic_allan_variance(random_record, 10.0, window_s=500.0)
    with pytest.raises(InvalidWindowError, match="less than one sample"):
        dynamic_allan_variance(random_record, 10.0, window_s=0.01)
    with pytest.raises(InvalidWindowError, match="window of 5 samples"):
        dynamic_allan_variance(random_record, 10.0, window_s=0.5)
    with pytest.raises(InvalidWindowError, match="block_samples"):
        dynamic_allan_variance(random_record, 10.0, window_s=50.0, block_samples=499)
    bad = random_record.copy()
    bad[1234, 1] = np.nan
    with pytest.raises(NonFiniteSamplesError, match="sample 1234 axis 1"):
        dynamic_allan_variance(bad, 10.0, window_s=50.0)
    with pytest.raises(ValueError, match="axes"):
        dynamic_allan_variance_stream(iter([random_record[:100], random_record[100:, :1]]), 10.0,
                                      window_s=5.0)


def test_windows_across_a_gap_are_left_out_and_the_others_are_exact() -> None:
    """A recorded gap (NaN on the time grid) with ``missing="gap"``: the windows missing
    over a tenth of an axis' samples are NaN on that axis, those missing less keep partial
    clusters near the unbroken value, every other window equals the DAVAR of the unbroken
    record (a rate sinusoid makes a joined record differ), times stay true."""
    rng = np.random.default_rng(11)
    fs, n = 10.0, 36_000
    t = np.arange(n) / fs
    clean = rng.normal(size=(n, 2)) + 0.5 * np.sin(2 * np.pi * t / 600.0)[:, None]
    ref = dynamic_allan_variance(clean, fs, window_s=600.0)
    gapped = clean.copy()
    gapped[10_000:11_000, 0] = np.nan  # 100 s lost on x only: over a tenth of a window
    got = dynamic_allan_variance_stream((gapped[a:a + 7000] for a in range(0, n, 7000)), fs,
                                        window_s=600.0, missing="gap", block_samples=12_000)
    np.testing.assert_array_equal(got.t_s, ref.t_s)
    starts = np.round(got.t_s * fs - 3000).astype(int)
    lost = np.clip(np.minimum(starts + 6000, 11_000) - np.maximum(starts, 10_000), 0, None)
    crosses, partial = lost > 600, (lost > 0) & (lost <= 600)  # over / within a tenth
    assert crosses.sum() >= 8 and partial.sum() >= 2
    assert np.isnan(got.avar[crosses, :, 0]).all() and not np.isnan(got.avar[~crosses, :, 0]).any()
    whole = ~crosses & ~partial
    np.testing.assert_allclose(got.avar[whole, :, 0], ref.avar[whole, :, 0], rtol=1e-9)
    # a window missing a few per cent keeps its value, inside its (widened) interval
    assert (got.edf[partial, :, 0] < ref.edf[partial, :, 0]).all()
    ok = (ref.avar[partial, :, 0] >= got.ci_low[partial, :, 0] * 0.9) & (
        ref.avar[partial, :, 0] <= got.ci_high[partial, :, 0] * 1.1)
    assert ok.all()
    np.testing.assert_allclose(got.avar[:, :, 1], ref.avar[:, :, 1], rtol=1e-9)
    # joining the stretches instead would shift the sinusoid's phase in every later window
    joined = dynamic_allan_variance(np.delete(clean, np.s_[10_000:11_000], axis=0), fs,
                                    window_s=600.0)
    late = slice(len(joined.t_s) - 5, len(joined.t_s))
    assert not np.allclose(joined.avar[late, :, 0], ref.avar[-5:, :, 0], rtol=0.05)
    with pytest.raises(NonFiniteSamplesError):
        dynamic_allan_variance(gapped, fs, window_s=600.0)
    with pytest.raises(NonFiniteSamplesError):
        dynamic_allan_variance(np.where(np.isnan(gapped), np.inf, gapped), fs, window_s=600.0,
                               missing="gap")
