"""Safran Sensonor STIM300 normal-mode binary datagram (pure codec).

Layout (STIM300 datasheet TS1524, tables 5-20 to 5-22; cross-checked against the public
pystim300 driver's ``normal.py``, ``crc.py`` and ``scaling.py``)::

    ID | gyro X,Y,Z (3 x int24 BE) | gyro status | [accel 9+1] | [incl 9+1]
       | [temperature triples 3 x int16 BE + status, one per cluster present]
       | counter (uint8) | latency (uint16 BE, us) | CRC-32 (BE)

* rate = value / 2**14 deg/s; temperature = value / 2**8 degC;
* acceleration (output unit g) = value / 2**19 g for the +-10 g accelerometers,
  / 2**18 g for +-30 g, / 2**16 g for +-80 g (datasheet table 5-27; pystim300
  ``scaling.py``), converted here to m/s^2 with the standard gravity 9.80665 m/s^2.
  Checked again against a second public reader, geirhovland/stim300 ``stim300_read.py``
  ("Acc X,Y,Z ... Assumes range 10g --> 2^19 = 524288"), whose README's sample datagram
  of a unit at rest reads z = 1.0138 g with that divisor (2**20 would halve it to 0.51 g,
  so 2**-20 g is not the +-10 g LSB);
* CRC-32/MPEG-2 over ID..latency padded with zero bytes to a multiple of 4 (the padding
  is not transmitted).

Identifiers: 0x90 rate only, 0x91/0x92/0x93 with accelerometers and/or inclinometers,
0x94 and 0xA5-0xA7 the same with temperatures. The accelerometer and inclinometer
clusters travel in :attr:`Stim300Frame.other_clusters` as raw bytes; the accelerometer
cluster (first of them) is decoded into :attr:`Reading.accel_m_s2` by :meth:`to_reading`.
"""

from __future__ import annotations

from dataclasses import dataclass

from analysis.units.conversions import STANDARD_GRAVITY_M_S2
from devices.codecs.base import DecodeResult, Reading, StreamingOnPowerUp, scan_frames
from devices.codecs.crc import crc32_mpeg2
from devices.errors import CodecError

RATE_LSB_PER_DEG_S = 2**14
TEMP_LSB_PER_DEGC = 2**8
COUNTER_MODULUS = 256
#: Accelerometer LSB per g of each range variant (g: +-10, +-30, +-80).
ACCEL_LSB_PER_G: dict[int, int] = {10: 2**19, 30: 2**18, 80: 2**16}

# identifier -> (has accelerometer cluster, has inclinometer cluster, has temperatures)
DATAGRAMS: dict[int, tuple[bool, bool, bool]] = {
    0x90: (False, False, False), 0x91: (True, False, False), 0x92: (False, True, False),
    0x93: (True, True, False), 0x94: (False, False, True), 0xA5: (True, False, True),
    0xA6: (False, True, True), 0xA7: (True, True, True),
}


@dataclass(frozen=True)
class Stim300Frame:
    """One normal-mode datagram, as integers on the wire.

    Attributes
    ----------
    identifier : int
        Datagram identifier (0x90...).
    gyro : tuple of 3 int
        Raw signed 24-bit rates (LSB = 2**-14 deg/s).
    gyro_status : int
        Gyro status byte (0 = all good).
    counter : int
        Sample counter 0..255.
    latency_us : int
        Latency, microseconds 0..65535.
    temperature : tuple of 3 int or None
        Raw gyro temperatures (LSB = 2**-8 degC), for identifiers with temperatures.
    temperature_status : int
        Status byte of the gyro temperature triple.
    other_clusters : bytes
        Accelerometer/inclinometer clusters and their temperature triples, raw (the
        accelerometer cluster first: 3 x int24 BE and a status byte).
    """

    identifier: int
    gyro: tuple[int, int, int]
    gyro_status: int
    counter: int
    latency_us: int
    temperature: tuple[int, int, int] | None = None
    temperature_status: int = 0
    other_clusters: bytes = b""


