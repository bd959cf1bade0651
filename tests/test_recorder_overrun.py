"""A unit whose process the host starves across the end of its run (issue 29, item 3).

A time-warped simulated unit (x20) is frozen (SIGSTOP: its reader and its simulator) from
three quarters of its run to half its run past its end. A run ends at its duration on the
unit's own time base: the simulator generates no sample due after it, so the record does not run
on by the time the host overran (a 300 s step had run to ~510 s of device time), and the
samples declared missing are the ones it generated and lost while frozen inside the run,
never the ones of the time after it (1257 and 2095 had been declared against 0).
"""

from __future__ import annotations

import os
import signal
import threading
from pathlib import Path

import pytest

from station.recording.recorder import Recorder, RunConfig
from station.storage.hdf5 import read_run
from tests.test_recorder_helpers import assert_books

RATE_HZ = 20.0
WARP = 20.0
DURATION_S = 40.0  # 2 s of wall time
URL = f"sim+serial://MTI-630?protocol=xbus&rate={RATE_HZ:g}&warp={WARP:g}&seed=3"


@pytest.mark.slow
def test_a_unit_starved_past_its_end_records_its_duration_only(tmp_path: Path) -> None:
    """Frozen from 30 s to about 60 s of its clock: the record ends by 40 s, the simulator
    sent no more than 40 s of samples (an overrun into the 20 s frozen past its end would
    add up to 400), and the books balance: what it sent is what was recorded plus what
    was declared missing (at most the 10 s frozen inside the run)."""
    recorder = Recorder(RunConfig((URL,), DURATION_S, tmp_path / "r.h5"))
    recorder.prepare()
    worker = recorder.workers[0]
    assert worker.pid is not None

    def starve() -> None:
        threading.Event().wait(0.75 * DURATION_S / WARP)
        os.kill(worker.pid, signal.SIGSTOP)  # type: ignore[arg-type]
        try:
            threading.Event().wait(1.5)  # 30 s of its clock: 20 s past its end
        finally:
            os.kill(worker.pid, signal.SIGCONT)  # type: ignore[arg-type]

    freezer = threading.Thread(target=starve, daemon=True)
    freezer.start()
    stop = recorder.run()
    freezer.join()
    totals = stop.totals[0]
    unit = read_run(recorder.path).units[0]
    record = unit.record
    assert record.duration_s <= DURATION_S, record.duration_s
    # what the simulator made before the first sample received (it is opened held: only
    # a loaded host starving it right after the start): the leading gap, lost, not frozen
    before = sum(e.missing_samples for e in unit.events
                 if e.kind == "gap" and "before the first sample" in e.detail)
    assert totals.samples_sent is not None
    # its run on its own time line: 40 s of sample periods from its release, however late
    # the host ran it (it made none before: it is opened held)
    assert totals.samples_sent <= DURATION_S * RATE_HZ, (totals, before)
    assert totals.samples_missing_declared - before <= 0.25 * DURATION_S * RATE_HZ + 2, totals
    assert_books(totals.samples_recorded, totals.samples_missing_low,
                 totals.samples_missing_declared, totals.samples_missing_high,
                 totals.samples_sent, totals)
