"""Safran Sensonor STIM300 normal-mode binary datagram (pure codec).

Follows the data sheet TS1524 rev. 31 (its tables live in
:mod:`devices.codecs.stim300_sheet`)::

    ID | rate X,Y,Z (3 x int24 BE) + status | [acceleration 9+1] | [inclination 9+1]
       | [temperature triples 3 x int16 BE + status, one per cluster present]
       | [PPS/AUX int24 + status] | counter (uint8) | latency (uint16 BE, us)
       | CRC-32 (BE) | [CR LF]

* order and lengths: Table 5-20 (full content, identifier 0xAF) with the identifiers of
  Table 5-21 (0x90-0xA7; 0xF0-0xF7 with PPS); lengths checked against Table 5-12;
* CRC-32 (polynomial 0x04C11DB7, seed 0xFFFFFFFF, no reflection: CRC-32/MPEG-2) over the
  identifier to the latency, padded with the zero dummy bytes of Table 5-22 (not sent);
* CR/LF after the CRC where the unit is configured so (Table 5-11, "DATAGRAM
  TERMINATION"): part of the datagram, never skipped bytes;
* scale factors (section 7.5.2.2): angular rate and average angular rate 2**-14 deg/s;
  incremental angle 2**-21 deg per sample (read as the mean rate over the sample, times
  the output rate); acceleration 2**-20, 2**-19, 2**-18, 2**-16 g for the 5, 10, 30, 80 g
  variants (to m/s^2 with 9.80665 m/s^2); incremental velocity 2**-23, 2**-22, 2**-21,
  2**-19 m/s per sample; temperature 2**-8 degC; inclination 2**-22 g. Integrated angle
  and velocity are refused (see :data:`~devices.codecs.stim300_sheet.REFUSED_OUTPUTS`);
* counter (7.5.2.2.18): it counts the internal samples at 2000 Hz, so it advances by
  ``2000 / rate`` per datagram (:attr:`Stim300Codec.counter_step`) and wraps every 0.128 s;
* status bytes (Table 5-23): 0 = OK.

The accelerometer and inclinometer clusters and their temperature triples travel in
:attr:`Stim300Frame.other_clusters` as raw bytes (:meth:`Stim300Codec.clusters` reads
them); the accelerometer cluster is decoded into :attr:`Reading.accel_m_s2` by
:meth:`Stim300Codec.to_reading`.
"""

from __future__ import annotations

from dataclasses import dataclass

from analysis.units.conversions import STANDARD_GRAVITY_M_S2
from devices.codecs.base import DecodeResult, Reading, StreamingOnPowerUp, scan_frames
from devices.codecs.crc import crc32_mpeg2
from devices.codecs.stim300_sheet import (
    ACCEL_LSB_PER_G,
    ACCEL_LSB_PER_M_S,
    ACCEL_OUTPUTS,
    ANGLE_LSB_PER_DEG,
    COUNTER_MODULUS,
    DATAGRAMS,
    GYRO_OUTPUTS,
    INCL_LSB_PER_G,
    OFFERED_RATES_HZ,
    RATE_LSB_PER_DEG_S,
    REFUSED_OUTPUTS,
    TEMP_LSB_PER_DEGC,
    counter_step,
    payload_length,
)
from devices.errors import CodecError

CRLF = b"\r\n"


@dataclass(frozen=True)
class Stim300Frame:
    """One normal-mode datagram, as integers on the wire.

    Attributes
    ----------
    identifier : int
        Datagram identifier (0x90...; Tables 5-20, 5-21).
    gyro : tuple of 3 int
        Raw signed 24-bit gyro outputs (their unit: the configured output, 7.5.2.2.2-5).
    gyro_status : int
        Gyro status byte (Table 5-23; 0 = all good).
    counter : int
        Datagram counter 0..255 (counts the 2000 Hz internal samples, 7.5.2.2.18).
    latency_us : int
        Latency, microseconds 0..65535 (7.5.2.2.19).
    temperature : tuple of 3 int or None
        Raw gyro temperatures (LSB = 2**-8 degC), for identifiers with temperatures.
    temperature_status : int
        Status byte of the gyro temperature triple.
    other_clusters : bytes
        Accelerometer/inclinometer clusters (3 x int24 BE and a status byte each, the
        accelerometer's first), then their temperature triples, raw, in Table 5-20 order.
    aux : int or None
        The PPS/AUX word as sent (24 bits, unsigned here; 7.5.2.2.15-16), for the
        identifiers that carry it (0xF0-0xF7, 0xAF).
    aux_status : int
        Its status byte.
    """

    identifier: int
    gyro: tuple[int, int, int]
    gyro_status: int
    counter: int
    latency_us: int
    temperature: tuple[int, int, int] | None = None
    temperature_status: int = 0
    other_clusters: bytes = b""
    aux: int | None = None
    aux_status: int = 0


