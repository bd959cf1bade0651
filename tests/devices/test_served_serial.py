"""A served serial gyro records through the URL ``station devices serve`` prints.

For every serial protocol: ``station devices serve 'sim+serial://...'`` runs in a process
of its own, as a user runs it; the record service records the plain ``serial://`` URL it
printed (hardware to this process: a profile, no simulator). The samples must arrive,
counter after counter with none declared missing (the served gyro runs without faults),
and the server's ledger must say it delivered them: none lost on its side. At 10 Hz
a frame is sent a whole period after its sample fell due, which the simulator once took
for lateness and booked every frame lost (issue 29, item 7).
"""

from __future__ import annotations

import json
import signal
from pathlib import Path

import pytest

from devices.serial_codecs import SERIAL_PROTOCOLS
from station.services.record import RecordRequest, record
from station.storage.hdf5 import open_run_file, read_unit
from tests.devices.helpers import serve


@pytest.mark.parametrize("protocol", SERIAL_PROTOCOLS)
@pytest.mark.slow
def test_a_served_serial_gyro_records_through_its_printed_url(tmp_path: Path,
                                                              protocol: str) -> None:
    rate = 10  # the profile's (VG951)
    proc, info = serve(f"sim+serial://VG951?protocol={protocol}&rate={rate}&seed=3", 60)
    try:
        url = str(info["url"])
        assert url.startswith("serial://") and f"protocol={protocol}" in url
        outcome = record(RecordRequest(units=(url,), duration="2s", out=tmp_path,
                                       profile="VG951"))
        (unit,) = outcome.units
        assert outcome.exit_status == 0, outcome.unit_errors
        assert unit.samples_sent is None  # hardware to the recorder
        assert unit.samples_recorded >= rate  # at least half the 2 s arrived
        # a loaded host may lose a sample on the server's side: every loss is declared
        # (recorded + declared spans the counter), none invented, at most a quarter lost
        with open_run_file(outcome.path) as f:
            counter = read_unit(f, "unit1").counter
        assert len(counter) == unit.samples_recorded
        declared = unit.samples_missing_declared
        assert unit.samples_missing_low <= declared <= unit.samples_missing_high
        assert int(counter[-1] - counter[0]) + 1 == len(counter) + declared, unit
        assert declared <= 0.25 * (len(counter) + declared), unit
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=30)
        assert proc.returncode == 0, err
        ledger = json.loads(out.strip().splitlines()[-1])["ledger"]
        assert ledger["dropped"] == 0, ledger  # no fault injected: only the host may lose
        assert ledger["generated"] >= ledger["delivered"] >= unit.samples_recorded, ledger
    finally:
        proc.kill()
        proc.communicate()
