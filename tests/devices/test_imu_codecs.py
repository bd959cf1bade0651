"""IMU accelerometers in the serial codecs: golden bytes, hypothesis round trips and fuzz,
and simulated STIM300, KVH 1750 and Xbus units that deliver gravity on z over their ptys."""

from __future__ import annotations

import struct
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from analysis.errors import ModelError
from analysis.models.accel_noise import AccelNoiseModel, gravity_by_axis
from analysis.units.conversions import STANDARD_GRAVITY_M_S2 as G
from analysis.units.earth import parse_orientation
from devices.codecs.base import Reading
from devices.codecs.crc import crc32_mpeg2
from devices.codecs.kvh1750 import Kvh1750Codec
from devices.codecs.stim300 import Stim300Codec
from devices.codecs.xbus import ACCELERATION, XbusCodec, XbusMessage, parse_mtdata2
from devices.errors import CodecError, DeviceConfigurationError, FrameError
from devices.urls import open_device
from tests.devices.test_codecs_serial import stim_frames

FUZZ = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def test_stim300_golden_accelerometer_datagram() -> None:
    """0x91 (rate + acc) built by hand: acc words of 2**19 LSB per g at +-10 g."""
    body = (bytes([0x91]) + (2**14).to_bytes(3, "big", signed=True) + bytes(6) + b"\x00"
            + (2**19).to_bytes(3, "big", signed=True) + (-(2**18)).to_bytes(3, "big", signed=True)
            + (2**20).to_bytes(3, "big", signed=True) + b"\x02"
            + bytes([9]) + (77).to_bytes(2, "big"))
    wire = body + crc32_mpeg2(body + b"\x00" * (-len(body) % 4)).to_bytes(4, "big")
    codec = Stim300Codec(0x91)
    (frame,) = codec.decode(wire).frames
    reading = codec.to_reading(frame)
    assert reading.accel_m_s2 == pytest.approx((G, -G / 2, 2 * G), rel=1e-15)
    assert reading.status == 0x0200 and reading.counter == 9  # accel status in bits 8-15
    assert codec.encode(frame) == wire
    # the same words read by a +-80 g unit: 2**16 LSB per g
    assert Stim300Codec(0x91, accel_range_g=80).to_reading(frame).accel_m_s2 == \
        pytest.approx((8 * G, -4 * G, 16 * G))


def test_stim300_accelerometer_scale_reads_a_unit_at_rest_as_1_g() -> None:
    """Provenance: a public STIM300 reader (geirhovland/stim300, README) printed a +-10 g
    unit at rest as Acc X, Y, Z = -0.011890411376953125, -0.016986846923828125,
    1.0138282775878906 g with words / 2**19: the words -6234, -8906, 531538. At 2**-20 g
    per LSB they would read 0.51 g on the vertical."""
    words = (-6234, -8906, 531538)
    body = (bytes([0x91]) + bytes(9) + b"\x00" + b"".join(w.to_bytes(3, "big", signed=True)
                                                          for w in words) + b"\x00"
            + bytes([1]) + (500).to_bytes(2, "big"))
    wire = body + crc32_mpeg2(body + b"\x00" * (-len(body) % 4)).to_bytes(4, "big")
    codec = Stim300Codec(0x91)
    (frame,) = codec.decode(wire).frames
    accel_g = np.array(codec.to_reading(frame).accel_m_s2) / G
    np.testing.assert_allclose(accel_g, (-0.011890411376953125, -0.016986846923828125,
                                         1.0138282775878906), rtol=1e-15)


@pytest.mark.parametrize("ident", [0x91, 0x93, 0xA5, 0xA7])
@FUZZ
@given(data=st.data())
def test_stim300_accelerometer_datagrams_round_trip(ident: int, data: st.DataObject) -> None:
    codec = Stim300Codec(ident)
    frame = data.draw(stim_frames(codec))
    (back,) = codec.decode(codec.encode(frame)).frames
    assert back == frame
    reading = codec.to_reading(frame)
    assert reading.accel_m_s2 is not None and len(reading.accel_m_s2) == 3
    # a reading inside the range survives the quantization to its LSB (2**-19 g)
    accel = tuple(data.draw(st.floats(-9.9 * G, 9.9 * G)) for _ in range(3))
    sent = Reading((0.5, -0.25, 0.0), 7, 0, None, 24.0, accel)
    got = codec.to_reading(codec.decode(codec.encode(codec.from_reading(sent))).frames[0])
    assert got.accel_m_s2 == pytest.approx(accel, abs=G * 2**-19)
    assert got.rate_deg_s == sent.rate_deg_s


@FUZZ
@given(st.binary(max_size=200))
def test_stim300_accelerometer_decoder_never_raises(data: bytes) -> None:
    codec = Stim300Codec(0xA7, accel_range_g=30)
    for frame in codec.decode(data).frames:
        assert codec.to_reading(frame).accel_m_s2 is not None


def test_gyro_only_datagrams_keep_decoding_without_accelerations() -> None:
    codec = Stim300Codec(0x94)
    reading = Reading((1.0, 2.0, 3.0), 5, 0, None, 25.0, (0.0, 0.0, G))
    got = codec.to_reading(codec.decode(codec.encode(codec.from_reading(reading))).frames[0])
    assert got.accel_m_s2 is None and got.rate_deg_s == (1.0, 2.0, 3.0)
    assert codec.n_accel_axes == 0 and codec.accel_range_m_s2 is None
    assert Stim300Codec(0xA5, accel=False).to_reading(
        Stim300Codec(0xA5).from_reading(reading)).accel_m_s2 is None
    with pytest.raises(CodecError, match="carries no accelerometers"):
        Stim300Codec(0x94, accel=True)
    with pytest.raises(CodecError, match="10, 30 or 80"):
        Stim300Codec(0xA5, accel_range_g=20)