@dataclass(frozen=True)
class Stim300Clusters:
    """The accelerometer and inclinometer clusters of a datagram in physical units.

    Attributes
    ----------
    accel_g, incl_g : tuple of 3 float or None
        Accelerations (acceleration output, g) and inclinations (g), None where absent.
    accel_status, incl_status : int
        Their status bytes (Table 5-23).
    gyro_temperature_c, accel_temperature_c, incl_temperature_c : tuple of 3 float or None
        Temperature triples, degC.
    """

    accel_g: tuple[float, ...] | None
    accel_status: int
    incl_g: tuple[float, ...] | None
    incl_status: int
    gyro_temperature_c: tuple[float, ...] | None
    accel_temperature_c: tuple[float, ...] | None
    incl_temperature_c: tuple[float, ...] | None


def _int24(b: bytes) -> int:
    return int.from_bytes(b, "big", signed=True)


def _triple16(b: bytes) -> tuple[int, int, int]:
    return (int.from_bytes(b[0:2], "big", signed=True),
            int.from_bytes(b[2:4], "big", signed=True),
            int.from_bytes(b[4:6], "big", signed=True))


def _clip24(value: float) -> int:
    lim = 2**23 - 1
    return max(-lim - 1, min(lim, round(value)))


def _crc_input(body: bytes) -> bytes:
    """The CRC's input: the datagram to the latency and the zero dummy bytes that make
    it whole 32-bit words (Table 5-22)."""
    return body + b"\x00" * (-len(body) % 4)


