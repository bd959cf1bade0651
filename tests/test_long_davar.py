"""DAVAR and reconcile of long records in bounded memory: the numbers of the in-memory
paths, a memmap's pages handed back.

As in ``test_long_records.py``, the block-wise paths start above
:data:`analysis.allan.blocks.LONG_SAMPLES`; the tests lower it (and the block size) so that a
short record takes them.
"""

from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from analysis.allan import blocks
from analysis.davar.estimators import dynamic_allan_variance, plan_davar
from analysis.davar.long import dynamic_allan_variance_long, group_span
from analysis.errors import NonFiniteSamplesError
from analysis.reconcile.discrepancy import block_means
from station.services.davar import DavarRequest, davar
from station.services.records import RecordSource

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture()
def small_blocks(monkeypatch: pytest.MonkeyPatch) -> None:
    """Records over 5000 samples are long, walked in blocks of 1237."""
    monkeypatch.setattr(blocks, "LONG_SAMPLES", 5000)
    monkeypatch.setattr(blocks, "BLOCK_SAMPLES", 1237)


def _record(n: int, k: int = 2) -> np.ndarray:
    rng = np.random.default_rng(11)
    x = 0.01 * rng.standard_normal((n, k)) + 1e-4 * np.cumsum(rng.standard_normal((n, k)), 0)
    return x + 0.3  # a bias, which the angle's mean removal takes away


def _rss_kb() -> int:
    status = Path("/proc/self/status").read_text()
    return int(re.search(r"VmRSS:\s+(\d+)", status).group(1))  # type: ignore[union-attr]


@pytest.mark.parametrize("windows", [(2 / 41, 1 / 41), (0.1, None)])
def test_davar_by_groups_of_windows_gives_the_fast_davars_numbers(
    small_blocks: None, tmp_path: Path, windows: tuple[float, float | None]
) -> None:
    """An axis-major memmap (as a long run file is read), a gap in one axis, several groups
    of windows: the fast DAVAR's Allan variances within 4e-12 (measured 1.9e-12, 1e-12 in
    deviation: rounding of the angles, each group's own against each block's), the same
    NaN cells and the same partial windows (edf reduced)."""
    n, fs = 100_000, 100.0
    x = _record(n)
    x[40_000:40_010, 1] = np.nan  # a short gap: partial clusters in the windows holding it
    x[70_000:71_200, 1] = np.nan  # over a tenth of any window: NaN there
    mapped = np.memmap(tmp_path / "rate.f8", dtype=np.float64, mode="w+", shape=(2, n))
    mapped[:] = x.T
    window_s = windows[0] * n / fs
    step_s = None if windows[1] is None else windows[1] * n / fs
    kw = {"window_s": window_s, "step_s": step_s, "missing": "gap"}
    plan = plan_davar(fs, window_s, step_s, "log")
    angle = np.memmap(tmp_path / "angle.f8", dtype=np.float64, mode="w+",
                      shape=(group_span(plan) + 1,))
    assert n / group_span(plan) > 2  # several groups
    fast = dynamic_allan_variance(x, fs, **kw)  # type: ignore[arg-type]
    long = dynamic_allan_variance_long(mapped.T, fs, angle_out=angle, **kw)  # type: ignore[arg-type]
    np.testing.assert_array_equal(np.isnan(long.avar), np.isnan(fast.avar))
    assert np.isnan(fast.avar[:, :, 1]).any() and not np.isnan(fast.avar[:, :, 0]).any()
    partial = np.isfinite(fast.avar[:, 0, 1]) & (fast.edf[:, 0, 1] < fast.edf[:, 0, 0])
    assert partial.any()
    np.testing.assert_allclose(long.avar, fast.avar, rtol=4e-12)
    np.testing.assert_allclose(long.edf, fast.edf, rtol=1e-12)
    np.testing.assert_array_equal(long.t_s, fast.t_s)
    np.testing.assert_array_equal(long.noise_alpha, fast.noise_alpha)


