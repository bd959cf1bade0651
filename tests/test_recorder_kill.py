"""SIGKILL of a real recorder process at several moments: nothing flushed is lost.

Each case starts ``station record`` (one simulated Xsens over a pty, real time), waits
until the file holds data, lets it run for a chosen time, kills it with SIGKILL and then
checks: the file opens with h5py (SWMR read, as a reader of a file left open must), its
last flush is at most 1 s before the kill, every committed sample is the simulated
signal at its counter (to the STIM300's resolution) with counters and gaps agreeing,
opening it marks the run interrupted, and ``station recover`` closes it so that h5py
opens it without SWMR, keeping every committed sample.
"""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import h5py
import pytest

from station.cli import main
from station.hdf5 import REASON_RECOVERED, read_run
from tests.test_recorder_helpers import (
    check_unit_against_signal,
    last_flush_age_s,
    start_recorder,
    wait_for_samples,
)

#: Seconds after the first committed samples at which each recorder is killed: spread
#: over the 0.5 s flush cycle (early, mid, late) and over the first seconds of a run.
KILL_AFTER_S = (1.31, 0.23, 0.77)
#: Xbus has a 16-bit counter: a loaded machine's stalls cannot alias into counter wraps
#: (see test_recorder_faults for the wrapping counters).
URL = "sim+serial://STIM300?protocol=xbus&rate=500&seed={seed}"


@pytest.fixture(scope="module")
def killed_runs(tmp_path_factory: pytest.TempPathFactory) -> list[tuple[Path, float, str]]:
    """Three recorders killed at their moments: (file, kill time as time.time(), url)."""
    started = []
    for i, _ in enumerate(KILL_AFTER_S):
        folder = tmp_path_factory.mktemp(f"kill{i}")
        url = URL.format(seed=10 + i)
        proc = start_recorder("--unit", url, "--duration", "1h", "--out", str(folder),
                             "--quiet", "--flush-interval", "0.5")
        started.append((proc, folder, url))
    out = []
    try:
        for (proc, folder, url), after_s in zip(started, KILL_AFTER_S, strict=True):
            path = wait_for_samples(folder, 1)
            time.sleep(after_s)
            assert proc.poll() is None, proc.communicate()
            os.kill(proc.pid, signal.SIGKILL)
            killed_at = time.time()
            proc.wait(10)
            out.append((path, killed_at, url))
    finally:
        for proc, _, _ in started:
            if proc.poll() is None:
                proc.kill()
            proc.communicate(timeout=10)
    return out


@pytest.mark.parametrize("case", range(len(KILL_AFTER_S)))
def test_killed_recorder_leaves_a_readable_file_intact_to_its_last_flush(
        killed_runs: list[tuple[Path, float, str]], case: int) -> None:
    path, killed_at, url = killed_runs[case]
    with h5py.File(path, "r", swmr=True) as f:  # opens with h5py
        assert f["units/unit1/rate"].attrs["units"] == "deg/s"
    age = last_flush_age_s(path, killed_at)
    assert 0.0 <= age <= 1.0, f"last flush {age:.3f} s before the kill"
    n = check_unit_against_signal(path, "unit1", url)
    assert n >= 500 * KILL_AFTER_S[case] * 0.5  # about 500 Hz since the first flush
    run = read_run(path)  # opening it marks the run interrupted
    assert run.interrupted and run.stop_reason.startswith("interrupted")
    assert run.units[0].record.n_samples == n
    with h5py.File(path, "r", swmr=True) as f:
        written = f["units/unit1/rate"].shape[0]
    print(f"killed {KILL_AFTER_S[case]} s after the first flush: last flush {age:.3f} s "
          f"before the kill, {n} samples intact, {written - n} written after it")


@pytest.mark.parametrize("case", range(len(KILL_AFTER_S)))
def test_recover_closes_the_killed_file_keeping_every_committed_sample(
        killed_runs: list[tuple[Path, float, str]], case: int,
        capsys: pytest.CaptureFixture[str]) -> None:
    path, _, url = killed_runs[case]
    before = read_run(path).units[0].record.n_samples
    with pytest.raises(OSError):
        h5py.File(path, "r")  # left open for write: plain open refuses it
    assert main(["recover", str(path)]) == 0
    assert f"{before} samples kept" in capsys.readouterr().out
    with h5py.File(path, "r") as f:  # now any HDF5 tool opens it
        assert f["units/unit1/rate"].shape[0] == before
        assert f.attrs["stop_reason"].decode() == REASON_RECOVERED
    run = read_run(path)
    assert run.interrupted and run.stop_reason == REASON_RECOVERED
    assert run.units[0].record.n_samples == before
    assert check_unit_against_signal(path, "unit1", url) == before
    assert main(["recover", str(path)]) == 0
    assert "nothing to do" in capsys.readouterr().out
