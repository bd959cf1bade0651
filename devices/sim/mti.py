"""The messages a simulated Xsens MTi sends, written from the protocol document.

Built from the Xsens "MT Low Level Communication Protocol" (as einride/xsens-go
implements it, and as the MTi-G-710 captures in ``../shared/real-captures/`` show it),
not from :class:`devices.codecs.xbus.XbusCodec`'s encoder, so that a misreading of the
document cannot pass both the codec and its simulator:

* a message is ``FA FF 36 LEN data CS`` (``FF LEN_H LEN_L`` for more than 254 data
  bytes), the checksum making the byte sum of FF..CS zero modulo 256;
* MTData2 items are ``identifier (uint16 BE) | size (uint8) | value``, float32 values
  big-endian;
* the PacketCounter (0x1020) counts every MTData2 message the unit sends, GNSS ones too;
* an MTi-G sends its GNSS PVT data (0x7010, 94 bytes on the MTi-G-710) in messages of
  their own, with PacketCounter, SampleTimeFine and UTCTime only: no rate of turn;
* a healthy unit's StatusWord has its bits 1 where things are good: self-test passed
  (bit 0), filter valid (bit 1), and on an MTi-G a GNSS fix (bit 2) and filter mode
  "with GNSS" (bits 23-25 = 011): 0x01800007, as the MTi-G-710 captures read.
"""

from __future__ import annotations

import math
import struct

from devices.codecs.base import Reading

_PACKET_COUNTER = 0x1020
_SAMPLE_TIME_FINE = 0x1060
_UTC_TIME = 0x1010
_STATUS_WORD = 0xE020
_TEMPERATURE_F32 = 0x0810
_ACCELERATION_F32 = 0x4020
_ACCELERATION_HR_F32 = 0x4040
_RATE_OF_TURN_F32 = 0x8020
_RATE_OF_TURN_HR_F32 = 0x8040
_GNSS_PVT_DATA = 0x7010
_GNSS_PVT_BYTES = 94
_MID_MTDATA2 = 0x36
_TICKS_PER_S = 10_000  # SampleTimeFine
#: StatusWord of a healthy MTi without GNSS (self-test passed, filter valid) and of a
#: healthy MTi-G with a fix (also GNSS fix, filter mode 011 "with GNSS").
HEALTHY_WORD = 0x00000003
HEALTHY_WORD_GNSS = 0x01800007
_SELFTEST_PASSED = 0x1


def _message(data: bytes) -> bytes:
    """An MTData2 message with its length field and checksum."""
    n = len(data)
    length = bytes([n]) if n < 0xFF else b"\xff" + n.to_bytes(2, "big")
    body = b"\xff" + bytes([_MID_MTDATA2]) + length + data
    return b"\xfa" + body + bytes([(-sum(body)) & 0xFF])


def _item(identifier: int, value: bytes) -> bytes:
    return struct.pack(">HB", identifier, len(value)) + value