def _layout(identifier: int) -> tuple[int, int, int]:
    """(other cluster bytes before temperatures, other temperature bytes, payload length)."""
    accel, incl, temp = DATAGRAMS[identifier]
    n_other = int(accel) + int(incl)
    other = 10 * n_other
    other_temp = 7 * n_other if temp else 0
    payload = 10 + other + (7 if temp else 0) + other_temp + 3
    return other, other_temp, payload


def _crc_input(body: bytes) -> bytes:
    return body + b"\x00" * (-len(body) % 4)


def _int24(b: bytes) -> int:
    return int.from_bytes(b, "big", signed=True)


def _clip24(value: float) -> int:
    lim = 2**23 - 1
    return max(-lim - 1, min(lim, round(value)))


class Stim300Codec(StreamingOnPowerUp):
    """STIM300 datagram codec for one configured identifier.

    Parameters
    ----------
    identifier : int
        The datagram the unit is configured to send (default 0x94: rates + temperatures).
    accel_range_g : {10, 30, 80}
        The accelerometer variant (sets the LSB of the acceleration words), g.
    accel : bool
        Decode the accelerometers (only where the datagram carries them): False reads
        an accelerometer datagram as a gyro-only one.

    Raises
    ------
    CodecError
        Unknown identifier or range, or ``accel`` asked of a datagram without them.
    """

    name = "stim300"
    counter_modulus = COUNTER_MODULUS
    n_axes = 3
    has_device_time = False

    def __init__(self, identifier: int = 0x94, *, accel_range_g: int = 10,
                 accel: bool | None = None) -> None:
        if identifier not in DATAGRAMS:
            raise CodecError(f"unknown STIM300 datagram identifier 0x{identifier:02X}")
        if accel_range_g not in ACCEL_LSB_PER_G:
            raise CodecError(f"STIM300 accelerometer range must be 10, 30 or 80 g, "
                             f"got {accel_range_g}")
        carried = DATAGRAMS[identifier][0]
        if accel and not carried:
            raise CodecError(f"STIM300 datagram 0x{identifier:02X} carries no "
                             f"accelerometers (0x91, 0x93, 0xA5 and 0xA7 do)")
        self.identifier = identifier
        self.has_temperature = DATAGRAMS[identifier][2]
        self.n_accel_axes = 3 if carried and accel is not False else 0
        self.accel_range_m_s2: float | None = (
            accel_range_g * STANDARD_GRAVITY_M_S2 if self.n_accel_axes else None)
        self._m_s2_per_lsb = STANDARD_GRAVITY_M_S2 / ACCEL_LSB_PER_G[accel_range_g]
        self._other, self._other_temp, payload = _layout(identifier)
        self.frame_length = 1 + payload + 4

    def _length(self, data: bytes, pos: int) -> int:
        return self.frame_length

    def _parse(self, raw: bytes) -> Stim300Frame | None:
        body, crc = raw[:-4], int.from_bytes(raw[-4:], "big")
        if crc32_mpeg2(_crc_input(body)) != crc:
            return None
        gyro = (_int24(body[1:4]), _int24(body[4:7]), _int24(body[7:10]))
        pos = 11
        other = body[pos:pos + self._other]
        pos += self._other
        temperature = None
        temperature_status = 0
        if self.has_temperature:
            temperature = tuple(
                int.from_bytes(body[pos + 2 * i:pos + 2 * i + 2], "big", signed=True)
                for i in range(3))
            temperature_status = body[pos + 6]
            pos += 7
            other += body[pos:pos + self._other_temp]
            pos += self._other_temp
        return Stim300Frame(
            identifier=body[0], gyro=gyro, gyro_status=body[10], counter=body[pos],
            latency_us=int.from_bytes(body[pos + 1:pos + 3], "big"),
            temperature=temperature, temperature_status=temperature_status,  # type: ignore[arg-type]
            other_clusters=other,
        )

    def decode(self, data: bytes) -> DecodeResult[Stim300Frame]:
        """Datagrams of the configured identifier found in ``data`` (resynchronizing)."""
        return scan_frames(data, bytes([self.identifier]), self._length, self._parse)

    def encode(self, frame: Stim300Frame) -> bytes:
        """Wire bytes of ``frame`` including the CRC.

        Raises
        ------
        CodecError
            A field is out of its wire range or does not fit the identifier.
        """
        if frame.identifier != self.identifier:
            raise CodecError(f"frame identifier 0x{frame.identifier:02X} is not "
                             f"0x{self.identifier:02X}")
        if (frame.temperature is None) == self.has_temperature:
            raise CodecError("temperature presence does not match the identifier")
        if len(frame.other_clusters) != self._other + self._other_temp:
            raise CodecError("other_clusters length does not match the identifier")
        try:
            body = bytearray([frame.identifier])
            for g in frame.gyro:
                body += g.to_bytes(3, "big", signed=True)
            body.append(frame.gyro_status)
            body += frame.other_clusters[:self._other]
            if frame.temperature is not None:
                for t in frame.temperature:
                    body += t.to_bytes(2, "big", signed=True)
                body.append(frame.temperature_status)
                body += frame.other_clusters[self._other:]
            body.append(frame.counter)
            body += frame.latency_us.to_bytes(2, "big")
        except (OverflowError, ValueError) as exc:
            raise CodecError(f"STIM300 field out of range: {exc}") from exc
        return bytes(body) + crc32_mpeg2(_crc_input(bytes(body))).to_bytes(4, "big")

    def to_reading(self, frame: Stim300Frame) -> Reading:
        """Rates in deg/s (value / 2**14), temperature in degC (mean of the triple),
        accelerations in m/s^2 (the range's LSB; status: the gyro and accelerometer
        status bytes, the accelerometer's in bits 8-15)."""
        temperature = None
        if frame.temperature is not None:
            temperature = sum(frame.temperature) / 3 / TEMP_LSB_PER_DEGC
        accel = None
        status = frame.gyro_status
        if self.n_accel_axes:
            raw = frame.other_clusters
            accel = tuple(_int24(raw[3 * i:3 * i + 3]) * self._m_s2_per_lsb for i in range(3))
            status |= raw[9] << 8
        return Reading(
            rate_deg_s=tuple(g / RATE_LSB_PER_DEG_S for g in frame.gyro),
            counter=frame.counter, status=status, temperature_c=temperature,
            accel_m_s2=accel,
        )

    def from_reading(self, reading: Reading) -> Stim300Frame:
        """Quantize a reading to a datagram (rates rounded to 2**-14 deg/s, clipped; the
        accelerations to the range's LSB, clipped, zero when the reading has none)."""
        gyro = tuple(_clip24(r * RATE_LSB_PER_DEG_S) for r in reading.rate_deg_s)
        temperature = None
        if self.has_temperature:
            t = round((reading.temperature_c or 0.0) * TEMP_LSB_PER_DEGC)
            temperature = (t, t, t)
        other = bytearray(self._other + self._other_temp)
        if DATAGRAMS[self.identifier][0]:
            accel = reading.accel_m_s2 or (0.0, 0.0, 0.0)
            for i, a in enumerate(accel[:3]):
                other[3 * i:3 * i + 3] = _clip24(a / self._m_s2_per_lsb).to_bytes(
                    3, "big", signed=True)
            other[9] = (reading.status >> 8) & 0xFF
            if temperature is not None:  # the accelerometers' temperature triple
                pos = self._other
                for i in range(3):
                    other[pos + 2 * i:pos + 2 * i + 2] = temperature[i].to_bytes(
                        2, "big", signed=True)
        return Stim300Frame(
            identifier=self.identifier, gyro=gyro, gyro_status=reading.status & 0xFF,  # type: ignore[arg-type]
            counter=reading.counter % COUNTER_MODULUS, latency_us=0, temperature=temperature,
            other_clusters=bytes(other),
        )
