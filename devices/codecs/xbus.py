"""Xsens MTi Xbus messages and MTData2 data items (pure codec).

Message (Xsens "MT Low Level Communication Protocol")::

    FA (preamble) | FF (bus id) | MID | LEN | data | CS
    extended:      FA | FF | MID | FF | LEN_H LEN_L | data | CS

The checksum makes the byte sum of BID..CS zero modulo 256. MTData2 (MID 0x36) data is
a sequence of items ``data id (uint16 BE) | size (uint8) | value``; the identifiers,
their precision and coordinate-system bits, the fixed-point formats and the StatusWord
bits are in :mod:`devices.codecs.xbus_items` (docs/devices.md, "Xsens MTi (Xbus)"). The
ones a gyro station uses, in any of the four precisions:

======  ===============  ==========================================
0x1020  PacketCounter    uint16, wraps at 65536; counts every message
0x1060  SampleTimeFine   uint32, 10 kHz ticks
0x8020  RateOfTurn       3 values, rad/s (0x8040 RateOfTurnHR with ``high_rate``)
0x4020  Acceleration     3 values, m/s^2 (0x4040 AccelerationHR with ``high_rate``)
0x0810  Temperature      1 value, degC
0xE020  StatusWord       uint32, bits 1 where good (0xE010 StatusByte: its bits 0-7)
======  ===============  ==========================================

An MTi sends other outputs in MTData2 messages of their own (an MTi-G-710's GNSS PVT
data at 4 Hz): such a message carries no rate of turn, yet the PacketCounter counts
it. :meth:`XbusCodec.to_reading` gives None for it and :meth:`XbusCodec.rateless_counter`
its counter, so that the adapter does not take its counter step for a lost sample.

GoToConfig (0x30) / GoToMeasurement (0x10) are acknowledged by MID + 1.

Limitation of the protocol, not of this decoder: the 8-bit sum detects every single
bit flip except one in the length byte, which shortens the frame so that a data byte
becomes the checksum (accepted 1 time in 256), and misses two flips of the same bit in
two bytes that change them in opposite directions (``benchmarks/bench_fuzz_checks.py``
measures both). :meth:`XbusCodec.to_reading` checks the MTData2 item structure, which
rejects most of the first kind; the adapter's sanity checks (counter continuity, the
rate range, device time against the station's own timing) catch much of the rest.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

from analysis.units.conversions import STANDARD_GRAVITY_M_S2
from devices.codecs.base import DecodeResult, Reading, scan_frames
from devices.codecs.xbus_items import (
    ACCEL_CLIPPING,
    ACCELERATION,
    ACCELERATION_HR,
    FILTER_VALID,
    FLOAT32,
    GYRO_CLIPPING,
    PACKET_COUNTER,
    RATE_OF_TURN,
    RATE_OF_TURN_HR,
    SAMPLE_TIME_FINE,
    SELFTEST_PASSED,
    STATUS_BYTE,
    STATUS_WORD,
    TEMPERATURE,
    DataId,
    decode_values,
    status_byte_flags,
    status_word_flags,
)
from devices.errors import CodecError, FrameError

__all__ = ["ACCELERATION", "ACCELERATION_HR", "PACKET_COUNTER", "RATE_OF_TURN",
           "RATE_OF_TURN_HR", "SAMPLE_TIME_FINE", "STATUS_BYTE", "STATUS_WORD",
           "TEMPERATURE", "XbusCodec", "XbusMessage", "build_mtdata2", "checksum",
           "parse_mtdata2"]

PREAMBLE = 0xFA
BUS_ID = 0xFF
MID_GOTO_CONFIG = 0x30
MID_GOTO_MEASUREMENT = 0x10
MID_MTDATA2 = 0x36
SAMPLE_TIME_FINE_HZ = 10_000.0
COUNTER_MODULUS = 65536
DEG_PER_RAD = 180.0 / math.pi
#: StatusWord :meth:`XbusCodec.from_reading` sends for a good sample: self-test passed,
#: filter valid.
HEALTHY_STATUS_WORD = SELFTEST_PASSED | FILTER_VALID


@dataclass(frozen=True)
class XbusMessage:
    """One Xbus message: message identifier and its data bytes."""

    mid: int
    data: bytes


def checksum(body: bytes) -> int:
    """Checksum byte that makes ``sum(body) + cs`` zero modulo 256 (body = BID..data)."""
    return (-sum(body)) & 0xFF


def parse_mtdata2(data: bytes) -> dict[int, bytes]:
    """Split MTData2 data into ``{data id: value bytes}``.

    Raises
    ------
    FrameError
        An item runs past the end of the data.
    """
    items: dict[int, bytes] = {}
    pos = 0
    while pos < len(data):
        if pos + 3 > len(data):
            raise FrameError("MTData2 item header truncated")
        data_id = int.from_bytes(data[pos:pos + 2], "big")
        size = data[pos + 2]
        if pos + 3 + size > len(data):
            raise FrameError(f"MTData2 item 0x{data_id:04X} truncated")
        items[data_id] = data[pos + 3:pos + 3 + size]
        pos += 3 + size
    return items


def build_mtdata2(items: dict[int, bytes]) -> bytes:
    """Inverse of :func:`parse_mtdata2` (items in the dict's order)."""
    out = bytearray()
    for data_id, value in items.items():
        if len(value) > 255:
            raise CodecError(f"MTData2 item 0x{data_id:04X} longer than 255 bytes")
        out += data_id.to_bytes(2, "big") + bytes([len(value)]) + value
    return bytes(out)


class XbusCodec:
    """Xbus message codec with the MTData2 mapping of a gyro station.

    Parameters
    ----------
    max_data_length : int
        Longest data field accepted (bytes); a candidate announcing more is garbage.
        Bounds how long a false preamble can hold up resynchronization.
    accel : bool
        Decode the Acceleration item (0x4020, any precision), which every MTData2
        message with a rate of turn must then carry (an MTi configured to output it);
        False (the default here; a device URL turns it on unless ``accel=0``) ignores it.
    high_rate : bool
        Take the rates from RateOfTurnHR (0x8040) and the accelerations from
        AccelerationHR (0x4040) instead (URL ``hr=1``): the MTi sends them in messages
        of their own, at their own rate. A message with the other kind only carries no
        sample of this stream.
    """

    #: An 8-bit sum lets some corrupted frames through (two flipped bits that cancel):
    #: the adapter checks counter continuity (:class:`~devices.batching.BatchBuilder`).
    weak_check = True
    #: Measurement range of the MTi family's gyros, deg/s: a larger rate is a corrupted
    #: frame (used when no product profile gives the unit's own range).
    rate_range_deg_s = 2000.0
    #: Measurement range of the MTi family's accelerometers, g.
    accel_range_g = 16.0

    name = "xbus"
    counter_modulus = COUNTER_MODULUS
    n_axes = 3
    has_device_time = True
    has_temperature = True

    def __init__(self, max_data_length: int = 512, *, accel: bool = False,
                 high_rate: bool = False) -> None:
        self.max_data_length = max_data_length
        self.n_accel_axes = 3 if accel else 0
        self.accel_range_m_s2: float | None = (
            self.accel_range_g * STANDARD_GRAVITY_M_S2 if accel else None)
        self.high_rate = high_rate
        self.rate_type = RATE_OF_TURN_HR if high_rate else RATE_OF_TURN
        self.accel_type = ACCELERATION_HR if high_rate else ACCELERATION
        #: The item a message needs to make a sample, as a refusal names it.
        self.rate_item = ("RateOfTurnHR (0x8040)" if high_rate else "RateOfTurn (0x8020)")
        #: What to change where a stream carries none (the adapter's refusal).
        self.rate_item_hint = ("configure the MTi to output RateOfTurnHR, or leave hr=1 "
                               "out of the URL for RateOfTurn" if high_rate else
                               "configure the MTi to output RateOfTurn, or give hr=1 in "
                               "the URL for RateOfTurnHR")

    def _length(self, data: bytes, pos: int) -> int | None:
        if pos + 4 > len(data):
            return None
        if data[pos + 1] != BUS_ID:
            return 0
        length = data[pos + 3]
        header = 4
        if length == 0xFF:
            if pos + 6 > len(data):
                return None
            length = int.from_bytes(data[pos + 4:pos + 6], "big")
            header = 6
        return header + length + 1 if length <= self.max_data_length else 0

    def _parse(self, raw: bytes) -> XbusMessage | None:
        if sum(raw[1:]) & 0xFF:
            return None
        header = 6 if raw[3] == 0xFF else 4
        return XbusMessage(raw[2], raw[header:-1])

    def decode(self, data: bytes) -> DecodeResult[XbusMessage]:
        """Messages whose checksum verifies, resynchronizing on FA FF."""
        return scan_frames(data, bytes([PREAMBLE, BUS_ID]), self._length, self._parse)

    def encode(self, frame: XbusMessage) -> bytes:
        """Wire bytes (extended length form when the data exceed 254 bytes).

        Raises
        ------
        CodecError
            MID out of 0..255 or data longer than 65535 bytes.
        """
        if not 0 <= frame.mid <= 255 or len(frame.data) > 0xFFFF:
            raise CodecError("Xbus MID must be 0..255 and data at most 65535 bytes")
        n = len(frame.data)
        length = bytes([n]) if n < 0xFF else b"\xff" + n.to_bytes(2, "big")
        body = bytes([BUS_ID, frame.mid]) + length + frame.data
        return bytes([PREAMBLE]) + body + bytes([checksum(body)])

    def to_reading(self, frame: XbusMessage) -> Reading | None:
        """Reading of an MTData2 message with a rate of turn (None for any other message,
        and for an MTData2 message of other outputs: see :meth:`rateless_counter`).

        The values are read in the precision their identifiers give (float32, FP12.20,
        FP16.32, float64); ``status`` from the StatusWord or StatusByte bits
        (:func:`~devices.codecs.xbus_items.status_word_flags`), ``device_status`` the
        word (or byte) as sent.

        Raises
        ------
        FrameError
            A rate of turn without PacketCounter (or without Acceleration, when the codec
            decodes it), or an item of the wrong size.
        """
        if frame.mid != MID_MTDATA2:
            return None
        items = _items_by_type(frame.data)
        if self.rate_type not in items:
            return None
        try:
            rate_id, rate_value = items[self.rate_type]
            rate = decode_values(rate_value, rate_id.precision, 3, rate_id.name())
            counter = _uint(items[PACKET_COUNTER][1], 2, "PacketCounter")
            accel = None
            if self.n_accel_axes:
                accel_id, accel_value = items[self.accel_type]
                accel = decode_values(accel_value, accel_id.precision, 3, accel_id.name())
        except KeyError as exc:
            raise FrameError(f"MTData2 message without a usable item: 0x{exc.args[0]:04X}"
                             ) from exc
        stf = items.get(SAMPLE_TIME_FINE)
        temp = items.get(TEMPERATURE)
        status, device_status = self._status(items)
        return Reading(
            rate_deg_s=tuple(r * DEG_PER_RAD for r in rate), counter=counter,
            status=status,
            device_time_s=(_uint(stf[1], 4, "SampleTimeFine") / SAMPLE_TIME_FINE_HZ
                           if stf is not None else None),
            temperature_c=(decode_values(temp[1], temp[0].precision, 1, temp[0].name())[0]
                           if temp is not None else None),
            accel_m_s2=accel, device_status=device_status)

    def _status(self, items: dict[int, tuple[DataId, bytes]]) -> tuple[int, int | None]:
        """(station status, device word as sent) from StatusWord, else StatusByte."""
        if STATUS_WORD in items:
            word = _uint(items[STATUS_WORD][1], 4, "StatusWord")
            return status_word_flags(word, accel=bool(self.n_accel_axes)), word
        if STATUS_BYTE in items:
            byte = _uint(items[STATUS_BYTE][1], 1, "StatusByte")
            return status_byte_flags(byte), byte
        return 0, None

    def rateless_counter(self, frame: XbusMessage) -> int | None:
        """PacketCounter of an MTData2 message that carries no rate of turn (an MTi-G's
        GNSS PVT message): the device counted it, yet it holds no sample. None for any
        other message (one with a rate of turn, one without a usable counter)."""
        if frame.mid != MID_MTDATA2:
            return None
        try:
            items = _items_by_type(frame.data)
            if self.rate_type in items or PACKET_COUNTER not in items:
                return None
            return _uint(items[PACKET_COUNTER][1], 2, "PacketCounter")
        except FrameError:
            return None

    def from_reading(self, reading: Reading) -> XbusMessage:
        """MTData2 message with PacketCounter, SampleTimeFine, RateOfTurn, Acceleration
        (when the reading has one), Temperature (float32) and StatusWord: the reading's
        ``device_status`` if it has one, else :data:`HEALTHY_STATUS_WORD` with the
        self-test bit cleared and the clipping bits set where ``status`` flags them."""
        stf = round((reading.device_time_s or 0.0) * SAMPLE_TIME_FINE_HZ) % 2**32
        word = reading.device_status
        if word is None:
            flags = reading.status & (SELFTEST_PASSED | GYRO_CLIPPING | ACCEL_CLIPPING)
            word = (HEALTHY_STATUS_WORD ^ (flags & SELFTEST_PASSED)) | (flags & ~SELFTEST_PASSED)
        items = {
            PACKET_COUNTER: struct.pack(">H", reading.counter % COUNTER_MODULUS),
            SAMPLE_TIME_FINE: struct.pack(">I", stf),
            self.rate_type | FLOAT32: struct.pack(
                ">3f", *(r / DEG_PER_RAD for r in reading.rate_deg_s)),
        }
        if reading.accel_m_s2 is not None:
            items[self.accel_type | FLOAT32] = struct.pack(">3f", *reading.accel_m_s2)
        items[TEMPERATURE | FLOAT32] = struct.pack(">f", reading.temperature_c or 0.0)
        items[STATUS_WORD] = struct.pack(">I", word & 0xFFFFFFFF)
        return XbusMessage(MID_MTDATA2, build_mtdata2(items))

    def greeting(self) -> bytes:
        """GoToConfig then GoToMeasurement, as a host sends them after opening the port."""
        return (self.encode(XbusMessage(MID_GOTO_CONFIG, b""))
                + self.encode(XbusMessage(MID_GOTO_MEASUREMENT, b"")))

    def acknowledges(self, frame: XbusMessage) -> bool:
        """Whether ``frame`` is the GoToMeasurement acknowledgement (MID 0x11)."""
        return frame.mid == MID_GOTO_MEASUREMENT + 1

    def answer(self, frame: XbusMessage) -> tuple[XbusMessage, bool] | None:
        """Device side: acknowledge GoToConfig (stop streaming) and GoToMeasurement (start)."""
        if frame.mid in (MID_GOTO_CONFIG, MID_GOTO_MEASUREMENT):
            return XbusMessage(frame.mid + 1, b""), frame.mid == MID_GOTO_MEASUREMENT
        return None


def _items_by_type(data: bytes) -> dict[int, tuple[DataId, bytes]]:
    """MTData2 items by data type (identifier less its coordinate-system and precision
    bits), each with its identifier's fields; the first of a type counts.

    Raises
    ------
    FrameError
        An item runs past the end of the data.
    """
    out: dict[int, tuple[DataId, bytes]] = {}
    for identifier, value in parse_mtdata2(data).items():
        data_id = DataId.of(identifier)
        out.setdefault(data_id.data_type, (data_id, value))
    return out


def _uint(value: bytes, size: int, what: str) -> int:
    """A big-endian unsigned item of ``size`` bytes.

    Raises
    ------
    FrameError
        The item is not ``size`` bytes long.
    """
    if len(value) != size:
        raise FrameError(f"MTData2 item {what} of {len(value)} bytes, not {size}: "
                         f"not a usable item")
    return int.from_bytes(value, "big")
