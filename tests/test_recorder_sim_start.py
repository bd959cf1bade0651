"""A simulated unit's run starts with its first sample: no leading gap.

The recorder opens its simulated units held (``open_device(url, held=True)``): the
simulated device samples nothing until the run starts, so its first sample (counter 0)
falls due at the start and ``sent`` counts the run's samples only. Held only once open,
a raw-CAN node had sent one or two samples before the hold (declared "missing 1-2 in
1 gap" at the start of every run), and a Modbus gyro or a serial unit at 1 kHz a few to
16.
"""

from __future__ import annotations

import pytest

from devices.opened import SimulatedDevice
from devices.urls import open_device
from station.recording.recorder import Recorder, RunConfig
from station.storage.hdf5 import open_run_file, read_unit

#: One of each simulated transport the recorder holds (a CAN node in a process of its
#: own is covered by the recordings of tests/devices/test_can_multicast.py).
HELD_URLS = (
    "sim+can://STIM300?rate=100&layout=shared",
    "sim+can://STIM300?rate=100&layout=per_axis",
    "sim+canopen://STIM300/5?rate=100",
    "sim+modbus+tcp://STIM300?rate=50",
    "sim+serial://VG951?rate=100",
)


@pytest.mark.parametrize("url", HELD_URLS)
def test_a_device_opened_held_samples_nothing_until_resumed(url: str) -> None:
    opened = open_device(url, held=True)
    try:
        assert isinstance(opened, SimulatedDevice)
        assert opened.core.held
        opened.source.open()  # (a CANopen node is configured over SDO while held)
        start = opened.clock()
        while opened.clock() - start < 0.1:  # ten sample periods at 100 Hz
            opened.source.read(0.02)
        assert opened.samples_sent() == 0
        opened.resume()
        assert not opened.core.held
    finally:
        opened.close()


def test_a_device_opened_unheld_samples_at_once() -> None:
    opened = open_device("sim+can://STIM300?rate=100")
    try:
        assert isinstance(opened, SimulatedDevice)
        assert not opened.core.held
    finally:
        opened.close()


def test_simulated_can_and_modbus_runs_start_without_a_gap(tmp_path) -> None:
    """Two raw-CAN units (both frame layouts) record 2 s with nothing missing: sent ==
    recorded; a Modbus unit has no gap before its first sample and logs no busy answer
    from the time before it (its polled registers may miss a sample mid-run on a loaded
    host, a gap of its own)."""
    urls = (*HELD_URLS[:2], HELD_URLS[3])
    recorder = Recorder(RunConfig(urls, 2.0, tmp_path / "r.h5", backoff_max_s=0.1))
    stop = recorder.run()
    can = stop.totals[:2]
    for t in can:
        assert (t.samples_missing_declared, t.gaps) == (0, 0), t
        assert t.samples_sent == t.samples_recorded == 200, t
    with open_run_file(recorder.path) as f:
        for t in stop.totals:
            events = read_unit(f, t.unit_id).events
            leading = events[(events["kind"] == b"gap") & (events["after_counter"] < 0)]
            assert len(leading) == 0, (t.url, leading)
            assert not (events["kind"] == b"timeout").any(), (t.url, events)
    modbus = stop.totals[2]
    assert modbus.samples_recorded + modbus.samples_missing_declared == modbus.samples_sent