def test_kvh1750_accelerations_in_g_become_m_s2() -> None:
    body = struct.pack(">4s6fBBh", bytes.fromhex("FE81FF55"), 0, 0, 0, 0.5, -1.0, 1.0,
                       0x77, 3, 30)
    wire = body + crc32_mpeg2(body).to_bytes(4, "big")
    (frame,) = Kvh1750Codec().decode(wire).frames
    assert Kvh1750Codec().to_reading(frame).accel_m_s2 == (0.5 * G, -G, G)
    assert Kvh1750Codec(accel=False).to_reading(frame).accel_m_s2 is None


@FUZZ
@given(st.tuples(*[st.floats(-98.0, 98.0, width=32)] * 3))
def test_kvh1750_acceleration_round_trip(accel: tuple[float, float, float]) -> None:
    codec = Kvh1750Codec()
    sent = Reading((0.1, 0.2, 0.3), 9, 0, None, 25.0, accel)
    got = codec.to_reading(codec.decode(codec.encode(codec.from_reading(sent))).frames[0])
    assert got.accel_m_s2 == pytest.approx(accel, rel=1e-6, abs=1e-30)


@FUZZ
@given(st.tuples(*[st.floats(-156.0, 156.0, width=32)] * 3))
def test_xbus_acceleration_item_round_trip(accel: tuple[float, float, float]) -> None:
    codec = XbusCodec(accel=True)
    message = codec.from_reading(Reading((1.0, 0.0, 0.0), 3, 0, 0.5, 25.0, accel))
    (back,) = codec.decode(codec.encode(message)).frames
    assert struct.unpack(">3f", parse_mtdata2(back.data)[ACCELERATION]) == accel
    got = codec.to_reading(back)
    assert got is not None and got.accel_m_s2 == accel


def test_xbus_without_acceleration_item() -> None:
    gyro_only = XbusCodec(accel=False).from_reading(Reading((1.0, 0.0, 0.0), 3))
    assert ACCELERATION not in parse_mtdata2(gyro_only.data)
    with pytest.raises(FrameError, match="usable item"):
        XbusCodec(accel=True).to_reading(gyro_only)  # an MTi configured without it: accel=0
    got = XbusCodec(accel=False).to_reading(XbusMessage(gyro_only.mid, gyro_only.data))
    assert got is not None and got.accel_m_s2 is None


def test_accelerometer_model_table_and_gravity_from_the_bench() -> None:
    model = AccelNoiseModel.from_table({"vrw_m_s_rt_h": 0.07, "bias_instability_ug": 50})
    assert model.as_noise_model().term_names == ("arw", "bias_instability")
    with pytest.raises(ModelError, match="unknown key"):
        AccelNoiseModel.from_table({"vrw": 1.0})
    with pytest.raises(ModelError, match=">= 0"):
        AccelNoiseModel(vrw_m_s_rt_h=-1.0)
    g = gravity_by_axis(parse_orientation("x:up,y:north,z:east"), ("x", "y", "z"))
    np.testing.assert_allclose(g, [G, 0.0, 0.0], atol=1e-12)


def _read_for(url: str, seconds: float) -> tuple[np.ndarray | None, tuple[str, ...], int]:
    device = open_device(url)
    try:
        device.source.open()
        batches = []
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            batch = device.source.read(0.1)
            if len(batch):
                batches.append(batch)
    finally:
        device.close()
    accel = [b.accel_m_s2 for b in batches]
    n = sum(len(b) for b in batches)
    if any(a is None for a in accel):
        assert all(a is None for a in accel)
        return None, device.source.describe().accel_axes, n
    return np.concatenate(accel), device.source.describe().accel_axes, n


@pytest.mark.parametrize("url", [
    "sim+serial://STIM300?protocol=stim300&datagram=0xA5&rate=500&warp=4&seed=3",
    "sim+serial://DSP-1750?protocol=kvh1750&rate=500&warp=4&seed=3",
    "sim+serial://MTI-630?protocol=xbus&rate=200&warp=4&seed=3",
])
def test_a_simulated_imu_delivers_gravity_on_z_within_its_noise(url: str) -> None:
    accel, axes, n = _read_for(url, 0.8)
    assert axes == ("accel_x", "accel_y", "accel_z") and accel is not None and accel.shape == (n, 3)
    assert n > 200
    mean, std = accel.mean(axis=0), accel.std(axis=0)
    # white noise of 0.035..0.07 m/s/sqrt(h) at 200..500 Hz: std 0.008..0.03 m/s^2
    assert np.all((std > 0.003) & (std < 0.06)), std
    assert abs(mean[2] - G) < 5 * std[2] / np.sqrt(n) + 0.01
    assert np.all(np.abs(mean[:2]) < 5 * std[:2] / np.sqrt(n) + 0.01)


def test_bench_orientation_and_the_accel_switch() -> None:
    base = "sim+serial://STIM300?protocol=stim300&datagram=0xA5&rate=500&warp=4&seed=4"
    accel, _, _ = _read_for(base + "&latitude=45&orientation=x:up,y:north,z:east", 0.5)
    assert accel is not None and abs(accel[:, 0].mean() - G) < 0.02
    assert abs(accel[:, 2].mean()) < 0.02
    off, axes, n = _read_for(base + "&accel=0", 0.3)
    assert off is None and axes == () and n > 50
    with pytest.raises(DeviceConfigurationError, match="carries no accelerometers"):
        open_device("sim+serial://STIM300?protocol=stim300&datagram=0x94&accel=1")
    with pytest.raises(DeviceConfigurationError, match="0 or 1"):
        open_device("sim+serial://STIM300?protocol=kvh1750&accel=yes")
