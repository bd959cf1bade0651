"""IMUs on the buses: a simulated raw-CAN, CANopen and Modbus IMU read through its adapter
returns the accelerations the simulator generated, sample by sample, to the layout's or
the register map's resolution; ``accel=0`` reads the same unit as a gyro; ``accel=1``
with a layout that carries no accelerometers is refused in one line."""

from __future__ import annotations

import numpy as np
import pytest

from devices.codecs.base import Reading
from devices.codecs.can_frame import SHARED_ACCEL_LSB_M_S2, SHARED_IMU_LAYOUT
from devices.codecs.modbus_map import IMU_FLOAT32_MAP, IMU_INT32_MAP
from devices.errors import DeviceConfigurationError
from devices.protocols import ACCEL_AXIS_NAMES
from devices.urls import open_device
from tests.devices.helpers import collect, device_index

G = 9.80665


def _accelerations(url: str, modulus: int, n: int, rate_atol: float) -> tuple[np.ndarray,
                                                                                np.ndarray]:
    """(accelerations read, the simulator's accelerations of the same samples), m/s^2."""
    with open_device(url) as dev:
        dev.source.open()
        assert dev.source.describe().accel_axes == ACCEL_AXIS_NAMES
        got = collect(dev.source, n)
        core = dev.simulator.core
        offset = device_index(got, core, modulus, atol=rate_atol)
        return got.column("accel_m_s2"), core.accel_history(got.counter + offset)


@pytest.mark.parametrize(("layout", "modulus", "half_lsb"), [
    ("shared_imu", 256, SHARED_ACCEL_LSB_M_S2 / 2), ("per_axis_imu", 15, 0.5e-6)])
def test_raw_can_imu_sends_the_generated_accelerations(layout: str, modulus: int,
                                                        half_lsb: float) -> None:
    got, sent = _accelerations(
        f"sim+can://STIM300?layout={layout}&rate=200&warp=2&history=100000&seed=3",
        modulus, 300, rate_atol=1e-4)
    np.testing.assert_allclose(got, sent, atol=half_lsb + 1e-12, rtol=0)
    assert got[:, 2].mean() == pytest.approx(G, abs=0.05)  # gravity on z


@pytest.mark.parametrize("name", ["int32_imu", "float32_imu"])
def test_modbus_imu_sends_the_generated_accelerations(name: str) -> None:
    got, sent = _accelerations(
        f"sim+modbus+tcp://STIM300?map={name}&rate=20&warp=4&oversample=4&history=100000"
        f"&seed=8", 65536, 60, rate_atol=1e-6)
    atol, rtol = (0.5e-6, 0.0) if name == "int32_imu" else (0.0, 1e-7)
    np.testing.assert_allclose(got, sent, atol=atol + 1e-12, rtol=rtol)


def test_accel_0_reads_an_imu_as_a_gyro_and_accel_1_needs_accelerometers() -> None:
    with open_device("sim+can://STIM300?layout=shared_imu&accel=0&rate=200&seed=1") as dev:
        dev.source.open()
        assert dev.source.describe().accel_axes == ()
        assert collect(dev.source, 20).batches[0].accel_m_s2 is None
    for url in ("sim+can://STIM300?layout=shared&accel=1",
                "sim+modbus+tcp://STIM300?map=int32&accel=1"):
        with pytest.raises(DeviceConfigurationError, match="accel=1: .* carries no accel"):
            open_device(url)


def test_layouts_and_maps_round_trip_an_imu_reading() -> None:
    reading = Reading((0.01, -0.02, 0.03), 7, temperature_c=25.0,
                      accel_m_s2=(0.125, -0.5, G))
    frames = [SHARED_IMU_LAYOUT.decode(f.arbitration_id, SHARED_IMU_LAYOUT.encode(f))
              for f in SHARED_IMU_LAYOUT.from_reading(reading)]
    back = SHARED_IMU_LAYOUT.to_reading({f.arbitration_id: f for f in frames})
    assert [f.arbitration_id for f in frames] == [0x180, 0x280]
    np.testing.assert_allclose(back.accel_m_s2, reading.accel_m_s2,
                               atol=SHARED_ACCEL_LSB_M_S2 / 2)
    for regs in (IMU_INT32_MAP, IMU_FLOAT32_MAP):
        decoded = regs.decode(regs.encode(reading))
        np.testing.assert_allclose(decoded.accel_m_s2, reading.accel_m_s2, atol=1e-6)
        assert regs.without_accel().decode(regs.encode(reading)).accel_m_s2 is None


@pytest.mark.parametrize("tpdo", ["event", "sync"])
def test_canopen_imu_maps_tpdo3_and_4_and_sends_the_generated_accelerations(tpdo: str
                                                                            ) -> None:
    got, sent = _accelerations(
        f"sim+canopen://STIM300/5?accel=1&tpdo={tpdo}&rate=50&warp=2&history=100000&seed=4",
        65536, 100, rate_atol=1e-6)
    np.testing.assert_allclose(got, sent, atol=0.5e-6 + 1e-12, rtol=0)  # 0x200A: 1e-6 m/s^2
    assert got[:, 2].mean() == pytest.approx(G, abs=0.05)
