"""Long records in bounded memory: the block-wise paths give today's numbers, a memmap's
pages are handed back, and ``station analyze`` of a long run file stays flat.

The block-wise paths start above :data:`analysis.allan.blocks.LONG_SAMPLES`; the tests lower
it (and the block size) so that a short record takes them, and compare with the same
record analysed in one piece.
"""

from __future__ import annotations

import importlib
import re
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import numpy as np
import pytest

from analysis.allan import blocks, kernels
from analysis.allan.deviations import deviation
from analysis.allan.estimators import (
    cluster_allan_variance,
    cumulative_angle,
    overlapping_allan_variance,
)
from analysis.allan.gaps import gap_allan_variance, gap_summary_of_index
from analysis.allan.noise_id import b1_ratio, lag1_alpha
from analysis.allan.outliers import detect_spikes, replace_flagged, replace_spikes
from analysis.figures.spec import bias_stability
from analysis.figures.tones import find_tones
from analysis.gmwm.wavelet import _lag_sum_long, haar_wavelet_variance
from station.evaluation.long_records import (
    COMPILER_LIBRARIES,
    release_compiler_pages,
    return_freed_heap,
)
from station.evaluation.resolution import value_census

ROOT = Path(__file__).resolve().parents[1]
T = TypeVar("T")


@pytest.fixture()
def small_blocks(monkeypatch: pytest.MonkeyPatch) -> None:
    """Records over 5000 samples are long, walked in blocks of 1237."""
    monkeypatch.setattr(blocks, "LONG_SAMPLES", 5000)
    monkeypatch.setattr(blocks, "BLOCK_SAMPLES", 1237)


def _record(n: int = 60_000) -> np.ndarray:
    rng = np.random.default_rng(7)
    t = np.arange(n) / 100.0
    x = 0.01 * rng.standard_normal(n) + 1e-4 * np.cumsum(rng.standard_normal(n)) / 30
    x += 0.004 * np.sin(2 * np.pi * 11.0 * t)
    x[[50, 20_000, 20_001, 59_990]] += [0.6, -0.5, -0.55, 0.7]
    return x


def _memmap(tmp_path: Path, x: np.ndarray) -> np.memmap:
    mm = np.memmap(tmp_path / "rate.f8", dtype=np.float64, mode="w+", shape=x.shape)
    mm[:] = x
    mm.flush()
    return np.memmap(tmp_path / "rate.f8", dtype=np.float64, mode="r", shape=x.shape)


def _angle_out(tmp_path: Path, n_samples: int) -> np.memmap:
    """A memmap for the angle of ``n_samples`` (shape (n + 1, 1))."""
    return np.memmap(tmp_path / "angle.f8", dtype=np.float64, mode="w+", shape=(n_samples + 1, 1))


def _in_one_piece(monkeypatch: pytest.MonkeyPatch, compute: Callable[[], T]) -> T:
    """``compute()`` with no record counting as long (the in-memory path)."""
    with monkeypatch.context() as mp:
        mp.setattr(blocks, "LONG_SAMPLES", 1 << 30)
        return compute()