def test_davar_by_groups_refuses_what_the_fast_davar_refuses(small_blocks: None) -> None:
    x = _record(20_000, 1)[:, 0]
    x[12_345] = np.inf
    with pytest.raises(NonFiniteSamplesError, match="12345"):
        dynamic_allan_variance_long(x, 100.0, window_s=20.0, missing="gap")
    x[12_345] = np.nan
    with pytest.raises(NonFiniteSamplesError, match="missing='gap'"):
        dynamic_allan_variance_long(x, 100.0, window_s=20.0)
    with pytest.raises(ValueError, match="angle_out"):
        dynamic_allan_variance_long(x, 100.0, window_s=20.0, missing="gap",
                                    angle_out=np.empty(10))


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs /proc (Linux)")
def test_davar_of_a_memmap_maps_in_about_one_group(tmp_path: Path) -> None:
    """A 64 MB memmap in windows of 1/32 of it: the resident set grows by about one group of
    windows (3 windows, 6 MB), not the record (the fast DAVAR mapped in all of it, plus
    copies of three windows of every axis)."""
    n, fs = 8 << 20, 1000.0
    path = tmp_path / "rate.f8"
    with open(path, "wb") as fh:
        fh.truncate(n * 8)
    rate = np.memmap(path, dtype=np.float64, mode="r", shape=(n,))
    kw = {"window_s": n / 32 / fs, "taus": np.array([1.0, 10.0, 100.0]) / fs}
    plan = plan_davar(fs, kw["window_s"], None, kw["taus"])  # type: ignore[arg-type]
    angle = np.memmap(tmp_path / "angle.f8", dtype=np.float64, mode="w+",
                      shape=(group_span(plan) + 1,))
    before = _rss_kb()
    result = dynamic_allan_variance_long(rate, fs, angle_out=angle, backend="numpy",
                                         **kw)  # type: ignore[arg-type]
    grown = _rss_kb() - before
    assert result.avar.shape == (311, 3, 1) and not result.avar.any()
    assert grown < 16_000, grown  # kB


def _bench_memory() -> ModuleType:
    spec = importlib.util.spec_from_file_location("bench_memory",
                                                  ROOT / "benchmarks" / "bench_memory.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("gaps", [0, 2])
def test_station_davar_of_a_long_run_file_gives_the_numbers_of_one_piece(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, gaps: int
) -> None:
    """``station davar`` of a run file read into scratch memmaps (gaps laid out on the
    time grid in one) against the same run read into memory: within 1e-12, the same
    windows left out."""
    bench = _bench_memory()
    monkeypatch.setattr(bench, "BATCH", 8192)
    run = tmp_path / "run.h5"
    bench.write_run(run, 60_000 / 3600 / 1000, 1000.0, 2, gaps=gaps)
    request = DavarRequest(RecordSource(run, warmup_s=0.0), window_s=6.0)
    whole = davar(request).as_json()
    monkeypatch.setattr(blocks, "LONG_SAMPLES", 5000)
    monkeypatch.setattr(blocks, "BLOCK_SAMPLES", 1237)
    answer = davar(request)
    assert blocks.is_mapped(answer.record.rate_deg_s)  # the long path was taken
    streamed = answer.as_json()
    assert json.dumps(streamed).count("null") == json.dumps(whole).count("null")
    assert ("null" in json.dumps(whole)) == (gaps > 0)
    for a, b in zip(whole["axes"], streamed["axes"], strict=True):  # type: ignore[call-overload]
        assert a.keys() == b.keys() and a["t_s"] == b["t_s"] and a["tau_s"] == b["tau_s"]
        assert a["warmup_end_s"] == b["warmup_end_s"] and a["stationary"] == b["stationary"]
        av = np.array(a["adev"], dtype=float)
        bv = np.array(b["adev"], dtype=float)
        np.testing.assert_allclose(bv, av, rtol=1e-12)


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs /proc (Linux)")
def test_reconcile_decimates_a_memmap_a_few_blocks_at_a_time(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Block means of a memmap (reconcile's decimation of a long record): numpy's means bit
    for bit, and a 64 MB record is not mapped in whole (it was, before)."""
    x = _record(30_011)
    mapped = np.memmap(tmp_path / "rate.f8", dtype=np.float64, mode="w+", shape=x.shape)
    mapped[:] = x
    with monkeypatch.context() as small:
        small.setattr(blocks, "BLOCK_SAMPLES", 1237)
        for d in (7, 3000):
            np.testing.assert_array_equal(block_means(mapped, d), block_means(x, d))
            np.testing.assert_array_equal(block_means(mapped[:, 1], d), block_means(x[:, 1], d))
    n = 8 << 20
    path = tmp_path / "big.f8"
    with open(path, "wb") as fh:
        fh.truncate(n * 8)
    big = np.memmap(path, dtype=np.float64, mode="r", shape=(n,))
    before = _rss_kb()
    assert not block_means(big, 8).any()
    grown = _rss_kb() - before
    assert grown < 16_000, grown  # kB: 8 MB of means, a few blocks of the record