class MtiMessages:
    """What a simulated MTi writes for each sample: its IMU message, and after it the
    GNSS messages that fall due.

    Parameters
    ----------
    sample_rate_hz : float
        Rate of the messages with a rate of turn, Hz.
    gnss_hz : float
        Rate of the GNSS-only messages, Hz (0: an MTi without GNSS).
    accel : bool
        Whether the IMU messages carry the accelerations.
    high_rate : bool
        Send RateOfTurnHR / AccelerationHR (0x8040 / 0x4040) instead of RateOfTurn /
        Acceleration.

    Notes
    -----
    The unit's counter for sample ``i`` is ``i`` plus the GNSS messages before it
    (``floor(i * gnss_hz / sample_rate_hz)``; the k-th comes after the sample at which
    that count reaches k + 1), whether the sample is sent or lost, as a unit counts what
    it sends. A GNSS message whose sample this simulator did not send (a starved device
    thread, an outage) goes out before the next sample it sends: a real unit would have
    sent it on time, and the station would have counted it lost with the samples; sent
    late it keeps the simulator's books and the station's exact.
    """

    def __init__(self, sample_rate_hz: float, *, gnss_hz: float = 0.0, accel: bool = False,
                 high_rate: bool = False) -> None:
        if not 0.0 <= gnss_hz <= sample_rate_hz:
            raise ValueError(f"gnss_hz must be 0..{sample_rate_hz:g} (the sample rate), "
                             f"got {gnss_hz:g}")
        self.sample_rate_hz = sample_rate_hz
        self.gnss_hz = gnss_hz
        self.accel = accel
        self.rate_id = _RATE_OF_TURN_HR_F32 if high_rate else _RATE_OF_TURN_F32
        self.accel_id = _ACCELERATION_HR_F32 if high_rate else _ACCELERATION_F32
        self.healthy_word = HEALTHY_WORD_GNSS if gnss_hz else HEALTHY_WORD
        self._gnss_sent = 0

    def gnss_before(self, index: int) -> int:
        """GNSS messages the unit sent before sample ``index``."""
        return math.floor(index * self.gnss_hz / self.sample_rate_hz) if self.gnss_hz else 0

    def packet_counter(self, index: int) -> int:
        """PacketCounter of sample ``index`` (uint16)."""
        return (index + self.gnss_before(index)) % 65536

    def imu(self, reading: Reading) -> bytes:
        """The IMU message of a sample (``reading.counter`` is its index)."""
        index = reading.counter
        word = self.healthy_word if reading.status == 0 else \
            self.healthy_word & ~_SELFTEST_PASSED
        ticks = round((reading.device_time_s or 0.0) * _TICKS_PER_S) % 2**32
        data = (_item(_PACKET_COUNTER, struct.pack(">H", self.packet_counter(index)))
                + _item(_SAMPLE_TIME_FINE, struct.pack(">I", ticks))
                + _item(_STATUS_WORD, struct.pack(">I", word)))
        if self.accel and reading.accel_m_s2 is not None:
            data += _item(self.accel_id, struct.pack(">3f", *reading.accel_m_s2))
        rad_s = tuple(math.radians(r) for r in reading.rate_deg_s)
        data += _item(self.rate_id, struct.pack(">3f", *rad_s))
        data += _item(_TEMPERATURE_F32, struct.pack(">f", reading.temperature_c or 0.0))
        return _message(data)

    def gnss_due(self, reading: Reading) -> bytes:
        """The GNSS messages the unit sends before this sample and has not sent yet
        (normally the one after the previous sample, or ``b""``); PVT content left zero:
        the station reads none of it."""
        due = self.gnss_before(reading.counter)
        out = b"".join(self._gnss_message(k) for k in range(self._gnss_sent, due))
        self._gnss_sent = max(self._gnss_sent, due)
        return out

    def _gnss_message(self, k: int) -> bytes:
        """The k-th GNSS message (from 0): after sample ``s``, the first at which
        :meth:`gnss_before` of the next sample reaches k + 1."""
        s = max(0, math.ceil((k + 1) * self.sample_rate_hz / self.gnss_hz) - 1)
        while self.gnss_before(s + 1) < k + 1:
            s += 1
        while s > 0 and self.gnss_before(s) >= k + 1:
            s -= 1
        counter = (s + k + 1) % 65536
        # half a period after sample s, as the MTi-G-710's GNSS messages fall between two
        # IMU messages on its SampleTimeFine
        ticks = round((s + 0.5) / self.sample_rate_hz * _TICKS_PER_S) % 2**32
        return _message(_item(_GNSS_PVT_DATA, bytes(_GNSS_PVT_BYTES))
                        + _item(_UTC_TIME, bytes(12))
                        + _item(_SAMPLE_TIME_FINE, struct.pack(">I", ticks))
                        + _item(_PACKET_COUNTER, struct.pack(">H", counter)))
