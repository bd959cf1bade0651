"""The messages a simulated KVH DSP-1750 sends, laid out from KVH's document.

Built byte by byte from the tables of the KVH ICD 56-0298 rev. B (1775 IMU technical
manual, section 5), not from the station's codec, so that a misreading of the layout in
one cannot pass unseen through both: byte numbers below are the tables' (counted from 1).

* Format A, Tables 5-1 and 5-2 (36 bytes): header 0xFE81FF55 in bytes 1-4; X, Y, Z
  rotation in 5-8, 9-12, 13-16; X, Y, Z acceleration (g) in 17-20, 21-24, 25-28; status
  29; sequence number 30; temperature (INT16) 31-32; CRC 33-36.
* Format B, Tables 5-3 and 5-4 (40 bytes): header 0xFE81FF56; the same up to byte 28;
  time stamp (UINT32, us) 29-32; status 33; sequence 34; temperature (INT16) 35-36; CRC
  37-40.
* Format C, Tables 5-5 to 5-7 (38 bytes): header 0xFE81FF57; the same up to byte 28;
  29-32 the temperature (SPFP) when the sequence number modulo 4 is 0, else the magnetic
  field X, Y, Z (gauss) in turn; status 33; sequence 34; CRC 35-38.
* Every multi-byte word goes MSB first; SPFP is IEEE-754 single precision.
* Status, Table 5-8: bit 0, 1, 2 gyro X, Y, Z valid; bits 4, 5, 6 accelerometer X, Y, Z
  valid (1 = valid); bits 3 and 7 always 0.
* Temperature: degC, 1/100 degC, degF or 1/100 degF, as the unit is set.
* CRC, Table 5-9: width 32, polynomial 0x04C11DB7, XOR in 0xFFFFFFFF, no reflection,
  XOR out 0, over every byte before it.
"""

from __future__ import annotations

import math
import struct

from analysis.units.conversions import STANDARD_GRAVITY_M_S2
from devices.codecs.base import Reading
from devices.codecs.crc import crc32_mpeg2

#: (length, byte number of the status, of the sequence number, of the temperature word,
#: of the time stamp (0: none)) of each format, from Tables 5-1 to 5-6.
_LAYOUT = {"A": (36, 29, 30, 31, 0), "B": (40, 33, 34, 35, 29), "C": (38, 33, 34, 29, 0)}
_HEADER_LAST_BYTE = {"A": 0x55, "B": 0x56, "C": 0x57}
#: Valid bits of the status byte (Table 5-8), indexed by the sensor.
_VALID_BIT = {"gyro x": 0, "gyro y": 1, "gyro z": 2, "accel x": 4, "accel y": 5, "accel z": 6}
#: The Earth's field a unit on a bench in mid-latitudes reads, gauss (format C's slots).
BENCH_MAGNETIC_FIELD_GAUSS = (0.2, 0.0, 0.44)


class KvhMessageWriter:
    """Turns a simulated reading into the bytes a DSP-1750 sends.

    Parameters
    ----------
    message_format : {"A", "B", "C"}
        The message the unit is set to send.
    tempunits : {"C", "F", "0.01C", "0.01F"}
        Its temperature setting.
    angle_unit : {"deg", "rad"}, output : {"rate", "delta"}
        Its gyro words: rate (unit/s) or delta angle (unit per sample).
    sample_rate_hz : float
        Output rate, Hz (a delta angle is the rate over one period).

    Notes
    -----
    A reading's ``status`` (the station's sense: bits set where a sensor is not valid,
    at the status byte's positions) clears those valid bits; 0 sends 0x77, all valid.
    """

    def __init__(self, message_format: str, tempunits: str, angle_unit: str, output: str,
                 sample_rate_hz: float) -> None:
        if message_format not in _LAYOUT:
            raise ValueError(f"format must be A, B or C, got {message_format!r}")
        if tempunits not in ("C", "F", "0.01C", "0.01F"):
            raise ValueError(f"tempunits must be C, F, 0.01C or 0.01F, got {tempunits!r}")
        self.message_format = message_format
        self.tempunits = tempunits
        per_deg = 1.0 if angle_unit == "deg" else math.pi / 180.0
        self._gyro_per_deg_s = per_deg / (sample_rate_hz if output == "delta" else 1.0)

    def _temperature_word(self, temperature_c: float) -> float:
        value = temperature_c * 1.8 + 32.0 if self.tempunits.endswith("F") else temperature_c
        return value * 100.0 if self.tempunits.startswith("0.01") else value

    def _status_byte(self, reading_status: int) -> int:
        byte = 0
        for bit in _VALID_BIT.values():
            if not reading_status >> bit & 1:
                byte |= 1 << bit
        return byte

    def __call__(self, reading: Reading) -> bytes:
        """The message for ``reading`` (rates deg/s, accelerations m/s^2, 1 g up z when it
        carries none; temperature degC, 25 when it carries none)."""
        length, at_status, at_sequence, at_temperature, at_stamp = _LAYOUT[self.message_format]
        out = bytearray(length)

        def put(byte_number: int, data: bytes) -> None:
            out[byte_number - 1:byte_number - 1 + len(data)] = data

        put(1, bytes((0xFE, 0x81, 0xFF, _HEADER_LAST_BYTE[self.message_format])))
        for i, rate in enumerate(reading.rate_deg_s):
            put(5 + 4 * i, struct.pack(">f", rate * self._gyro_per_deg_s))
        accel = reading.accel_m_s2 or (0.0, 0.0, STANDARD_GRAVITY_M_S2)
        for i, a in enumerate(accel):
            put(17 + 4 * i, struct.pack(">f", a / STANDARD_GRAVITY_M_S2))
        sequence = reading.counter % 128
        put(at_status, bytes((self._status_byte(reading.status),)))
        put(at_sequence, bytes((sequence,)))
        word = self._temperature_word(25.0 if reading.temperature_c is None
                                      else reading.temperature_c)
        if self.message_format == "C":
            slot = sequence % 4
            put(at_temperature, struct.pack(
                ">f", word if slot == 0 else BENCH_MAGNETIC_FIELD_GAUSS[slot - 1]))
        else:
            put(at_temperature, struct.pack(">h", max(-32768, min(32767, round(word)))))
        if at_stamp:
            stamp_us = round((reading.device_time_s or 0.0) * 1e6) % 2**32
            put(at_stamp, stamp_us.to_bytes(4, "big"))
        crc_at = length - 3
        put(crc_at, crc32_mpeg2(bytes(out[:crc_at - 1])).to_bytes(4, "big"))
        return bytes(out)
