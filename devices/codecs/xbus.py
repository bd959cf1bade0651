"""Xsens MTi Xbus messages and MTData2 data items (pure codec).

Message (Xsens "MT Low Level Communication Protocol")::

    FA (preamble) | FF (bus id) | MID | LEN | data | CS
    extended:      FA | FF | MID | FF | LEN_H LEN_L | data | CS

The checksum makes the byte sum of BID..CS zero modulo 256. MTData2 (MID 0x36) data is
a sequence of items ``data id (uint16 BE) | size (uint8) | value``; the ones a gyro
station uses:

======  ===============  ==========================================
0x1020  PacketCounter    uint16, wraps at 65536
0x1060  SampleTimeFine   uint32, 10 kHz ticks
0x8020  RateOfTurn       3 x float32, rad/s
0x4020  Acceleration     3 x float32, m/s^2
0x0810  Temperature      float32, degC
0xE020  StatusWord       uint32
======  ===============  ==========================================

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
from devices.errors import CodecError, FrameError

PREAMBLE = 0xFA
BUS_ID = 0xFF
MID_GOTO_CONFIG = 0x30
MID_GOTO_MEASUREMENT = 0x10
MID_MTDATA2 = 0x36
PACKET_COUNTER = 0x1020
SAMPLE_TIME_FINE = 0x1060
RATE_OF_TURN = 0x8020
ACCELERATION = 0x4020
TEMPERATURE = 0x0810
STATUS_WORD = 0xE020
SAMPLE_TIME_FINE_HZ = 10_000.0
COUNTER_MODULUS = 65536
DEG_PER_RAD = 180.0 / math.pi

_ITEM_FORMATS = {PACKET_COUNTER: ">H", SAMPLE_TIME_FINE: ">I", RATE_OF_TURN: ">3f",
                 ACCELERATION: ">3f", TEMPERATURE: ">f", STATUS_WORD: ">I"}


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
        Decode the Acceleration item (0x4020), which every MTData2 message must then
        carry (an MTi configured to output it); False (the default here; a device URL
        turns it on unless ``accel=0``) ignores it.
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

    def __init__(self, max_data_length: int = 512, *, accel: bool = False) -> None:
        self.max_data_length = max_data_length
        self.n_accel_axes = 3 if accel else 0
        self.accel_range_m_s2: float | None = (
            self.accel_range_g * STANDARD_GRAVITY_M_S2 if accel else None)

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
        """Reading of an MTData2 message (None for any other message).

        Raises
        ------
        FrameError
            MTData2 without RateOfTurn or PacketCounter (or Acceleration, when the
            codec decodes it), or an item of the wrong size.
        """
        if frame.mid != MID_MTDATA2:
            return None
        items = parse_mtdata2(frame.data)
        try:
            rate = struct.unpack(">3f", items[RATE_OF_TURN])
            (counter,) = struct.unpack(">H", items[PACKET_COUNTER])
            stf = items.get(SAMPLE_TIME_FINE)
            temp = items.get(TEMPERATURE)
            status = items.get(STATUS_WORD)
            accel = (struct.unpack(">3f", items[ACCELERATION]) if self.n_accel_axes
                     else None)
            return Reading(
                rate_deg_s=tuple(r * DEG_PER_RAD for r in rate), counter=counter,
                status=struct.unpack(">I", status)[0] if status is not None else 0,
                device_time_s=(struct.unpack(">I", stf)[0] / SAMPLE_TIME_FINE_HZ
                               if stf is not None else None),
                temperature_c=struct.unpack(">f", temp)[0] if temp is not None else None,
                accel_m_s2=accel,
            )
        except (KeyError, struct.error) as exc:
            raise FrameError(f"MTData2 message without a usable item: {exc}") from exc

    def from_reading(self, reading: Reading) -> XbusMessage:
        """MTData2 message with PacketCounter, SampleTimeFine, RateOfTurn, Acceleration
        (when the reading has one), Temperature, StatusWord."""
        stf = round((reading.device_time_s or 0.0) * SAMPLE_TIME_FINE_HZ) % 2**32
        values: dict[int, tuple[float, ...]] = {
            PACKET_COUNTER: (reading.counter % COUNTER_MODULUS,),
            SAMPLE_TIME_FINE: (stf,),
            RATE_OF_TURN: tuple(r / DEG_PER_RAD for r in reading.rate_deg_s),
        }
        if reading.accel_m_s2 is not None:
            values[ACCELERATION] = reading.accel_m_s2
        values |= {TEMPERATURE: (reading.temperature_c or 0.0,), STATUS_WORD: (reading.status,)}
        items = {k: struct.pack(_ITEM_FORMATS[k], *v) for k, v in values.items()}
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
