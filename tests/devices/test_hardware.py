"""Opt-in checks against a real gyro, any transport::

    pytest tests/devices --hardware-url "can://can0?interface=socketcan&rate=1000"
    pytest tests/devices --hardware-port /dev/ttyUSB0 --hardware-protocol stim300

Skipped without ``--hardware-url`` or ``--hardware-port``. A static gyro on a quiet link
must stream what ``describe()`` says at its nominal rate, with no CRC errors; samples the
host loses (a loaded station drops frames a full socket cannot take) must each be
declared, none invented (the books hold), and few.
"""

from __future__ import annotations

from devices.protocols import RateSource, Simulated
from devices.urls import open_device
from tests.devices.helpers import check_books, check_lost_share, collect


def test_real_gyro_streams_continuous_samples(hardware_url: str, hardware_seconds: float) -> None:
    with open_device(hardware_url) as dev:
        assert not isinstance(dev, Simulated), "pass a hardware URL, not a sim+ URL"
        source = dev.source
        assert isinstance(source, RateSource)
        source.open()
        desc = source.describe()
        n = max(200, int(hardware_seconds * desc.sample_rate_hz))  # 5 s of samples by default
        got = collect(source, n, deadline_s=15)
        assert got.rate.shape[1] == desc.n_axes
        assert got.crc_errors == 0
        check_lost_share(got, check_books(got))
        for batch in got.batches:
            assert (batch.temperature_c is not None) == desc.has_temperature
            assert (batch.device_time_s is not None) == desc.has_device_time
        t = got.column("receive_time_s")
        measured_hz = (got.counter[-1] - got.counter[0]) / (t[-1] - t[0])
        assert abs(measured_hz / desc.sample_rate_hz - 1) < 0.1, measured_hz
