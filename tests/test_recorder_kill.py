"""SIGKILL of a real recorder process, from its first instant on: nothing flushed is lost.

Recorders (one simulated Xsens over a pty, real time) are killed with SIGKILL at moments
drawn from the first second after their run file appears, and later. Then: the file
opens (it exists under its name only once its whole layout is written, in SWMR mode),
the samples lost are those received since the last flush the recorder completed (the
cut its run state records, not a multiple of the flush interval: on a loaded host a flush
comes late, and that is the host's scheduling, printed, not the recorder's bound), every
committed sample
is the simulated signal at its counter with counters and gaps agreeing, opening it
marks the run interrupted, and ``station recover`` closes it so that h5py opens it
without SWMR, keeping every committed sample. ``python benchmarks/bench_reliability.py``
kills many more, at random moments, and reports the largest loss.
"""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from station.cli import main
from station.storage.hdf5 import REASON_RECOVERED, read_run
from tests.test_recorder_helpers import (
    check_unit_against_signal,
    data_lost_s,
    last_flush_age_s,
    start_recorder,
)

#: Seconds after the run file appears at which each recorder is killed: two drawn from
#: the first second (seed 21), one later, past a few flushes.
KILL_AFTER_S = (*(float(t) for t in np.round(np.random.default_rng(21).uniform(0, 1, 2), 3)),
                2.3)
#: Xbus has a 16-bit counter: a loaded machine's stalls cannot alias into counter wraps.
URL = "sim+serial://STIM300?protocol=xbus&rate=500&seed={seed}"
FLUSH_S = 0.5
#: A sample's way from the unit's read to the recorder's engine, s: the unit holds its
#: batches 0.05 s (``ReadSettings.batch_s``) after a read of up to 0.05 s, then the pipe,
#: with room for a loaded host to schedule the two processes.
HANDOVER_S = 0.5


def kill_when_due(runs: list[tuple[object, Path, float]]) -> list[tuple[Path, float]]:
    """Kill each recorder ``(process, folder, seconds)`` that many seconds after its run
    file appears; returns (file, kill time as time.time()) in the order given."""
    appeared: dict[int, tuple[Path, float]] = {}
    killed: dict[int, tuple[Path, float]] = {}
    deadline = time.monotonic() + 180.0
    while len(killed) < len(runs) and time.monotonic() < deadline:
        for i, (proc, folder, after_s) in enumerate(runs):
            if i in killed:
                continue
            if i not in appeared:
                files = list(folder.glob("*.h5"))
                if files:
                    appeared[i] = (files[0], time.monotonic())
                continue
            path, seen = appeared[i]
            if time.monotonic() - seen >= after_s:
                assert proc.poll() is None, proc.communicate()
                os.kill(proc.pid, signal.SIGKILL)
                killed[i] = (path, time.time())
        time.sleep(0.002)
    assert len(killed) == len(runs), "a recorder wrote no run file"
    return [killed[i] for i in range(len(runs))]


@pytest.fixture(scope="module")
def killed_runs(tmp_path_factory: pytest.TempPathFactory) -> list[tuple[Path, float, str]]:
    """Recorders killed at their moments: (file, kill time as time.time(), url)."""
    started = []
    for i, after_s in enumerate(KILL_AFTER_S):
        folder = tmp_path_factory.mktemp(f"kill{i}")
        url = URL.format(seed=10 + i)
        proc = start_recorder("--unit", url, "--duration", "1h", "--out", str(folder),
                              "--quiet", "--flush-interval", str(FLUSH_S))
        started.append((proc, folder, after_s, url))
    try:
        killed = kill_when_due([(p, folder, after) for p, folder, after, _ in started])
    finally:
        for proc, *_ in started:
            if proc.poll() is None:
                proc.kill()
            proc.communicate(timeout=10)
    return [(path, at, url) for (path, at), (*_, url) in zip(killed, started, strict=True)]


@pytest.mark.parametrize("case", range(len(KILL_AFTER_S)))
@pytest.mark.slow
def test_killed_recorder_leaves_a_readable_file_intact_to_its_last_flush(
        killed_runs: list[tuple[Path, float, str]], case: int) -> None:
    path, killed_at, url = killed_runs[case]
    with h5py.File(path, "r", swmr=True) as f:  # opens with h5py, whatever the moment
        assert f["units/unit1/rate"].attrs["units"] == "deg/s"
    run = read_run(path)  # opening it marks the run interrupted
    assert run.interrupted and run.stop_reason.startswith("interrupted")
    n = run.units[0].record.n_samples
    if n:
        assert check_unit_against_signal(path, "unit1", url) == n
    lost = data_lost_s(path, killed_at)
    # the recorder's own record: the cut of its last completed flush (everything it had
    # received before is committed); how long ago that was is the host's scheduling
    since_flush = last_flush_age_s(path, killed_at)
    assert since_flush >= 0.0, "a flush recorded after the kill"
    assert lost <= since_flush + HANDOVER_S, (
        f"{lost:.3f} s of data lost, {since_flush:.3f} s since the last flush's cut")
    print(f"killed {KILL_AFTER_S[case]} s after the file appeared: {n} samples "
          f"intact, {lost:.3f} s of data lost, {since_flush:.3f} s since the last flush "
          f"(flush lag {max(0.0, since_flush - FLUSH_S):.3f} s beyond its interval)")


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
    if before:
        assert check_unit_against_signal(path, "unit1", url) == before
    assert main(["recover", str(path)]) == 0
    assert "nothing to do" in capsys.readouterr().out
