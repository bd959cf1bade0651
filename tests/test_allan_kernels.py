"""The Allan kernels of analysis.allan.kernels: numpy fallback, compiled kernel and reference agree.

The reference is the plainest possible formula; the fallback is what runs without numba;
the compiled kernel runs only where numba is installed (skipped otherwise). allantools'
``oadev`` is the outside oracle for the whole estimator.
"""

from __future__ import annotations

import os

import allantools
import numpy as np
import pytest

from analysis.allan import kernels
from analysis.allan.estimators import cumulative_angle, overlapping_allan_variance

needs_numba = pytest.mark.skipif(not kernels.have_compiled(), reason="numba is not installed")


@pytest.fixture(scope="module")
def theta() -> np.ndarray:
    rng = np.random.default_rng(11)
    rate = (
        rng.standard_normal((70_001, 2))
        + np.cumsum(rng.standard_normal((70_001, 2)), axis=0) * 1e-3
    )
    return cumulative_angle(rate, 50.0)


M_VALUES = np.array([1, 2, 3, 5, 8, 13, 100, 1000, 4097, 20_000, 35_000])


def test_numpy_fallback_matches_reference(theta: np.ndarray) -> None:
    ref = kernels.overlapping_sums_reference(theta, M_VALUES)
    got = kernels.overlapping_sums(theta, M_VALUES, backend="numpy")
    assert got.shape == (len(M_VALUES), 2)
    np.testing.assert_allclose(got, ref, rtol=1e-12)


@needs_numba
def test_compiled_matches_numpy_fallback(theta: np.ndarray) -> None:
    fallback = kernels.overlapping_sums(theta, M_VALUES, backend="numpy")
    compiled = kernels.overlapping_sums(theta, M_VALUES, backend="numba")
    np.testing.assert_allclose(compiled, fallback, rtol=1e-12)


def test_single_axis_and_edge_m() -> None:
    theta = cumulative_angle(np.random.default_rng(3).standard_normal(9), 1.0)  # N = 9
    m = np.array([1, 4])  # m = N // 2 leaves N + 1 - 2m = 2 terms
    ref = kernels.overlapping_sums_reference(theta, m)
    for backend in ("numpy", "auto"):
        np.testing.assert_allclose(
            kernels.overlapping_sums(theta, m, backend=backend), ref, rtol=1e-13
        )
    d = theta[8] - 2 * theta[4] + theta[0], theta[9] - 2 * theta[5] + theta[1]
    assert ref[1, 0] == pytest.approx(d[0][0] ** 2 + d[1][0] ** 2, rel=1e-14)


def test_rejects_m_out_of_range_and_unknown_backend() -> None:
    theta = np.zeros((11, 1))
    with pytest.raises(ValueError, match="1..5"):
        kernels.overlapping_sums(theta, np.array([6]))
    with pytest.raises(ValueError, match="backend"):
        kernels.overlapping_sums(theta, np.array([1]), backend="fortran")  # type: ignore[arg-type]


def test_overlapping_adev_matches_allantools_oadev() -> None:
    rng = np.random.default_rng(5)
    rate = rng.standard_normal(50_000) + 0.01 * np.cumsum(rng.standard_normal(50_000))
    fs = 100.0
    ours = overlapping_allan_variance(rate, fs, taus="log")
    taus_out, adev, _, n = allantools.oadev(rate, rate=fs, data_type="freq", taus=ours.tau_s)
    np.testing.assert_allclose(taus_out, ours.tau_s, rtol=1e-12)
    np.testing.assert_allclose(np.sqrt(ours.avar), adev, rtol=1e-9)
    np.testing.assert_array_equal(n, ours.n_terms)


def test_window_sums_backends_match_direct_sums() -> None:
    theta = cumulative_angle(np.random.default_rng(8).standard_normal(5000), 1.0)[:, 0]
    window, m = 700, np.array([1, 2, 9, 77, 300, 350])
    for starts in (np.arange(0, 4301, 1), np.arange(0, 4301, 37), np.arange(0, 4301, 900)):
        direct = np.array(
            [
                [
                    kernels.second_difference_squares(theta[s : s + window + 1], int(k)).sum()
                    for k in m
                ]
                for s in starts
            ]
        )
        for backend in ("numpy", "numba"):
            got = kernels.window_sums(theta, m, starts, window, backend=backend)
            np.testing.assert_allclose(got, direct, rtol=1e-12)


def test_window_sums_reject_windows_outside_theta() -> None:
    theta = np.zeros(101)
    with pytest.raises(ValueError, match="inside theta"):
        kernels.window_sums(theta, np.array([1]), np.array([0, 60]), 50)
    with pytest.raises(ValueError, match="1..25"):
        kernels.window_sums(theta, np.array([26]), np.array([0]), 50)


