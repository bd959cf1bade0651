"""Modbus register maps (pure, fuzzed) and a real pymodbus server: TCP on 127.0.0.1 and
RTU on a pty null modem.

Proves that the register codec is an exact inverse both ways for INT32 (ABCD) and
FLOAT32 (CDAB) maps, that a polled gyro returns exactly the generated samples with
counters continuous but for declared polling misses, that an outage of the server is reported,
reconnected and counted,
and that the environment channel (a chamber temperature) reads through the same stack.
"""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from devices.codecs.base import Reading
from devices.codecs.modbus_map import (
    GYRO_FLOAT32_MAP,
    GYRO_INT32_MAP,
    IMU_FLOAT32_MAP,
    IMU_INT32_MAP,
    ModbusRegisterMap,
    RegisterField,
)
from devices.errors import CodecError, FrameError
from devices.modbus import ModbusEnvironmentChannel
from devices.sim.modbus_server import CHAMBER_FIELD
from devices.transports.modbus import ModbusTransport
from devices.urls import open_device
from tests.devices.helpers import check_accounting, collect, device_index

FUZZ = settings(max_examples=100, deadline=None)
MAPS = {"int32": GYRO_INT32_MAP, "float32": GYRO_FLOAT32_MAP, "int32_imu": IMU_INT32_MAP,
        "float32_imu": IMU_FLOAT32_MAP}


def test_word_orders_golden() -> None:
    """1.5 deg/s as FLOAT32 0x3FC00000: ABCD = [0x3FC0, 0x0000], CDAB = [0x0000, 0x3FC0]."""
    assert RegisterField(0, "float32").pack(1.5) == [0x3FC0, 0x0000]
    assert RegisterField(0, "float32", word_order="little").pack(1.5) == [0x0000, 0x3FC0]
    assert RegisterField(0, "int32", 1e-6).pack(-1e-6) == [0xFFFF, 0xFFFF]
    assert RegisterField(0, "int32", 1e-6).unpack([0x0001, 0x0000]) == pytest.approx(0.065536)


@pytest.mark.parametrize("name", MAPS)
def test_registers_decode_then_encode_is_identity(name: str) -> None:
    regs_map = MAPS[name]
    _, count = regs_map.span

    @FUZZ
    @given(st.lists(st.integers(0, 0xFFFF), min_size=count, max_size=count))
    def check(registers: list[int]) -> None:
        reading = regs_map.decode(registers)
        if not all(map(math.isfinite, reading.rate_deg_s + (reading.temperature_c or 0.0,)
                       + (reading.accel_m_s2 or ()))):
            return  # NaN/inf payloads have no unique encoding
        # Registers not covered by a field (gaps in the block) encode as 0.
        covered = {a - regs_map.span[0] for f in regs_map.fields()
                   for a in range(f.address, f.address + f.n_registers)}
        expect = [r if i in covered else 0 for i, r in enumerate(registers)]
        assert regs_map.encode(reading) == expect

    check()


@pytest.mark.parametrize("name", MAPS)
def test_reading_round_trip_to_resolution(name: str) -> None:
    regs_map = MAPS[name]
    rate = st.floats(-2000, 2000)

    @FUZZ
    @given(st.tuples(rate, rate, rate), st.integers(0, 2**40), st.floats(-40, 125))
    def check(rates: tuple, counter: int, temp: float) -> None:
        got = regs_map.decode(regs_map.encode(Reading(rates, counter, temperature_c=temp)))
        assert got.counter == counter % regs_map.counter_modulus
        for g, want, f in zip(got.rate_deg_s, rates, regs_map.axes, strict=True):
            if f.kind == "float32":
                assert g == struct.unpack(">f", struct.pack(">f", want))[0]
            else:
                assert abs(g - want) <= f.scale / 2 + 1e-12

    check()


def test_bad_maps_and_blocks_are_rejected() -> None:
    with pytest.raises(CodecError):
        RegisterField(0, "int64")  # type: ignore[arg-type]
    with pytest.raises(CodecError):
        ModbusRegisterMap.from_table({"axes": [{"address": 0}]})  # no counter
    with pytest.raises(FrameError):
        GYRO_INT32_MAP.decode([0] * 3)
    with pytest.raises(FrameError):
        GYRO_INT32_MAP.decode([70000] * 9)
    table = {"axes": [{"address": 10, "kind": "float32", "word_order": "little"}],
             "counter": {"address": 12, "kind": "uint16"}}
    assert ModbusRegisterMap.from_table(table).span == (10, 3)


@pytest.mark.parametrize(("name", "transport"), [("int32", "tcp"), ("float32", "tcp"),
                                               ("int32", "rtu")])
@pytest.mark.slow
def test_polled_gyro_round_trip(name: str, transport: str) -> None:
    # Polling at 4 x the sample rate: a sample is missed only if a poll is 12 ms late.
    url = f"sim+modbus+{transport}://STIM300?map={name}&rate=20&warp=4&oversample=4&history=100000&seed=8"
    with open_device(url) as dev:
        dev.source.open()
        got = collect(dev.source, 300)
        core = dev.simulator.core
        offset = device_index(got, core, 65536, atol=1e-6)
        # A register holds one sample: a poll later than one period misses the one
        # before (a loaded host does that); it must then be declared, never invented.
        # How many depends on the host's load (none on a quiet one); the accounting
        # and the values may not. 300 samples (3.75 s): one 0.25 s pause of a shared
        # host (20 samples) is not a quarter of them, as it was of 100 in CI.
        declared, _ = check_accounting(got, core, offset)
        assert len(declared) <= 0.25 * len(got.counter)
        atol, rtol = (0.5e-6, 0.0) if name == "int32" else (0.0, 1e-7)
        np.testing.assert_allclose(got.rate, core.history(got.counter + offset),
                                   atol=atol + 1e-12, rtol=rtol)
        np.testing.assert_allclose(got.column("temperature_c"), 25.0, atol=0.01)
        assert dev.source.describe().transport == f"modbus+{transport}"


@pytest.mark.parametrize("transport", ["tcp", "rtu"])
@pytest.mark.slow
def test_server_outage_is_reported_reconnected_and_counted(transport: str) -> None:
    url = (f"sim+modbus+{transport}://STIM300?rate=20&warp=10&history=100000&seed=9&drop=0.05"
           "&disconnect_every_s=4&disconnect_for_s=3")
    with open_device(url) as dev:
        dev.source.open()
        got = collect(dev.source, 130, deadline_s=30)
        core = dev.simulator.core
        offset = device_index(got, core, 65536, atol=1e-6)
        declared, lost = check_accounting(got, core, offset)
        assert len(lost) >= 40  # 3 s at 20 Hz, minus what the last poll caught
        assert got.disconnects >= 1
        kinds = got.event_kinds()
        assert {"disconnect", "reconnect", "timeout"} <= set(kinds)  # timeout: DEVICE_BUSY


def test_environment_channel_reads_chamber_temperature() -> None:
    with open_device("sim+modbus+tcp://STIM300?rate=20&warp=10&history=100000&seed=1") as dev:
        server = dev.simulator
        channel = ModbusEnvironmentChannel(
            ModbusTransport("tcp", "127.0.0.1", port=server.port), CHAMBER_FIELD,
            device_id=server.env_device_id, clock=server.core.clock)
        channel.open()
        try:
            t1, v1 = channel.read()
            t2, v2 = channel.read()
        finally:
            channel.close()
        assert 23.0 <= v1 <= v2 < 23.0 + 0.01 * (t2 + 1.0)
        assert (channel.name, channel.unit) == ("chamber", "degC")
