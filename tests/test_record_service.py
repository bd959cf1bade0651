"""The record service as the TUI uses it: a detached recorder's refusal read from its
status document, unit by unit (the unit check: tests/test_tui.py's set-up screen)."""

from __future__ import annotations

from pathlib import Path

import pytest

from devices.protocols import DeviceDescription
from station.errors import Problem
from station.services.record import RecorderStatus, RecordRequest, read_status, write_status
from station.services.recorder_process import (
    RecorderStartError,
    start_recording,
    wait_for_run_file,
)

BAD = "sim+serial://VG951?protocol=stim300&rate=10&dorp=0.1"


def test_status_document_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "r.status.json"
    assert read_status(path) is None
    status = RecorderStatus("refused", problems=(Problem("no sample", "unit2", "sim+can://X"),
                                                 Problem("disk full")))
    checked = RecorderStatus("checked", units=(DeviceDescription(
        "VG951", "SIM-1", "stim300", "serial", ("x", "y", "z"), 10.0, True, 256, False, True,
        settings=(("port", "/dev/pts/3"),)),))
    write_status(path, checked)
    assert read_status(path) == checked
    write_status(path, status)
    assert read_status(path) == status and not list(tmp_path.glob(".*tmp"))


@pytest.mark.slow
def test_a_detached_recorder_says_why_it_refused_the_run(tmp_path: Path) -> None:
    process = start_recording(RecordRequest((BAD,), "1min", tmp_path / "runs"))
    with pytest.raises(RecorderStartError) as refused:
        wait_for_run_file(process, timeout_s=60)
    problems = refused.value.problems
    assert [(p.unit_id, p.url) for p in problems] == [("unit1", BAD)]
    assert problems[0].text.startswith("bad device URL: unknown URL key 'dorp'")
    assert process.popen is not None and process.popen.wait(10) == 2
    assert not process.path.exists()