def test_auto_falls_back_to_numpy_without_numba(
    theta: np.ndarray, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(kernels, "_compiled", lambda: None)
    assert not kernels.have_compiled()
    ref = kernels.overlapping_sums_reference(theta, M_VALUES)
    np.testing.assert_allclose(kernels.overlapping_sums(theta, M_VALUES), ref, rtol=1e-12)
    with pytest.raises(ImportError, match="needs numba"):
        kernels.overlapping_sums(theta, M_VALUES, backend="numba")


def test_compiled_kernels_from_several_threads_under_numbas_workqueue_layer() -> None:
    """numba's fallback threading layer aborts the process when two threads launch
    parallel kernels at once; the station analyses in worker threads (the TUI grades while
    it computes a DAVAR), so the launches must take turns."""
    pytest.importorskip("numba")
    import subprocess
    import sys
    import textwrap

    script = textwrap.dedent("""
        import threading
        import numpy as np
        from analysis.allan import kernels
        theta = np.cumsum(np.random.default_rng(1).normal(size=(200_001, 1)), axis=0)
        m = np.unique(np.logspace(0, 4.5, 60).astype(np.int64))
        want = kernels.overlapping_sums(theta, m, backend="numpy")
        bad = []
        def work():
            for _ in range(20):
                got = kernels.overlapping_sums(theta, m, backend="numba")
                starts = np.arange(0, 100_000, 5_000, dtype=np.int64)
                kernels.window_sums(theta[:, 0], m[m < 5_000], starts, 100_000,
                                    backend="numba")
                if not np.allclose(got, want, rtol=1e-12):
                    bad.append(1)
        threads = [threading.Thread(target=work) for _ in range(4)]
        for t in threads: t.start()
        for t in threads: t.join()
        import numba
        print(numba.threading_layer(), len(bad))
    """)
    env = {**os.environ, "NUMBA_THREADING_LAYER": "workqueue"}
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         env=env, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.split() == ["workqueue", "0"]


def test_a_process_forked_after_compiled_kernels_runs_them_too() -> None:
    """An analysis in process (parallel kernels launched) and then a forked process pool
    that runs kernels again (``station reproduce``): GNU OpenMP, numba's default threading
    layer on Linux, cannot run in a forked child and numba kills it ("fork() called from a
    process already using GNU OpenMP"); the compiled kernels pick a fork-safe layer."""
    pytest.importorskip("numba")
    import subprocess
    import sys
    import textwrap

    script = textwrap.dedent("""
        import multiprocessing
        import numpy as np
        from analysis.allan import kernels
        theta = np.cumsum(np.random.default_rng(1).normal(size=(20_001, 1)), axis=0)
        m = np.arange(1, 200, dtype=np.int64)
        def child(_):
            return float(kernels.overlapping_sums(theta, m, backend="numba")[-1, 0])
        parent = child(0)
        with multiprocessing.get_context("fork").Pool(2) as pool:
            print(pool.map(child, range(2)) == [parent] * 2)
    """)
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_THREADING_LAYER"}
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         env=env, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.split() == ["True"]


@needs_numba
def test_compiled_rn_sums_match_numpy_rn_ratio() -> None:
    """R(n)'s one-pass compiled sums give the numpy ratio to rounding (m from 1 to N/3)."""
    from analysis.allan import kernels_numba, noise_id

    angle = np.cumsum(np.random.default_rng(7).standard_normal(30_001))
    for m in (1, 2, 7, 1_000, 9_999):
        assert noise_id.rn_ratio(angle, m, kernels_numba) == pytest.approx(
            noise_id.rn_ratio(angle, m), rel=1e-12)


@pytest.mark.parametrize("step", [1_000, 50])
def test_numpy_window_sums_hold_no_record_long_array(step: int) -> None:
    """The numpy DAVAR kernel walks the terms a chunk at a time, whatever the step: its
    peak allocation is a few chunks and the result, not the record's length per m."""
    import tracemalloc

    theta = np.cumsum(np.random.default_rng(4).standard_normal(1_000_001)) * 1e-3
    window, m = 20_000, np.array([1, 7, 100, 2_000])
    starts = np.arange(0, len(theta) - 1 - window + 1, step, dtype=np.int64)
    tracemalloc.start()
    got = kernels.window_sums(theta, m, starts, window, backend="numpy")
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    # a record-long float64 array alone is 8 MB; chunks are 256 kB, windows' rows 32 kB
    assert peak < 3 * got.nbytes + 4_000_000, peak
    picks = np.array([0, len(starts) // 2, len(starts) - 1])
    direct = np.array([[kernels.second_difference_squares(theta[s: s + window + 1], int(k)).sum()
                        for k in m] for s in starts[picks]])
    np.testing.assert_allclose(got[picks], direct, rtol=1e-11)


def test_auto_picks_by_the_work_alone() -> None:
    """A short record runs in numpy in a fresh process (numba's start-up, about a second,
    would cost more than it saves), and still in numpy after numba ran: the choice never
    depends on what the process did before, so the numbers do not either."""
    import subprocess
    import sys
    import textwrap

    script = textwrap.dedent("""
        import sys
        import numpy as np
        from analysis.allan import kernels
        from analysis.allan.estimators import overlapping_allan_variance
        first = overlapping_allan_variance(np.random.default_rng(1).normal(size=100_000), 100.0)
        cold = "numba" in sys.modules
        theta = np.cumsum(np.random.default_rng(2).normal(size=(1001, 1)), axis=0)
        kernels.overlapping_sums(theta, np.array([1, 2]), backend="numba")
        again = overlapping_allan_variance(np.random.default_rng(1).normal(size=100_000), 100.0)
        print(cold, kernels._pick("auto", 10) is None, kernels._pick("auto", 10**10) is not None,
              bool(np.array_equal(first.avar, again.avar)))
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.split() == ["False", "True", "True", "True"]


@needs_numba
def test_compiled_lag1_sums_give_the_numpy_noise_types() -> None:
    """The compiled lag-1 sums (one blocked pass for every tau) give the lag-1
    autocorrelations of the numpy path to rounding, and the same noise type at every
    tau, for white, flicker and random-walk rate noise with a bias, up to the third
    difference (the Hadamard family's)."""
    from analysis.allan import noise_id
    from analysis.allan.estimators import resolve_m
    from analysis.models.noise import flicker_rate_noise

    rng = np.random.default_rng(11)
    n = 200_000
    records = {
        "white": rng.standard_normal(n) + 3.0,
        "flicker": flicker_rate_noise(1.0, n, 100.0, rng) + 0.5 * rng.standard_normal(n),
        "walk": np.cumsum(rng.standard_normal(n)) * 1e-2 + rng.standard_normal(n),
    }
    theta = cumulative_angle(np.column_stack(list(records.values())), 100.0)
    m = resolve_m("log", n, 100.0)
    for d_max in (2, 3):
        numpy_id = noise_id.identify_noise(theta, m, d_max=d_max, backend="numpy")
        compiled_id = noise_id.identify_noise(theta, m, d_max=d_max, backend="numba")
        assert np.array_equal(numpy_id.alpha, compiled_id.alpha)
        assert np.array_equal(numpy_id.method, compiled_id.method)
    assert {-2, -1, 0} <= set(np.unique(numpy_id.alpha))  # the three types are there
    acf_m = m[n // m + 1 >= noise_id.MIN_ACF_POINTS]
    moments = kernels.lag1_moments(theta[:, 0], acf_m, 3, kernels._compiled())
    for i, mi in enumerate(acf_m):
        z = np.diff(theta[::mi, 0])
        for d in range(3):
            r1, length = noise_id.lag1_from_moments(moments[i, d])
            assert length == len(z)
            assert abs(r1 - noise_id.lag1_autocorrelation(z)) < 1e-11
            z = np.diff(z)


@needs_numba
@pytest.mark.parametrize("shape", [(5000,), (3000, 3), ((1 << 20) + 7,)])
@pytest.mark.parametrize("input_kind", ["rate", "angle_increment"])
def test_compiled_angle_is_numpys_bit_for_bit(shape: tuple[int, ...], input_kind: str) -> None:
    """The one-pass compiled running sum gives numpy's angle exactly, in-memory and block-wise
    (a record over 2^20 samples takes the block sums' mean) alike."""
    x = np.random.default_rng(11).standard_normal(shape) * 0.1 + 2.5
    numpy_angle = cumulative_angle(x, 250.0, input_kind=input_kind)  # type: ignore[arg-type]
    compiled = cumulative_angle(x, 250.0, input_kind=input_kind,  # type: ignore[arg-type]
                                backend="numba")
    np.testing.assert_array_equal(compiled, numpy_angle)


@needs_numba
def test_compiled_angle_refuses_what_numpy_refuses() -> None:
    from analysis.errors import NonFiniteSamplesError

    x = np.ones(100)
    x[42] = np.inf
    with pytest.raises(NonFiniteSamplesError, match="sample 42"):
        cumulative_angle(x, 10.0, backend="numba")
