"""Opt-in checks against a real gyro: ``pytest tests/devices --hardware-port /dev/ttyUSB0
--hardware-protocol stim300 --hardware-baud 921600``. Skipped without ``--hardware-port``."""

from __future__ import annotations

import numpy as np

from devices.urls import open_device
from tests.devices.helpers import collect


def test_real_serial_gyro_streams_continuous_samples(hardware: tuple[str, str, int]) -> None:
    port, protocol, baud = hardware
    with open_device(f"serial://{port}?protocol={protocol}&baud={baud}") as dev:
        dev.source.open()
        got = collect(dev.source, 2000, deadline_s=10)
        desc = dev.source.describe()
        assert got.rate.shape[1] == desc.n_axes
        assert got.crc_errors == 0 and got.gaps == []
        assert np.all(np.diff(got.counter) == 1)