def test_block_wise_analysis_of_a_memmap_gives_the_numbers_of_one_piece(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    x = _record()
    whole_angle = cumulative_angle(x, 100.0)
    whole = overlapping_allan_variance(x, 100.0)
    spikes = detect_spikes(x)
    tones = find_tones(x, 100.0)
    stability = bias_stability(x, 100.0, 10.0)
    repaired = replace_spikes(x, spikes.flags)
    monkeypatch.setattr(blocks, "LONG_SAMPLES", 5000)
    monkeypatch.setattr(blocks, "BLOCK_SAMPLES", 1237)
    mm = _memmap(tmp_path, x)
    angle = _angle_out(tmp_path, len(x))
    # one running sum either way: the angle is the same to the last bit
    np.testing.assert_array_equal(cumulative_angle(mm, 100.0, out=angle), whole_angle)
    for backend in ("numpy", "numba"):
        monkeypatch.setattr(
            "analysis.allan.kernels._pick",
            lambda b, w, _b=backend: (
                None if _b == "numpy" else importlib.import_module("analysis.allan.kernels_numba")
            ),
        )
        got = overlapping_allan_variance(mm, 100.0, angle_out=angle)
        np.testing.assert_allclose(got.avar, whole.avar, rtol=1e-12)
        np.testing.assert_array_equal(got.noise_alpha, whole.noise_alpha)
    long_spikes = detect_spikes(mm)
    assert long_spikes.spikes == spikes.spikes and len(spikes.spikes) == 3
    assert (long_spikes.scale, long_spikes.scale_linear) == (spikes.scale, spikes.scale_linear)
    np.testing.assert_array_equal(replace_flagged(mm, long_spikes.flagged), repaired)
    assert [t.freq_hz for t in find_tones(mm, 100.0)] == pytest.approx(
        [t.freq_hz for t in tones], rel=1e-12
    )
    assert bias_stability(mm, 100.0, 10.0) == stability


def test_exact_block_medians_of_quantized_and_continuous_values(small_blocks: None) -> None:
    rng = np.random.default_rng(3)
    for x in (
        rng.standard_normal(20_001),
        np.round(rng.standard_normal(20_000) * 3) / 7,
        np.zeros(9000),
    ):
        assert blocks.median(lambda a, b, v=x: v[a:b], len(x)) == np.median(x)


def test_block_sums_are_numpys_bit_for_bit(small_blocks: None) -> None:
    """numpy's pairwise sum (and the means of grading's bias batches) redone block by
    block: equal to the last bit, NaN counted as 0 where asked (``nanmean``)."""
    rng = np.random.default_rng(5)
    x = rng.standard_normal(100_003) * 1e3 + rng.standard_normal(100_003) ** 3 * 1e6
    assert blocks.pairwise_sum(x) == np.sum(x)
    assert blocks.pairwise_sum(x, 17, 90_017) == np.sum(x[17:90_017])
    np.testing.assert_array_equal(blocks.finite_batch_means(x, 10),
                                  x[: 10 * 10_000].reshape(10, 10_000).mean(axis=1))
    x[[5, 70_000]] = np.nan
    assert blocks.nan_mean(x) == np.nanmean(x)
    present = x[np.isfinite(x)]
    np.testing.assert_allclose(blocks.finite_batch_means(x, 10),
                               present[:100_000].reshape(10, 10_000).mean(axis=1), rtol=1e-12)


def _rss_kb() -> int:
    status = Path("/proc/self/status").read_text()
    return int(re.search(r"VmRSS:\s+(\d+)", status).group(1))  # type: ignore[union-attr]


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs /proc (Linux)")
def test_walking_a_memmap_hands_its_pages_back(tmp_path: Path) -> None:
    """Summing a 64 MB memmap a block at a time keeps the resident set near one block;
    reading it through without the hand-back maps all of it."""
    n = 8 << 20
    path = tmp_path / "big.f8"
    with open(path, "wb") as fh:
        fh.truncate(n * 8)
    mm = np.memmap(path, dtype=np.float64, mode="r", shape=(n, 1))
    before = _rss_kb()
    assert blocks.column_sums(mm)[0] == 0.0
    assert len(blocks.decimated(mm[:, 0], 100)) == len(range(0, n, 100))  # strided, too
    grown = _rss_kb() - before
    whole = np.memmap(path, dtype=np.float64, mode="r", shape=(n, 1))
    before = _rss_kb()
    assert float(whole.sum()) == 0.0
    unreleased = _rss_kb() - before
    assert unreleased > 50_000  # kB: the whole 64 MB was mapped in
    assert grown < 16_000, grown


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs /proc (Linux)")
def test_noise_identification_of_a_memmap_maps_in_about_one_block(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The lag-1 and B1 noise identification at m = 64 read the angle decimated: a block
    of decimated samples must not stride over 64 blocks of the record (a 24 h run at 1 kHz
    mapped in 150 MB at a time that way)."""
    monkeypatch.setattr(blocks, "LONG_SAMPLES", 1 << 14)
    n = 8 << 20
    path = tmp_path / "angle.f8"
    with open(path, "wb") as fh:
        fh.truncate(n * 8)
    angle = np.memmap(path, dtype=np.float64, mode="r", shape=(n,))
    before = _rss_kb()
    assert lag1_alpha(angle, 64) in (-2, -1, 0, 1, 2)
    assert b1_ratio(angle, 64) == 1.0  # a constant angle: no Allan variance to divide by
    grown = _rss_kb() - before
    assert grown < 16_000, grown  # kB; the whole 64 MB before the fix


def _peak_reset() -> bool:
    """Reset the process's peak resident set (VmHWM) to its current one; False where the
    system does not offer it (``/proc/self/clear_refs``, Linux 4.0 on)."""
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:
        return False
    return True


def _peak_kb() -> int:
    status = Path("/proc/self/status").read_text()
    return int(re.search(r"VmHWM:\s+(\d+)", status).group(1))  # type: ignore[union-attr]


@pytest.mark.skipif(not _peak_reset(), reason="needs a resettable VmHWM (Linux 4.0 on)")
def test_wavelet_lag_window_of_a_memmap_maps_in_about_one_block(tmp_path: Path) -> None:
    """The lag-window estimate of a wide level gathers thinned coefficients spread over
    the whole angle: the pages they map in go back each time the rows span a block (a
    24 h run at 1 kHz mapped in all of its 691 MB angle at once before)."""
    n = 8 << 20
    path = tmp_path / "angle.f8"
    with open(path, "wb") as fh:  # written, as the analysis writes its angle: in the
        for _ in range(n >> 20):  # file cache, where a fault maps in its neighbours too
            fh.write(np.ones(1 << 20).tobytes())
    angle = np.memmap(path, dtype=np.float64, mode="r", shape=(n, 1))
    before = _rss_kb()
    _peak_reset()
    m = 1 << 16  # thinned to every 16384th coefficient: 512 rows over the 64 MB
    assert _lag_sum_long(angle, m, 100.0, 2 * m)[0] == 0.0  # a constant angle
    grown = _peak_kb() - before  # the peak: the pages go back before it returns
    assert grown < 16_000, grown  # kB; most of the 64 MB before the fix


@pytest.mark.skipif(not _peak_reset(), reason="needs a resettable VmHWM (Linux 4.0 on)")
def test_value_census_of_many_values_peaks_at_about_one_block(tmp_path: Path) -> None:
    """The grading's census of a record's values (its LSB and stuck-output review) reads
    a block at a time: once a block alone holds more distinct values than it counts, it
    makes no Python list or dict of them (measured on 4e6 normal samples: a peak 37 MB over
    the resident set before, 23 MB after), and the census is the one of the record whole."""
    n = 4_000_000
    x = np.random.default_rng(3).standard_normal(n)
    whole = value_census(x)
    mm = _memmap(tmp_path, x)
    del x
    before = _rss_kb()
    _peak_reset()
    census = value_census(mm)
    grown = _peak_kb() - before
    assert census == whole
    assert census.distinct_capped and census.longest_run == 1
    assert grown < 30_000, grown  # kB


def test_returning_the_freed_heap_keeps_the_arrays_in_use() -> None:
    """``malloc_trim`` after an axis hands back freed pages only: what is in use stays."""
    kept = np.arange(1 << 20, dtype=np.float64)
    freed = [np.ones(1 << 10) for _ in range(4096)]  # small blocks, freed into the heap
    del freed
    return_freed_heap()
    assert float(kept.sum()) == (1 << 20) * ((1 << 20) - 1) / 2


def _compiler_resident_kb() -> int:
    """Resident kB of the compiler library's mappings (``/proc/self/smaps``)."""
    total, inside = 0, False
    with open("/proc/self/smaps") as smaps:
        for line in smaps:
            head = line.split()
            if "-" in head[0] and not head[0].endswith(":"):
                inside = any(n in line for n in COMPILER_LIBRARIES)
            elif inside and head[0] == "Rss:":
                total += int(head[1])
    return total


@pytest.mark.skipif(not kernels.have_compiled() or not sys.platform.startswith("linux"),
                    reason="numba is not installed, or not Linux (/proc/self/smaps)")
def test_releasing_the_compiler_pages_keeps_the_compiled_kernels() -> None:
    """After the compiled kernels ran, the compiler library's pages leave the resident set
    (loading numba leaves 40-70 MB of them); the kernels give the same sums afterwards and
    a new compilation still works (its pages are read in again from the file)."""
    import numba

    @numba.njit(cache=False)
    def compiled_here(v: float) -> float:  # the compiler runs in this process (the kernels
        return v + 1.0                     # may load from numba's cache without it)

    assert compiled_here(1.0) == 2.0
    theta = np.cumsum(np.random.default_rng(3).standard_normal((20_000, 2)), axis=0)
    m = np.array([1, 4, 16, 256])
    before = kernels.overlapping_sums(theta, m, backend="numba")
    resident = _compiler_resident_kb()
    release_compiler_pages()
    released = _compiler_resident_kb()
    assert resident > 10_000 and released < resident / 4, (resident, released)
    np.testing.assert_array_equal(kernels.overlapping_sums(theta, m, backend="numba"), before)

    @numba.njit(cache=False)
    def twice(v: float) -> float:
        return 2.0 * v

    assert twice(21.0) == 42.0


def _bench_line(minutes: float, *options: str) -> re.Match[str]:
    """The line of ``bench_memory.py`` on a run of ``minutes`` at 2 kHz, 1 axis, records
    over 2^16 samples long: ``peak_rss_mb``, ``seconds`` (and ``max_rel_diff``)."""
    run = subprocess.run(
        [
            sys.executable,
            str(ROOT / "benchmarks" / "bench_memory.py"),
            "--hours",
            str(minutes / 60),
            "--rate-hz",
            "2000",
            "--axes",
            "1",
            "--long-samples",
            str(1 << 16),
            *options,
        ],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
    )
    assert run.returncode == 0, run.stderr[-2000:]
    lines = run.stdout.strip().splitlines()
    assert len(lines) == 1, run.stdout
    match = re.fullmatch(r"peak_rss_mb=(\d+) seconds=(\d+\.\d)(?: max_rel_diff=(\S+))?",
                         lines[0])
    assert match, lines[0]
    return match


def _bench_memory(minutes: float, *options: str) -> int:
    return int(_bench_line(minutes, *options).group(1))


@pytest.mark.slow
def test_bench_memory_peak_is_flat_in_the_run_length() -> None:
    """``station analyze`` of 16- and 48-minute runs at 2 kHz through the block-wise path
    (records over 2^16 samples count as long): one line ``peak_rss_mb=... seconds=...``
    each, and the peak grows by less than 35 MB (measured 193 -> 222 MB; 215 -> 226 MB
    before the compiler's pages left the resident set after each axis' Allan analysis: the
    shorter run's peak now falls after they leave, the longer run's during that analysis,
    with them). Both runs are past the compiled kernels' threshold
    (``analysis.allan.kernels.COMPILED_MIN_TERMS``): a shorter run takes the numpy path,
    and the compiler's fixed ~100 MB would read as growth (2 min: 106-125 MB)."""
    short, long = _bench_memory(16), _bench_memory(48)
    assert 50 < short < 400 and 50 < long < 400, (short, long)
    assert long - short < 35, (short, long)


@pytest.mark.slow
def test_grade_peak_is_flat_in_the_run_length_with_the_numbers_of_one_piece() -> None:
    """``station grade --json`` of 2- and 10-minute runs at 2 kHz through the block-wise
    path: the peak grows by less than 20 MB (measured 159 -> 159 MB; the in-memory path
    205 -> 246 MB), and every number of the grading is the one the in-memory path gives
    (``--compare``: bit for bit, measured 0)."""
    _grade_is_flat_with_the_numbers_of_one_piece(max_diff=1e-12)


def _grade_is_flat_with_the_numbers_of_one_piece(*options: str, max_diff: float) -> None:
    """``station grade`` (bench_memory ``options``) of 2- and 10-minute runs through the
    block-wise path: the peak grows by under 20 MB, the numbers within ``max_diff``."""
    short_line = _bench_line(2, "--command", "grade", *options, "--compare")
    short, diff = int(short_line.group(1)), float(short_line.group(3))
    long = _bench_memory(10, "--command", "grade", *options)
    assert 50 < short < 400 and 50 < long < 400, (short, long)
    assert long - short < 20, (short, long)
    assert diff <= max_diff, diff


def test_gapped_allan_variance_of_a_memmap_gives_the_numbers_of_one_piece(
    tmp_path: Path, small_blocks: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The overlapping Allan variance of a long record with gaps (a memmap, its angle in
    another) equals the in-memory one: the same stretches, terms, edf and noise types."""
    x = _record()
    x[5000:5037] = np.nan
    x[20_100:20_600] = np.nan
    x[40_001] = np.nan
    x[59_990:] = np.nan
    whole = _in_one_piece(monkeypatch, lambda: gap_allan_variance(x, 100.0))
    mm = _memmap(tmp_path, x)
    present = int(np.isfinite(x).sum())
    angle = _angle_out(tmp_path, present)
    got = gap_allan_variance(mm, 100.0, angle_out=angle)
    np.testing.assert_allclose(got.avar, whole.avar, rtol=1e-12)
    for name in ("m", "n_terms", "n_clusters", "edf", "noise_alpha"):
        np.testing.assert_array_equal(getattr(got, name), getattr(whole, name), err_msg=name)
    summary = gap_summary_of_index(np.flatnonzero(np.isfinite(x)))
    assert (summary.count, summary.missing_samples) == (3, 37 + 500 + 1)


@pytest.mark.slow
def test_grade_of_a_gapped_run_is_flat_in_the_run_length_with_the_numbers_of_one_piece(
) -> None:
    """``station grade --json`` of runs with three gaps through the block-wise path (its
    sample index and the gapped Allan sums in scratch memmaps): flat from 2 to 10 minutes
    at 2 kHz (measured 159 -> 159 MB; the in-memory path 204 -> 263 MB), and the numbers of
    the in-memory path: the Allan values to rounding, the fitted terms to the fit's
    convergence (measured 9e-16 here, 2.6e-9 on a 2 h x 1 kHz x 3 axes run)."""
    _grade_is_flat_with_the_numbers_of_one_piece("--gaps", "3", max_diff=1e-6)


def test_cluster_allan_variance_of_a_memmap_gives_the_numbers_of_one_piece(
    tmp_path: Path, small_blocks: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The cluster (non-overlapping) estimator of a long record, its angle in a memmap and
    the cluster edges read a block at a time, equals the in-memory estimator."""
    x = _record()
    whole = _in_one_piece(monkeypatch, lambda: cluster_allan_variance(x, 100.0, taus="log"))
    mm = _memmap(tmp_path, x)
    angle = _angle_out(tmp_path, len(x))
    got = cluster_allan_variance(mm, 100.0, taus="log", angle_out=angle)
    np.testing.assert_allclose(got.avar, whole.avar, rtol=1e-12)
    np.testing.assert_array_equal(got.noise_alpha, whole.noise_alpha)
    np.testing.assert_array_equal(got.n_clusters, whole.n_clusters)


@pytest.mark.parametrize("kind", ["mdev", "tdev", "hdev", "ohdev", "totdev", "adev"])
def test_deviations_of_a_memmap_give_the_numbers_of_one_piece(
    tmp_path: Path, small_blocks: None, monkeypatch: pytest.MonkeyPatch, kind: str
) -> None:
    """The modified, Hadamard and total deviations of a long record (its angle in a
    memmap, the differences summed a block at a time; the total one reflected about the
    ends without building the reflection) equal the in-memory ones."""
    x = _record()
    whole = _in_one_piece(
        monkeypatch, lambda: deviation(x, 100.0, kind=kind))  # type: ignore[arg-type]
    mm = _memmap(tmp_path, x)
    angle = _angle_out(tmp_path, len(x))
    got = deviation(mm, 100.0, kind=kind, angle_out=angle)  # type: ignore[arg-type]
    np.testing.assert_allclose(got.variance, whole.variance, rtol=1e-12)
    np.testing.assert_array_equal(got.noise_alpha, whole.noise_alpha)
    np.testing.assert_array_equal(got.edf, whole.edf)


@pytest.mark.parametrize("ci", ["pw", "eta3"])
def test_wavelet_variance_of_a_memmap_gives_the_numbers_of_one_piece(
    tmp_path: Path, small_blocks: None, monkeypatch: pytest.MonkeyPatch, ci: str
) -> None:
    """The Haar wavelet variance of a long record (the GMWM's input: its mean squares from
    the overlapping Allan sums, the lag-window estimate from the coefficients it reads)
    equals the in-memory one, intervals included."""
    x = _record()
    whole = _in_one_piece(
        monkeypatch, lambda: haar_wavelet_variance(x, 100.0, ci=ci))  # type: ignore[arg-type]
    mm = _memmap(tmp_path, x)
    angle = _angle_out(tmp_path, len(x))
    got = haar_wavelet_variance(mm, 100.0, ci=ci, angle_out=angle)  # type: ignore[arg-type]
    np.testing.assert_allclose(got.wv, whole.wv, rtol=1e-12)
    np.testing.assert_allclose(got.variance, whole.variance, rtol=1e-12)
    np.testing.assert_allclose(got.edf, whole.edf, rtol=1e-12)
