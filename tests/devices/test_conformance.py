"""One conformance test over every supported adapter and transport (PyMeasure's
``test_all_instruments`` pattern), driven by the list ``station devices --json`` prints.

For each protocol's simulated device URL: the adapter satisfies :class:`RateSource`,
``describe()`` matches what ``read()`` returns (axes, optional channels, counter wrap),
units are present, and the measured sample rate is the nominal one.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from devices.protocols import DeviceDescription, RateSource
from devices.urls import SUPPORTED, open_device
from station.cli import main
from tests.devices.helpers import collect


def test_station_devices_json_lists_every_protocol(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["devices", "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    keys = {"protocol", "transport", "sim_url", "hardware_url"}
    assert [set(d) for d in listed] == [keys] * len(SUPPORTED)
    assert {d["protocol"] for d in listed} == {p.protocol for p in SUPPORTED}
    assert all(d["sim_url"].startswith("sim+") for d in listed)


@pytest.mark.parametrize("supported", SUPPORTED, ids=lambda p: f"{p.protocol}-{p.transport}")
def test_adapter_conformance(supported) -> None:
    with open_device(supported.sim_url) as dev:
        source = dev.source
        assert isinstance(source, RateSource)
        source.open()
        desc = source.describe()
        assert isinstance(desc, DeviceDescription)
        assert (desc.protocol, desc.transport) == (supported.protocol, supported.transport)
        assert (desc.rate_unit, desc.temperature_unit, desc.time_unit) == ("deg/s", "degC", "s")
        assert desc.n_axes == 3 and desc.sample_rate_hz > 0 and desc.settings
        got = collect(source, int(desc.sample_rate_hz * 2.0))
        for batch in got.batches:
            assert batch.rate_deg_s.shape == (len(batch), desc.n_axes)
            assert batch.rate_deg_s.dtype == np.float64 and batch.counter.dtype == np.int64
            assert batch.status.shape == batch.receive_time_s.shape == (len(batch),)
            assert (batch.temperature_c is not None) == desc.has_temperature
            assert (batch.device_time_s is not None) == desc.has_device_time
            assert dict(batch.units)["rate_deg_s"] == "deg/s"
        counter, t = got.counter, got.column("receive_time_s")
        assert desc.has_counter and np.all(np.diff(counter) >= 1)
        assert np.all(np.diff(t) >= 0)
        # The nominal rate is the simulator's; the rate seen through the transport is
        # that within what a loaded host's scheduling lets through.
        assert dev.simulator.core.sample_rate_hz == desc.sample_rate_hz
        late = t > t[0] + 0.5  # past what a port buffered before it was opened
        measured_hz = np.polyfit(t[late], counter[late], 1)[0]
        assert measured_hz == pytest.approx(desc.sample_rate_hz, rel=0.5)
        assert np.all(np.abs(got.rate) < 10.0)  # a static gyro: bias and noise only
        source.close()
        source.close()  # idempotent
