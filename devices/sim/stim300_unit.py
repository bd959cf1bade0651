"""The datagrams a simulated STIM300 sends, built from its data sheet.

Written from TS1524 rev. 31 on its own, not with the station's codec (a misreading of
the document shared by both would pass every round trip):

* the identifier's bits (Table 5-21): 0x90 rate; +0x01 acceleration, +0x02 inclination;
  with temperatures 0x94 (rate alone) and 0xA5-0xA7; with PPS 0xF0-0xF7 (bit 2 =
  temperature); 0xAF the full content with AUX (Table 5-20);
* Table 5-20's order: rate cluster, acceleration, inclination, the temperature triple of
  each cluster present (rate first), PPS/AUX word and status, counter, latency, CRC-32,
  then CR LF where configured;
* the CRC (section 5.5.7): polynomial x^32 + x^26 + x^23 + x^22 + x^16 + x^12 + x^11 +
  x^10 + x^8 + x^7 + x^5 + x^4 + x^2 + x + 1, seed 0xFFFFFFFF, over every byte before
  it and zero dummy bytes up to whole 32-bit words;
* the counter (7.5.2.2.18) counts the internal samples at 2000 samples/s: datagram ``i``
  at an output rate of ``r`` carries ``(i * 2000 / r) mod 256``;
* scale factors (7.5.2.2): 2**14 LSB per deg/s (rate, average rate), 2**21 per deg
  (incremental angle); 2**20, 2**19, 2**18, 2**16 LSB per g at +-5, 10, 30, 80 g
  (acceleration), 2**23, 2**22, 2**21, 2**19 per m/s (incremental velocity); 2**8 per
  degC.
"""

from __future__ import annotations

from dataclasses import dataclass

from devices.codecs.base import Reading

_POLY = 0x04C11DB7
_G0 = 9.80665  # m/s^2 per g, Table 7-2's k0


def _crc_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        c = byte << 24
        for _ in range(8):
            c = ((c << 1) ^ _POLY if c & 0x80000000 else c << 1) & 0xFFFFFFFF
        table.append(c)
    return tuple(table)


_TABLE = _crc_table()


def sheet_crc(data: bytes) -> int:
    """Section 5.5.7's CRC-32 of ``data`` (MSB first, seed 0xFFFFFFFF, no final XOR)."""
    crc = 0xFFFFFFFF
    for b in data:
        crc = ((crc << 8) & 0xFFFFFFFF) ^ _TABLE[(crc >> 24) ^ b]
    return crc


def _i24(value: float) -> bytes:
    return max(-(2**23), min(2**23 - 1, round(value))).to_bytes(3, "big", signed=True)


def _i16(value: float) -> bytes:
    return max(-(2**15), min(2**15 - 1, round(value))).to_bytes(2, "big", signed=True)


@dataclass(frozen=True)
class SimulatedStim300:
    """How a simulated unit is configured, and the datagram it sends for a sample.

    Attributes
    ----------
    identifier : int
        Datagram identifier (Table 5-21; 0xAF).
    rate_hz : float or None
        Output sample rate, Hz; None: the layout borrowed by another model, whose
        counter counts its datagrams.
    accel_range_g : int
        Accelerometer variant, g.
    crlf : bool
        CR LF after each datagram.
    gyro_output, accel_output : str
        ``rate``/``average``/``incremental`` and ``acceleration``/``average``/
        ``incremental`` (Table 5-11).
    latency_us : int
        The latency word every datagram carries, us.
    """

    identifier: int
    rate_hz: float | None
    accel_range_g: int = 10
    crlf: bool = False
    gyro_output: str = "rate"
    accel_output: str = "acceleration"
    latency_us: int = 500

    def contents(self) -> tuple[bool, bool, bool, bool]:
        """(acceleration, inclination, temperature, PPS/AUX) the identifier carries."""
        ident = self.identifier
        if ident == 0xAF:
            return True, True, True, True
        pps = ident & 0xF0 == 0xF0
        temperature = (ident & 0x04 != 0) if pps else ident in (0x94, 0xA5, 0xA6, 0xA7)
        return ident & 0x01 != 0, ident & 0x02 != 0, temperature, pps

    def counter(self, index: int) -> int:
        """The counter byte of sample ``index`` (the first sample counts 0)."""
        step = 1 if self.rate_hz is None else round(2000 / self.rate_hz)
        return (index * step) % 256

    def datagram(self, reading: Reading) -> bytes:
        """Wire bytes of ``reading`` (its ``counter``: the sample index; ``status``: the
        gyro status byte, the accelerometer's in bits 8-15, the temperature's in 16-23)."""
        accel, incl, temperature, pps = self.contents()
        per_sample = self.rate_hz or 0.0
        gyro_lsb = (2**21 / per_sample if self.gyro_output == "incremental" else 2**14)
        body = bytearray([self.identifier])
        for rate in reading.rate_deg_s:
            body += _i24(rate * gyro_lsb)
        body.append(reading.status & 0xFF)
        if accel:
            values = reading.accel_m_s2 or (0.0, 0.0, 0.0)
            shift = {5: 0, 10: 1, 30: 2, 80: 4}[self.accel_range_g]
            if self.accel_output == "incremental":
                scale = 2**(23 - shift) / per_sample
            else:
                scale = 2**(20 - shift) / _G0
            for a in values:
                body += _i24(a * scale)
            body.append((reading.status >> 8) & 0xFF)
        if incl:  # an inclinometer at rest on z: 1 g at 2**22 LSB per g
            body += _i24(0) + _i24(0) + _i24(2**22) + b"\x00"
        if temperature:
            t = _i16((reading.temperature_c or 0.0) * 2**8)
            for _ in range(1 + accel + incl):
                body += t * 3 + bytes([(reading.status >> 16) & 0xFF])
        if pps:
            body += bytes(4)
        body.append(self.counter(reading.counter))
        body += self.latency_us.to_bytes(2, "big")
        crc = sheet_crc(bytes(body) + bytes(-len(body) % 4))
        return bytes(body) + crc.to_bytes(4, "big") + (b"\r\n" if self.crlf else b"")
