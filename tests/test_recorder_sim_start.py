"""A simulated unit's run starts with its first sample: no leading gap.

The recorder opens its simulated units held (``open_device(url, held=True)``): the
simulated device samples nothing until the run starts, so its first sample (counter 0)
falls due at the start and ``sent`` counts the run's samples only. Held only once open,
a raw-CAN node had sent one or two samples before the hold (declared "missing 1-2 in
1 gap" at the start of every run), and a Modbus gyro or a serial unit at 1 kHz a few to
16.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from devices.opened import SimulatedDevice
from devices.urls import open_device
from station.model.profiles import load_profile
from station.recording.recorder import Recorder, RunConfig
from station.storage.hdf5 import open_run_file, read_unit
from tests.devices.helpers import multicast_unavailable

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


@pytest.mark.slow
def test_simulated_can_and_modbus_runs_start_without_a_gap(tmp_path) -> None:
    """Two raw-CAN units (both frame layouts) record 2 s with nothing missing: sent ==
    recorded; a Modbus unit samples nothing before the run (it sent the run's 100 samples
    at 50 Hz, not more) and logs no busy answer from the time before it. Its registers are
    polled: on a loaded host the first poll may come after the unit's first sample was
    overwritten (seen once, in CI: "missing 1" before a first sample received 94 ms into
    the run), a leading gap no longer than the samples due by then; mid-run, a gap of its
    own."""
    urls = (*HELD_URLS[:2], HELD_URLS[3])
    recorder = Recorder(RunConfig(urls, 2.0, tmp_path / "r.h5", backoff_max_s=0.1))
    stop = recorder.run()
    can = stop.totals[:2]
    for t in can:
        assert (t.samples_missing_declared, t.gaps) == (0, 0), t
        assert t.samples_sent == t.samples_recorded == 200, t
    modbus = stop.totals[2]
    with open_run_file(recorder.path) as f:
        for t in stop.totals:
            events = read_unit(f, t.unit_id).events
            leading = events[(events["kind"] == b"gap") & (events["after_counter"] < 0)]
            if t is modbus:
                due = leading["time_s"] * 50.0 + 1.0  # samples due by the first one received
                assert np.all(leading["missing_samples"] <= due), (t.url, leading)
            else:
                assert len(leading) == 0, (t.url, leading)
            assert not (events["kind"] == b"timeout").any(), (t.url, events)
    assert modbus.samples_sent == 100, modbus
    assert modbus.samples_recorded + modbus.samples_missing_declared == modbus.samples_sent


@pytest.mark.slow
def test_a_real_can_node_running_before_the_run_starts_it_without_a_gap(tmp_path) -> None:
    """A real node (here a simulated one in its own process, not held, recorded by its
    hardware ``can://`` URL) counted long before the run: its first sample received
    starts the counter tracking, with no gap before it."""
    why = multicast_unavailable()
    if why:
        pytest.skip(f"no udp_multicast bus on this host: {why}")
    with open_device("sim+can://VG951?interface=udp_multicast&rate=100&seed=5") as node:
        assert node.hardware_url is not None
        time.sleep(0.3)  # it sends before the station listens (30 samples)
        assert node.samples_sent() > 0
        recorder = Recorder(RunConfig((node.hardware_url,), 1.0, tmp_path / "r.h5",
                                      profile=load_profile("ADIS16405")))  # (100 Hz, x y z)
        (t,) = recorder.run().totals
        with open_run_file(recorder.path) as f:
            unit = read_unit(f, t.unit_id)
    assert t.samples_sent is None  # hardware: the station does not know what it sent
    assert (t.samples_missing_declared, t.gaps) == (0, 0), t
    assert t.samples_recorded >= 60, t
    assert unit.counter[0] > 0  # (the node's count, not the run's)
