"""KVH DSP-1750 / 1775 binary messages, formats A, B and C (pure codec).

Big-endian; SPFP is an IEEE-754 float32 (KVH ICD 56-0298 rev. B, the 1775 IMU technical
manual's appendix C, section 5). Byte numbers as the tables count them (from 1)::

    format A (Tables 5-1, 5-2; the default)  36 bytes  header FE 81 FF 55
    format B (Tables 5-3, 5-4)               40 bytes  header FE 81 FF 56
    format C (Tables 5-5, 5-6, 5-7)          38 bytes  header FE 81 FF 57

    5-16   gyro X, Y, Z (SPFP): rad or deg, a rate or a delta angle, by configuration
    17-28  accel X, Y, Z (SPFP, g)
    A: 29 status | 30 sequence 0..127 | 31-32 temperature (INT16) | 33-36 CRC
    B: 29-32 time stamp (UINT32, us) | 33 status | 34 sequence | 35-36 temperature
       (INT16) | 37-40 CRC
    C: 29-32 temperature or magnetic field (SPFP) by sequence modulo 4 | 33 status |
       34 sequence | 35-38 CRC

* Status (Table 5-8): bits 0-2 gyro X/Y/Z valid, bits 4-6 accelerometer X/Y/Z valid
  (1 = valid), bits 3 and 7 always 0 (so that the status cannot complete a header).
* Temperature (Tables 5-2, 5-4): degC, 1/100 degC, degF or 1/100 degF, as the unit's
  TEMPUNITS setting says; the message does not say which, so the station is told
  (``tempunits=``). Format C sends the temperature as SPFP in the same unit (the note
  under Table 5-7: its 1/100 setting adds precision), in the messages whose sequence
  number is a multiple of 4; the other three carry the magnetic field X, Y, Z (Table 5-7;
  the order as RISE-Maritime's Keelson KVH connector, after OpenDLV's
  opendlv-device-imu-kvhp1775, reads it: the copy of the table consulted was not legible),
  which the station does not record.
* CRC (Table 5-9): CRC-32, polynomial 0x04C11DB7, initial 0xFFFFFFFF, not reflected, no
  final XOR (CRC-32/MPEG-2) over every byte before it.

The decoder finds messages of all three formats by their headers, so the layout is never
in doubt. A codec told the unit's format (``message_format``) describes it (a device time
with format B) and refuses a message of another format by name
(:class:`~devices.errors.DeviceProtocolError`); one told nothing reads all three, and
describes no device time (a format-B time stamp still helps count gaps).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from typing import Literal, get_args

from analysis.units.conversions import STANDARD_GRAVITY_M_S2
from devices.codecs.base import DecodeResult, Reading, StreamingOnPowerUp, scan_frames
from devices.codecs.crc import crc32_mpeg2
from devices.errors import CodecError, DeviceProtocolError

MessageFormat = Literal["A", "B", "C"]
TempUnits = Literal["C", "F", "0.01C", "0.01F"]
MESSAGE_FORMATS: tuple[MessageFormat, ...] = get_args(MessageFormat)
TEMP_UNITS: tuple[TempUnits, ...] = get_args(TempUnits)

#: First three header bytes, common to the three formats; the fourth names the format.
SYNC = bytes.fromhex("FE81FF")
#: Header of each format (Tables 5-1, 5-3, 5-5).
HEADERS: dict[MessageFormat, bytes] = {"A": SYNC + b"\x55", "B": SYNC + b"\x56",
                                       "C": SYNC + b"\x57"}
_FORMAT_BY_ID = {header[3]: fmt for fmt, header in HEADERS.items()}
#: Message bytes before the CRC of each format.
_BODIES: dict[MessageFormat, struct.Struct] = {
    "A": struct.Struct(">4s6fBBh"), "B": struct.Struct(">4s6fIBBh"), "C": struct.Struct(">4s7fBB")}
#: Whole message length of each format, bytes (36, 40, 38).
FRAME_LENGTHS: dict[MessageFormat, int] = {f: body.size + 4 for f, body in _BODIES.items()}
COUNTER_MODULUS = 128
#: Status bits (Table 5-8), 1 = valid.
GYRO_VALID = 0x07
ACCEL_VALID = 0x70
#: Status bits the document says are always 0.
STATUS_RESERVED = 0x88
#: Accelerometer measurement range of the DSP-1750, g.
ACCEL_RANGE_G = 10.0
#: Format C: the sequence number modulo 4 of the messages that carry the temperature.
TEMPERATURE_SLOT = 0
_TEMPERATURE_SCALE: dict[TempUnits, float] = {"C": 1.0, "F": 1.0, "0.01C": 0.01, "0.01F": 0.01}


def word_to_celsius(word: float, tempunits: TempUnits) -> float:
    """Temperature (degC) of a message's temperature word in the unit's TEMPUNITS unit."""
    value = word * _TEMPERATURE_SCALE[tempunits]
    return (value - 32.0) * 5.0 / 9.0 if tempunits.endswith("F") else value


def celsius_to_word(temperature_c: float, tempunits: TempUnits) -> float:
    """The temperature word (unrounded) a unit set to ``tempunits`` sends for
    ``temperature_c`` (degC): the inverse of :func:`word_to_celsius`."""
    value = temperature_c * 9.0 / 5.0 + 32.0 if tempunits.endswith("F") else temperature_c
    return value / _TEMPERATURE_SCALE[tempunits]


@dataclass(frozen=True)
class Kvh1750Frame:
    """One message as sent.

    Attributes
    ----------
    gyro : tuple of 3 float
        Rate or delta angle per axis, in the configured unit (float32 values).
    accel_g : tuple of 3 float
        Acceleration, g.
    status : int
        Status byte (Table 5-8): bits 0-2 gyro X/Y/Z valid, bits 4-6 accelerometer X/Y/Z
        valid.
    sequence : int
        Sequence number 0..127.
    temperature : float
        Formats A and B: the INT16 temperature word (an int) in the TEMPUNITS unit.
        Format C: the SPFP word of bytes 29-32: the temperature in that unit where
        ``sequence % 4 == 0``, else the magnetic field X, Y or Z.
    message_format : {"A", "B", "C"}
        Which message (its header).
    timestamp_us : int
        Format B's time stamp, us (UINT32); 0 in the other formats.
    """

    gyro: tuple[float, float, float]
    accel_g: tuple[float, float, float]
    status: int
    sequence: int
    temperature: float
    message_format: MessageFormat = "A"
    timestamp_us: int = 0


def _f32(x: float) -> float:
    return float(struct.unpack(">f", struct.pack(">f", x))[0])


def _frame_length(data: bytes, pos: int) -> int | None:
    """Length of the message whose header starts at ``pos`` (None: the fourth header
    byte is not there yet; 0: not a data message)."""
    if pos + 4 > len(data):
        return None
    fmt = _FORMAT_BY_ID.get(data[pos + 3])
    return FRAME_LENGTHS[fmt] if fmt else 0


def _parse(raw: bytes) -> Kvh1750Frame | None:
    """The message in ``raw`` (one whole message), or None when its CRC fails."""
    if crc32_mpeg2(raw[:-4]) != int.from_bytes(raw[-4:], "big"):
        return None
    fmt = _FORMAT_BY_ID[raw[3]]
    fields = _BODIES[fmt].unpack(raw[:-4])
    gyro, accel = fields[1:4], fields[4:7]
    if fmt == "A":
        status, seq, temp = fields[7:]
        stamp = 0
    elif fmt == "B":
        stamp, status, seq, temp = fields[7:]
    else:
        temp, status, seq = fields[7:]
        stamp = 0
    return Kvh1750Frame(gyro, accel, status, seq, temp, fmt, stamp)


class Kvh1750Codec(StreamingOnPowerUp):
    """DSP-1750 / 1775 codec of formats A, B and C.

    Parameters
    ----------
    angle_unit : {"deg", "rad"}
        Unit of the gyro words.
    output : {"rate", "delta"}
        Whether the gyro words are rates (unit/s) or delta angles (unit per sample).
    sample_rate_hz : float
        Output rate (Hz), used to turn delta angles into rates.
    accel : bool
        Decode the accelerometer words (every message carries them); their valid bits
        then count in :attr:`Reading.status`.
    message_format : {"A", "B", "C"} or None
        The format the unit is set to send (A is its default), or None: whichever
        arrives (no device time described).
    tempunits : {"C", "F", "0.01C", "0.01F"}
        The unit's temperature setting: degC, degF, or hundredths of either.

    Raises
    ------
    CodecError
        An unknown unit, output, format or temperature unit, or a rate that is not
        finite and > 0.
    """

    name = "kvh1750"
    counter_modulus = COUNTER_MODULUS
    n_axes = 3
    has_temperature = True

    def __init__(self, angle_unit: Literal["deg", "rad"] = "deg",
                 output: Literal["rate", "delta"] = "rate", sample_rate_hz: float = 1000.0,
                 *, accel: bool = True, message_format: MessageFormat | None = None,
                 tempunits: TempUnits = "C") -> None:
        if angle_unit not in ("deg", "rad") or output not in ("rate", "delta"):
            raise CodecError(f"unsupported KVH configuration {angle_unit!r}/{output!r}")
        if message_format is not None and message_format not in MESSAGE_FORMATS:
            raise CodecError(f"KVH format={message_format!r} must be A, B or C (the message "
                             f"the unit sends: header 0xFE81FF55, 56 or 57)")
        if tempunits not in TEMP_UNITS:
            raise CodecError(f"KVH tempunits={tempunits!r} must be C, F, 0.01C or 0.01F "
                             f"(the unit's temperature setting)")
        if not (sample_rate_hz > 0 and math.isfinite(sample_rate_hz)):
            raise CodecError(f"sample_rate_hz must be finite and > 0, got {sample_rate_hz}")
        self.angle_unit = angle_unit
        self.output = output
        self.sample_rate_hz = sample_rate_hz
        self.message_format: MessageFormat | None = message_format
        self.tempunits: TempUnits = tempunits
        self.has_device_time = message_format == "B"
        deg = 1.0 if angle_unit == "deg" else 180.0 / math.pi
        self._to_deg_s = deg * (sample_rate_hz if output == "delta" else 1.0)
        self.n_accel_axes = 3 if accel else 0
        self.accel_range_m_s2: float | None = (
            ACCEL_RANGE_G * STANDARD_GRAVITY_M_S2 if accel else None)
        self._valid_bits = GYRO_VALID | (ACCEL_VALID if accel else 0)

    def decode(self, data: bytes) -> DecodeResult[Kvh1750Frame]:
        """Messages of any of the three formats found in ``data`` (resynchronizing on the
        header)."""
        return scan_frames(data, SYNC, _frame_length, _parse)

    def encode(self, frame: Kvh1750Frame) -> bytes:
        """Wire bytes of ``frame`` (floats must be float32-representable to round-trip).

        Raises
        ------
        CodecError
            Unknown format; sequence, status, time stamp or temperature out of range (a
            format A or B temperature must be an integer).
        """
        fmt = frame.message_format
        if fmt not in MESSAGE_FORMATS:
            raise CodecError(f"KVH format must be A, B or C, got {fmt!r}")
        if not 0 <= frame.sequence < COUNTER_MODULUS:
            raise CodecError(f"KVH sequence must be 0..127, got {frame.sequence}")
        if fmt == "A":
            tail: tuple[float, ...] = (frame.status, frame.sequence, frame.temperature)
        elif fmt == "B":
            tail = (frame.timestamp_us, frame.status, frame.sequence, frame.temperature)
        else:
            tail = (frame.temperature, frame.status, frame.sequence)
        try:
            body = _BODIES[fmt].pack(HEADERS[fmt], *frame.gyro, *frame.accel_g, *tail)
        except (struct.error, OverflowError) as exc:
            raise CodecError(f"KVH field out of range: {exc}") from exc
        return body + crc32_mpeg2(body).to_bytes(4, "big")

    def to_reading(self, frame: Kvh1750Frame) -> Reading:
        """Rates in deg/s, accelerations in m/s^2, temperature in degC.

        ``status`` is 0 when every present sensor's valid bit is set (the gyros, and the
        accelerometers unless they are left out), else those missing bits, with any
        reserved bit that is set; ``device_status`` is the status byte as sent. Format C
        messages that carry the magnetic field give no temperature (None).

        Raises
        ------
        DeviceProtocolError
            A message of another format than the codec was told: the unit is set
            otherwise than the URL says.
        """
        fmt = frame.message_format
        if self.message_format is not None and fmt != self.message_format:
            raise DeviceProtocolError(
                f"kvh1750: the unit sends format {fmt} messages (header 0x"
                f"{HEADERS[fmt].hex().upper()}) but the URL says format="
                f"{self.message_format}: give format={fmt}")
        if fmt == "C" and frame.sequence % 4 != TEMPERATURE_SLOT:
            temperature_c = None
        else:
            temperature_c = word_to_celsius(frame.temperature, self.tempunits)
        status = (~frame.status & self._valid_bits) | (frame.status & STATUS_RESERVED)
        return Reading(
            rate_deg_s=tuple(g * self._to_deg_s for g in frame.gyro),
            counter=frame.sequence, status=status,
            device_time_s=frame.timestamp_us * 1e-6 if fmt == "B" else None,
            temperature_c=temperature_c,
            accel_m_s2=(tuple(a * STANDARD_GRAVITY_M_S2 for a in frame.accel_g)
                        if self.n_accel_axes else None),
            device_status=frame.status,
        )

    def from_reading(self, reading: Reading) -> Kvh1750Frame:
        """Frame of the codec's format (A when it was told none) for a reading: rates to
        float32 in the configured unit, accelerations to float32 g (1 g up z when the
        reading has none), the temperature in the TEMPUNITS unit (rounded to the INT16 in
        formats A and B; format C sends 0 in the magnetic-field slots), the status bits of
        the reading's status cleared, the device time in us (format B, modulo 2^32)."""
        fmt = self.message_format or "A"
        gyro = tuple(_f32(r / self._to_deg_s) for r in reading.rate_deg_s)
        accel = (tuple(_f32(a / STANDARD_GRAVITY_M_S2) for a in reading.accel_m_s2)
                 if reading.accel_m_s2 is not None else (0.0, 0.0, 1.0))
        sequence = reading.counter % COUNTER_MODULUS
        word = celsius_to_word(reading.temperature_c or 0.0, self.tempunits)
        temperature: float
        if fmt != "C":
            temperature = round(word)
        else:
            temperature = _f32(word) if sequence % 4 == TEMPERATURE_SLOT else 0.0
        stamp = (round((reading.device_time_s or 0.0) * 1e6) % 2**32) if fmt == "B" else 0
        status = ((GYRO_VALID | ACCEL_VALID) & ~reading.status) | (
            reading.status & STATUS_RESERVED)
        return Kvh1750Frame(gyro=gyro, accel_g=accel,  # type: ignore[arg-type]
                            status=status & 0xFF, sequence=sequence, temperature=temperature,
                            message_format=fmt, timestamp_us=stamp)