class Stim300Codec(StreamingOnPowerUp):
    """STIM300 datagram codec for one configured unit.

    Parameters
    ----------
    identifier : int
        The datagram the unit is configured to send (default 0x94: rates + temperatures).
    accel_range_g : {5, 10, 30, 80}
        The accelerometer variant (sets the LSB of the acceleration words), g.
    accel : bool
        Decode the accelerometers (only where the datagram carries them): False reads
        an accelerometer datagram as a gyro-only one.
    rate_hz : float or None
        The output sample rate the unit is configured to, Hz (125, 250, 500, 1000 or
        2000, Table 5-11): the counter then advances by ``2000 / rate_hz`` per datagram.
        None: the framing borrowed by a simulated unit of another model, whose counter
        counts its datagrams (step 1); no incremental output then.
    crlf : bool
        The unit terminates each datagram with CR LF (Table 5-11, "DATAGRAM TERMINATION").
    gyro_output : {"rate", "average", "incremental"}
        The gyro output unit configured (Table 5-11): angular rate, average angular rate
        (both deg/s) or incremental angle (deg per sample, read as deg/s over the sample).
    accel_output : {"acceleration", "average", "incremental"}
        The accelerometer output unit: acceleration, average acceleration (g) or
        incremental velocity (m/s per sample, read as m/s^2 over the sample).

    Raises
    ------
    CodecError
        An identifier, range, rate or output unit the unit does not have, or ``accel``
        asked of a datagram without accelerometers.
    """

    name = "stim300"
    counter_modulus = COUNTER_MODULUS
    n_axes = 3
    has_device_time = False

    def __init__(self, identifier: int = 0x94, *, accel_range_g: int = 10,
                 accel: bool | None = None, rate_hz: float | None = None,
                 crlf: bool = False, gyro_output: str = "rate",
                 accel_output: str = "acceleration") -> None:
        if identifier not in DATAGRAMS:
            raise CodecError(f"unknown STIM300 datagram identifier 0x{identifier:02X} "
                             f"(TS1524 Tables 5-20, 5-21: "
                             f"{', '.join(f'0x{i:02X}' for i in sorted(DATAGRAMS))})")
        if accel_range_g not in ACCEL_LSB_PER_G:
            raise CodecError(f"STIM300 accelerometer range must be 5, 10, 30 or 80 g, "
                             f"got {accel_range_g}")
        content = DATAGRAMS[identifier]
        if accel and not content.accel:
            raise CodecError(f"STIM300 datagram 0x{identifier:02X} carries no "
                             f"accelerometers (0x91, 0x93, 0xA5, 0xA7, 0xF1, 0xF3, 0xF5, "
                             f"0xF7 and 0xAF do)")
        for what, value, offered in (("gyro_output", gyro_output, GYRO_OUTPUTS),
                                     ("accel_output", accel_output, ACCEL_OUTPUTS)):
            if value in REFUSED_OUTPUTS:
                raise CodecError(f"STIM300 {what}={value} is not read: "
                                 f"{REFUSED_OUTPUTS[value]}; use {' or '.join(offered)}")
            if value not in offered:
                raise CodecError(f"STIM300 {what} must be {', '.join(offered)}, got {value!r}")
        if rate_hz is None:
            self.counter_step = 1
            if "incremental" in (gyro_output, accel_output):
                raise CodecError("a STIM300 incremental output needs the unit's rate")
        else:
            try:
                self.counter_step = counter_step(rate_hz)
            except ValueError:
                raise CodecError(
                    f"a STIM300 sends at {', '.join(map(str, OFFERED_RATES_HZ))} samples/s "
                    f"(TS1524 Table 5-11), not {rate_hz:g} Hz") from None
        self.identifier = identifier
        self.content = content
        self.rate_hz = rate_hz
        self.crlf = crlf
        self.has_temperature = content.temperature
        self.n_accel_axes = 3 if content.accel and accel is not False else 0
        self.accel_range_m_s2: float | None = (
            accel_range_g * STANDARD_GRAVITY_M_S2 if self.n_accel_axes else None)
        # deg/s per gyro LSB; m/s^2 per accelerometer LSB (section 7.5.2.2)
        per_sample = float(rate_hz or 0.0)
        self._deg_s_per_lsb = (per_sample / ANGLE_LSB_PER_DEG if gyro_output == "incremental"
                               else 1.0 / RATE_LSB_PER_DEG_S)
        self._g_per_lsb = 1.0 / ACCEL_LSB_PER_G[accel_range_g]
        self._m_s2_per_lsb = (per_sample / ACCEL_LSB_PER_M_S[accel_range_g]
                              if accel_output == "incremental"
                              else STANDARD_GRAVITY_M_S2 * self._g_per_lsb)
        n_other = int(content.accel) + int(content.incl)
        self._other = 10 * n_other
        self._other_temp = 7 * n_other if content.temperature else 0
        self.frame_length = payload_length(content) + 4 + (2 if crlf else 0)

    def _length(self, data: bytes, pos: int) -> int:
        return self.frame_length

    def _parse(self, raw: bytes) -> Stim300Frame | None:
        if self.crlf:
            if raw[-2:] != CRLF:
                return None
            raw = raw[:-2]
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
            temperature = _triple16(body[pos:pos + 6])
            temperature_status = body[pos + 6]
            pos += 7
            other += body[pos:pos + self._other_temp]
            pos += self._other_temp
        aux = None
        aux_status = 0
        if self.content.aux:
            aux = int.from_bytes(body[pos:pos + 3], "big")
            aux_status = body[pos + 3]
            pos += 4
        return Stim300Frame(
            identifier=body[0], gyro=gyro, gyro_status=body[10], counter=body[pos],
            latency_us=int.from_bytes(body[pos + 1:pos + 3], "big"),
            temperature=temperature, temperature_status=temperature_status,
            other_clusters=other, aux=aux, aux_status=aux_status,
        )

    def decode(self, data: bytes) -> DecodeResult[Stim300Frame]:
        """Datagrams of the configured identifier found in ``data`` (resynchronizing)."""
        return scan_frames(data, bytes([self.identifier]), self._length, self._parse)

    def encode(self, frame: Stim300Frame) -> bytes:
        """Wire bytes of ``frame`` including the CRC (and CR LF where configured).

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
        if (frame.aux is None) == self.content.aux:
            raise CodecError("PPS/AUX presence does not match the identifier")
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
            if frame.aux is not None:
                body += frame.aux.to_bytes(3, "big")
                body.append(frame.aux_status)
            body.append(frame.counter)
            body += frame.latency_us.to_bytes(2, "big")
        except (OverflowError, ValueError) as exc:
            raise CodecError(f"STIM300 field out of range: {exc}") from exc
        wire = bytes(body) + crc32_mpeg2(_crc_input(bytes(body))).to_bytes(4, "big")
        return wire + CRLF if self.crlf else wire

    def clusters(self, frame: Stim300Frame) -> Stim300Clusters:
        """The frame's accelerometer and inclinometer clusters and its temperatures in
        physical units (accelerations at the acceleration output's scale, g)."""
        raw = frame.other_clusters
        pos = 0

        def cluster(present: bool) -> tuple[tuple[int, ...] | None, int]:
            nonlocal pos
            if not present:
                return None, 0
            words = tuple(_int24(raw[pos + 3 * i:pos + 3 * i + 3]) for i in range(3))
            status = raw[pos + 9]
            pos += 10
            return words, status

        accel, accel_status = cluster(self.content.accel)
        incl, incl_status = cluster(self.content.incl)
        temps: list[tuple[float, ...] | None] = [None, None]
        if self.has_temperature:
            for i, present in enumerate((self.content.accel, self.content.incl)):
                if present:
                    temps[i] = tuple(t / TEMP_LSB_PER_DEGC for t in _triple16(raw[pos:pos + 6]))
                    pos += 7
        gyro_t = (None if frame.temperature is None
                  else tuple(t / TEMP_LSB_PER_DEGC for t in frame.temperature))
        return Stim300Clusters(
            accel_g=None if accel is None else tuple(a * self._g_per_lsb for a in accel),
            accel_status=accel_status,
            incl_g=None if incl is None else tuple(v / INCL_LSB_PER_G for v in incl),
            incl_status=incl_status, gyro_temperature_c=gyro_t,
            accel_temperature_c=temps[0], incl_temperature_c=temps[1])

    def to_reading(self, frame: Stim300Frame) -> Reading:
        """Rates in deg/s, temperature in degC (mean of the gyro triple), accelerations
        in m/s^2 (section 7.5.2.2 scale factors of the configured outputs and range).

        ``device_status`` is the gyro status byte, the accelerometer's in bits 8-15
        (where decoded) and the gyro temperature's in bits 16-23 (where sent);
        ``status`` is the same word: 0 where every one of those bytes is 0 (Table 5-23:
        0 = OK), non-zero where the unit flags the sample or part of it.
        """
        temperature = None
        word = frame.gyro_status
        if frame.temperature is not None:
            temperature = sum(frame.temperature) / 3 / TEMP_LSB_PER_DEGC
            word |= frame.temperature_status << 16
        accel = None
        if self.n_accel_axes:
            raw = frame.other_clusters
            accel = tuple(_int24(raw[3 * i:3 * i + 3]) * self._m_s2_per_lsb for i in range(3))
            word |= raw[9] << 8
        return Reading(
            rate_deg_s=tuple(g * self._deg_s_per_lsb for g in frame.gyro),
            counter=frame.counter, status=word, temperature_c=temperature,
            accel_m_s2=accel, device_status=word,
        )

    def from_reading(self, reading: Reading) -> Stim300Frame:
        """Quantize a reading to a datagram (rates rounded to the gyro output's LSB,
        clipped; the accelerations to the range's LSB, clipped, zero when the reading has
        none). The counter is the reading's sample index times :attr:`counter_step`,
        modulo 256 (a data sheet unit's counter: 7.5.2.2.18)."""
        gyro = tuple(_clip24(r / self._deg_s_per_lsb) for r in reading.rate_deg_s)
        temperature = None
        if self.has_temperature:
            t = round((reading.temperature_c or 0.0) * TEMP_LSB_PER_DEGC)
            temperature = (t, t, t)
        other = bytearray(self._other + self._other_temp)
        if self.content.accel:
            accel = reading.accel_m_s2 or (0.0, 0.0, 0.0)
            for i, a in enumerate(accel[:3]):
                other[3 * i:3 * i + 3] = _clip24(a / self._m_s2_per_lsb).to_bytes(
                    3, "big", signed=True)
            other[9] = (reading.status >> 8) & 0xFF
        if temperature is not None:  # the other clusters' temperature triples
            for pos in range(self._other, self._other + self._other_temp, 7):
                for i in range(3):
                    other[pos + 2 * i:pos + 2 * i + 2] = temperature[i].to_bytes(
                        2, "big", signed=True)
        return Stim300Frame(
            identifier=self.identifier, gyro=gyro, gyro_status=reading.status & 0xFF,  # type: ignore[arg-type]
            counter=(reading.counter * self.counter_step) % COUNTER_MODULUS, latency_us=0,
            temperature=temperature,
            temperature_status=(reading.status >> 16) & 0xFF if temperature else 0,
            other_clusters=bytes(other), aux=0 if self.content.aux else None,
        )
