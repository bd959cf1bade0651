"""Raw CAN frame layouts: AUTOSAR E2E Profile 1 CRC and counters, signals with scale and
offset, status fields, fuzzed with hypothesis (Profile 1's reference frames:
test_can_e2e_p01.py; the user-written layout file: test_can_layout_file.py)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from devices.codecs.base import Reading
from devices.codecs.can_frame import (
    PER_AXIS_IMU_LAYOUT,
    PER_AXIS_LAYOUT,
    SHARED_IMU_LAYOUT,
    SHARED_LAYOUT,
    CanBitField,
    CanFrameLayout,
    CanFrameValues,
    CanSignal,
)
from devices.errors import CodecError, CrcError, FrameError
from devices.sim.signal import SignalSource
from tests.devices.e2e_reference import p01_reference_crc

FUZZ = settings(max_examples=100, deadline=None)
#: A unit with no CRC and no counter: offset-binary rates, status nibbles.
UNPROTECTED = CanFrameLayout(
    axes=tuple(CanSignal(0x300 + i, 0, 2, signed=False, byte_order="little", scale=0.005,
                         offset=-163.84) for i in range(3)),
    status=tuple(CanBitField(0x300 + i, 20, 4, invalid_mask=0x7) for i in range(3)),
    crc="none", counter_bits=0)
LAYOUTS = {"shared": SHARED_LAYOUT, "per_axis": PER_AXIS_LAYOUT,
           "shared_imu": SHARED_IMU_LAYOUT, "per_axis_imu": PER_AXIS_IMU_LAYOUT,
           "unprotected": UNPROTECTED}


def frame_values(layout: CanFrameLayout) -> st.SearchStrategy[CanFrameValues]:
    def build(aid: int, counter: int, data: st.DataObject) -> CanFrameValues:
        raw = []
        for name, item in layout.fields().items():
            if item.arbitration_id == aid:
                lo, hi = (item.raw_range() if isinstance(item, CanSignal)
                          else (0, item.mask))
                raw.append((name, data.draw(st.integers(lo, hi))))
        return CanFrameValues(aid, counter, tuple(raw))

    return st.builds(build, st.sampled_from(layout.arbitration_ids),
                     st.integers(0, layout.counter_modulus - 1), st.data())


def test_shared_layout_golden() -> None:
    """2^-13 deg/s per LSB: X = +1 deg/s (0x2000), Y = -0.5 (0xF000), Z = 0.25 (0x0800)."""
    data = SHARED_LAYOUT.encode(CanFrameValues(0x180, 44, (("axis0", 8192), ("axis1", -4096),
                                                           ("axis2", 2048))))
    assert data[1:7] == bytes.fromhex("2000F0000800") and data[7] == 44
    # the Profile 1 CRC from its definition: DataID 0x0180 low byte first, then bytes 1-7
    assert data[0] == p01_reference_crc(bytes([0x80, 0x01]) + data[1:])
    reading = SHARED_LAYOUT.to_reading({0x180: SHARED_LAYOUT.decode(0x180, data)})
    assert reading.rate_deg_s == (1.0, -0.5, 0.25) and reading.counter == 44


@pytest.mark.parametrize("name", LAYOUTS)
def test_round_trip_and_bit_flips(name: str) -> None:
    layout = LAYOUTS[name]

    @FUZZ
    @given(frame_values(layout), st.integers(0, 63))
    def check(values: CanFrameValues, bit: int) -> None:
        data = layout.encode(values)
        assert layout.decode(values.arbitration_id, data) == values
        if layout.crc == "none":
            return  # (nothing to see a flipped bit by)
        flipped = bytearray(data)
        flipped[bit // 8] ^= 1 << (bit % 8)
        with pytest.raises(CrcError):
            layout.decode(values.arbitration_id, bytes(flipped))

    check()


@pytest.mark.parametrize("name", LAYOUTS)
def test_random_frames_raise_only_codec_errors(name: str) -> None:
    layout = LAYOUTS[name]

    @FUZZ
    @given(st.integers(0, 0x7FF) | st.sampled_from(layout.arbitration_ids),
           st.binary(max_size=8))
    def check(aid: int, data: bytes) -> None:
        try:
            values = layout.decode(aid, data)
        except (CrcError, FrameError):
            return
        assert layout.decode(aid, layout.encode(values)) == values
        if layout.crc != "none":  # accepted only with a valid CRC (bits no field uses
            # may hold anything: the CRC covers them, nothing reads them)
            i = layout.crc_byte
            assert data[i] == p01_reference_crc(
                layout.data_id.to_bytes(2, "little") + data[:i] + data[i + 1:])

    check()


@pytest.mark.parametrize("name", LAYOUTS)
def test_reading_round_trip_to_resolution(name: str) -> None:
    layout = LAYOUTS[name]
    # within every axis' range (the shared layout's int16 at 2^-13 deg/s: +-4 deg/s)
    limit = min(100.0, *(s.symmetric_range() for s in layout.axes))
    rate = st.floats(-limit, limit)

    @FUZZ
    @given(st.tuples(rate, rate, rate), st.integers(0, 10_000), st.floats(-40, 85))
    def check(rates: tuple, counter: int, temp: float) -> None:
        frames = layout.from_reading(Reading(rates, counter, temperature_c=temp))
        decoded = {f.arbitration_id: layout.decode(f.arbitration_id, layout.encode(f))
                   for f in frames}
        reading = layout.to_reading(decoded)
        assert reading.counter == counter % layout.counter_modulus
        for got, want, sig in zip(reading.rate_deg_s, rates, layout.axes, strict=True):
            assert abs(got - want) <= sig.scale / 2 + 1e-12
        if layout.temperature is not None:
            assert abs(reading.temperature_c - temp) <= layout.temperature.scale / 2 + 1e-9

    check()


def test_layout_from_profile_table_and_rejections() -> None:
    table = {"counter_byte": 6, "counter_bits": 4, "crc_byte": 7, "data_id": 0x10,
             "axes": [{"arbitration_id": 0x200, "start_byte": 0, "length": 3, "signed": True,
                       "byte_order": "little", "scale": 1e-4}]}
    layout = CanFrameLayout.from_table(table)
    assert layout.axes == (CanSignal(0x200, 0, 3, True, "little", 1e-4),)
    assert layout.counter_modulus == 15 and layout.is_e2e_p01  # a 4-bit counter: Profile 1's
    assert CanFrameLayout.from_table({**table, "counter_modulus": 16}).counter_modulus == 16
    bad = [
        {"axes": [{"arbitration_id": 1, "start_byte": 6, "length": 2}]},  # on the counter
        {"axes": [{"bogus": 1}]},
        {**table, "crc_bytes": 7},  # a typo
        {**table, "counter_modulus": 17},  # more than 4 bits hold
        {**table, "counter_bits": 0, "counter_modulus": 15},
        {**table, "data_id": "0x10"},
        {**table, "crc": "crc16"},
        {**table, "status": [{"arbitration_id": 0x200, "start_bit": 50, "bits": 4}]},  # counter
        {**table, "status": [{"arbitration_id": 0x200, "start_bit": 20, "bits": 4}]},  # axis
        {**table, "axes": [{**table["axes"][0], "byte_order": "middle"}]},
        {**table, "axes": [{**table["axes"][0], "scale": 0}]},
    ]
    for t in bad:
        with pytest.raises(CodecError):
            CanFrameLayout.from_table(t)
    with pytest.raises(FrameError):
        layout.decode(0x201, bytes(8))


def test_a_signal_with_an_offset() -> None:
    """The Bosch MM7.10's rate: uint16 little-endian x 0.005 - 163.84 deg/s (raw 0x8000 is
    0 deg/s, 0 the bottom of the range, 0xFFFF 163.835 deg/s)."""
    sig = UNPROTECTED.axes[0]
    assert [sig.physical(r) for r in (0, 0x8000, 0xFFFF)] == pytest.approx(
        [-163.84, 0.0, 163.835], abs=1e-9)
    assert sig.quantize(1.0) == 0x8000 + 200 and sig.quantize(-500.0) == 0
    data = UNPROTECTED.encode(CanFrameValues(0x300, 0, (("axis0", 0x80C8), ("status0", 0))))
    assert data[:2] == bytes((0xC8, 0x80))
    assert UNPROTECTED.accel_range_m_s2 is None
    assert sig.symmetric_range() == pytest.approx(163.835)


def test_status_fields_make_device_status_and_status() -> None:
    """Each status field sits in its frame's bits, side by side in ``device_status`` (the
    first in the low bits); ``status`` keeps only the bits that flag a sample not valid
    (here bit 3 of each nibble does not)."""
    reading = Reading((0.0, 0.0, 0.0), 0, device_status=0x8A1)  # 1, 0xA, 8 by field
    frames = {f.arbitration_id: UNPROTECTED.decode(f.arbitration_id, UNPROTECTED.encode(f))
              for f in UNPROTECTED.from_reading(reading)}
    assert [UNPROTECTED.encode(f)[2] >> 4 for f in frames.values()] == [0x1, 0xA, 0x8]
    got = UNPROTECTED.to_reading(frames)
    assert got.device_status == 0x8A1 and got.status == 0x021
    plain = CanFrameValues(0x180, 1, (("axis0", 0), ("axis1", 0), ("axis2", 0)))
    decoded = SHARED_LAYOUT.decode(0x180, SHARED_LAYOUT.encode(plain))
    # a layout without status fields carries none
    assert SHARED_LAYOUT.to_reading({0x180: decoded}).device_status is None


@pytest.mark.parametrize("rate_hz", [100.0, 500.0])
def test_shared_layout_resolves_a_tactical_gyros_noise(rate_hz: float) -> None:
    """A VG951 (ARW 0.0076 deg/sqrt(h): 1.3e-3 deg/s per sample at 100 Hz) through the
    default shared frame keeps its noise: the standard deviation within 1 % and hardly
    a zero reading (a 1/256 deg/s LSB read 40 % zeros and inflated it by 7 % at 500 Hz)."""
    signal = SignalSource("VG951", rate_hz, seed=21).read(4000).rate_deg_s
    decoded = []
    for i, rates in enumerate(signal):
        frames = SHARED_LAYOUT.from_reading(Reading(tuple(rates.tolist()), i))
        wire = {f.arbitration_id: SHARED_LAYOUT.decode(f.arbitration_id,
                                                       SHARED_LAYOUT.encode(f)) for f in frames}
        decoded.append(SHARED_LAYOUT.to_reading(wire).rate_deg_s)
    got = np.asarray(decoded)
    np.testing.assert_allclose(got.std(axis=0), signal.std(axis=0), rtol=0.01)
    assert np.mean(got == 0.0) < 0.05
