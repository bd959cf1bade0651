"""KVH DSP-1750 "format A" binary message (pure codec).

36 bytes, big-endian (KVH DSP-1750 technical manual, message format A)::

    FE 81 FF 55 | gyro X,Y,Z (3 x float32) | accel X,Y,Z (3 x float32, g)
               | status (bits 0-2: gyro X/Y/Z valid) | sequence 0..127
               | temperature (int16, degC) | CRC-32/MPEG-2 over bytes 0..31

The gyro words are a rate or a delta angle (per sample), in rad or deg, by the unit's
configuration; :class:`Kvh1750Codec` takes both as parameters. The accelerometer words
(g, +-10 g range) become :attr:`Reading.accel_m_s2` (x 9.80665 m/s^2 per g).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from typing import Literal

from analysis.units.conversions import STANDARD_GRAVITY_M_S2
from devices.codecs.base import DecodeResult, Reading, StreamingOnPowerUp, scan_frames
from devices.codecs.crc import crc32_mpeg2
from devices.errors import CodecError

HEADER = bytes.fromhex("FE81FF55")
FRAME_LENGTH = 36
COUNTER_MODULUS = 128
GYRO_VALID = 0x07
#: Accelerometer measurement range of the DSP-1750, g.
ACCEL_RANGE_G = 10.0
_BODY = struct.Struct(">4s6fBBh")


@dataclass(frozen=True)
class Kvh1750Frame:
    """One format-A message as sent.

    Attributes
    ----------
    gyro : tuple of 3 float
        Rate or delta angle per axis, in the configured unit (float32 values).
    accel_g : tuple of 3 float
        Acceleration, g.
    status : int
        Status byte; bits 0-2 set when the X/Y/Z gyro data are valid.
    sequence : int
        Sequence number 0..127.
    temperature_c : int
        Temperature, degC.
    """

    gyro: tuple[float, float, float]
    accel_g: tuple[float, float, float]
    status: int
    sequence: int
    temperature_c: int


def _f32(x: float) -> float:
    return float(struct.unpack(">f", struct.pack(">f", x))[0])


class Kvh1750Codec(StreamingOnPowerUp):
    """DSP-1750 format-A codec.

    Parameters
    ----------
    angle_unit : {"deg", "rad"}
        Unit of the gyro words.
    output : {"rate", "delta"}
        Whether the gyro words are rates (unit/s) or delta angles (unit per sample).
    sample_rate_hz : float
        Output rate (Hz), used to turn delta angles into rates.
    accel : bool
        Decode the accelerometer words (every message carries them).
    """

    name = "kvh1750"
    counter_modulus = COUNTER_MODULUS
    n_axes = 3
    has_device_time = False
    has_temperature = True
    frame_length = FRAME_LENGTH

    def __init__(self, angle_unit: Literal["deg", "rad"] = "deg",
                 output: Literal["rate", "delta"] = "rate", sample_rate_hz: float = 1000.0,
                 *, accel: bool = True) -> None:
        if angle_unit not in ("deg", "rad") or output not in ("rate", "delta"):
            raise CodecError(f"unsupported KVH configuration {angle_unit!r}/{output!r}")
        if not (sample_rate_hz > 0 and math.isfinite(sample_rate_hz)):
            raise CodecError(f"sample_rate_hz must be finite and > 0, got {sample_rate_hz}")
        deg = 1.0 if angle_unit == "deg" else 180.0 / math.pi
        self._to_deg_s = deg * (sample_rate_hz if output == "delta" else 1.0)
        self.n_accel_axes = 3 if accel else 0
        self.accel_range_m_s2: float | None = (
            ACCEL_RANGE_G * STANDARD_GRAVITY_M_S2 if accel else None)

    def _parse(self, raw: bytes) -> Kvh1750Frame | None:
        if crc32_mpeg2(raw[:32]) != int.from_bytes(raw[32:], "big"):
            return None
        _, gx, gy, gz, ax, ay, az, status, seq, temp = _BODY.unpack(raw[:32])
        return Kvh1750Frame((gx, gy, gz), (ax, ay, az), status, seq, temp)

    def decode(self, data: bytes) -> DecodeResult[Kvh1750Frame]:
        """Messages found in ``data`` (resynchronizing on the 4-byte header)."""
        return scan_frames(data, HEADER, lambda d, p: FRAME_LENGTH, self._parse)

    def encode(self, frame: Kvh1750Frame) -> bytes:
        """Wire bytes of ``frame`` (floats must be float32-representable to round-trip).

        Raises
        ------
        CodecError
            Sequence, status or temperature out of range.
        """
        if not 0 <= frame.sequence < COUNTER_MODULUS:
            raise CodecError(f"KVH sequence must be 0..127, got {frame.sequence}")
        try:
            body = _BODY.pack(HEADER, *frame.gyro, *frame.accel_g, frame.status,
                              frame.sequence, frame.temperature_c)
        except (struct.error, OverflowError) as exc:
            raise CodecError(f"KVH field out of range: {exc}") from exc
        return body + crc32_mpeg2(body).to_bytes(4, "big")

    def to_reading(self, frame: Kvh1750Frame) -> Reading:
        """Rates in deg/s, accelerations in m/s^2; status 0 when all three gyros are
        valid, else the missing bits."""
        return Reading(
            rate_deg_s=tuple(g * self._to_deg_s for g in frame.gyro),
            counter=frame.sequence, status=(~frame.status) & GYRO_VALID,
            temperature_c=float(frame.temperature_c),
            accel_m_s2=(tuple(a * STANDARD_GRAVITY_M_S2 for a in frame.accel_g)
                        if self.n_accel_axes else None),
        )

    def from_reading(self, reading: Reading) -> Kvh1750Frame:
        """Frame for a reading: rates to float32 in the configured unit, accelerations to
        float32 g (1 g up z when the reading has none), degC rounded."""
        gyro = tuple(_f32(r / self._to_deg_s) for r in reading.rate_deg_s)
        accel = (tuple(_f32(a / STANDARD_GRAVITY_M_S2) for a in reading.accel_m_s2)
                 if reading.accel_m_s2 is not None else (0.0, 0.0, 1.0))
        return Kvh1750Frame(
            gyro=gyro, accel_g=accel,  # type: ignore[arg-type]
            status=GYRO_VALID & ~reading.status, sequence=reading.counter % COUNTER_MODULUS,
            temperature_c=round(reading.temperature_c or 0.0),
        )
