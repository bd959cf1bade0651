"""Raw CAN frame layout of a gyro or IMU that broadcasts its rates (pure codec).

A :class:`CanFrameLayout` says where each value sits: arbitration ID (one per axis or
one shared), byte offset, width, signedness, byte order, scale and offset; an IMU's
layout also places its accelerations (m/s^2), a unit's status bits are bit fields.
A layout may protect its frames as AUTOSAR E2E Profile 1 does (:mod:`devices.codecs.e2e_p01`:
a 4-bit alive counter 0..14 and the Profile 1 CRC over the DataID and every other data
byte), carry a plain rolling counter (8 bits, or 4 bits running 0..15), or neither
(``crc = "none"``, ``counter_bits = 0``). Layouts load from a TOML table
(:meth:`CanFrameLayout.from_table`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any, Literal

from devices.codecs.base import Reading
from devices.codecs.can_layout_table import layout_options
from devices.codecs.can_signals import CanBitField, CanFrameValues, CanSignal
from devices.codecs.e2e_p01 import (
    ALIVE_COUNTER_BITS,
    ALIVE_COUNTER_MODULUS,
    DATA_ID_MODES,
    DataIdMode,
    p01_crc,
)
from devices.errors import CodecError, CrcError, FrameError

#: The layout and its parts (the signals and frame values re-exported from
#: :mod:`devices.codecs.can_signals`), and the built-in layouts.
__all__ = ["CanBitField", "CanFrameLayout", "CanFrameValues", "CanSignal", "CrcKind",
           "PER_AXIS_IMU_LAYOUT", "PER_AXIS_LAYOUT", "SHARED_ACCEL_LSB_M_S2",
           "SHARED_IMU_LAYOUT", "SHARED_LAYOUT", "SHARED_RATE_LSB_DEG_S"]

CrcKind = Literal["e2e_p01", "none"]


@dataclass(frozen=True)
class CanFrameLayout:
    """Where a broadcasting gyro puts its rates, counter, CRC and status bits.

    Attributes
    ----------
    axes : tuple of CanSignal
        One rate signal per axis, deg/s.
    temperature : CanSignal or None
        Temperature signal, degC.
    accel : tuple of CanSignal
        One acceleration signal per accelerometer axis of an IMU, m/s^2 (empty: a gyro,
        or accelerometers left out).
    status : tuple of CanBitField
        The unit's status fields; a sample's ``device_status`` is their values side by
        side, the first in the low bits, and its ``status`` that word's invalid bits.
    counter_byte, counter_bits : int
        The counter's byte and width: 4 (a nibble of that byte), 8, or 0 (no counter:
        the station counts lost samples from the frames' time stamps alone).
    counter_nibble : {"low", "high"}
        Which nibble a 4-bit counter is in.
    counter_modulus : int
        The counter's wrap; 0 (the default) means Profile 1's for 4 bits (15: 0..14),
        256 for 8 bits, 1 with no counter. A 4-bit counter that runs 0..15 says 16.
    crc : {"e2e_p01", "none"}
        The AUTOSAR E2E Profile 1 CRC in ``crc_byte``, or none.
    crc_byte : int
        Position of the CRC (Profile 1's CRCOffset / 8).
    data_id : int
        16-bit E2E DataID folded into the CRC.
    data_id_mode : {"both", "low", "alt", "nibble"}
        How the DataID goes into the CRC (``nibble``: the low nibble of its high byte is
        sent in the counter byte's other nibble).
    dlc : int
        Data length of every frame.
    """

    axes: tuple[CanSignal, ...]
    temperature: CanSignal | None = None
    accel: tuple[CanSignal, ...] = ()
    status: tuple[CanBitField, ...] = ()
    counter_byte: int = 6
    counter_bits: int = 8
    counter_nibble: Literal["low", "high"] = "low"
    counter_modulus: int = 0
    crc: CrcKind = "e2e_p01"
    crc_byte: int = 7
    data_id: int = 0
    data_id_mode: DataIdMode = "both"
    dlc: int = 8

    def __post_init__(self) -> None:
        if self.counter_bits not in (0, 4, 8):
            raise CodecError("counter_bits must be 0 (no counter), 4 or 8")
        if self.counter_nibble not in ("low", "high"):
            raise CodecError("counter_nibble must be \"low\" or \"high\"")
        if not self.counter_modulus:
            default = {0: 1, ALIVE_COUNTER_BITS: ALIVE_COUNTER_MODULUS, 8: 256}
            object.__setattr__(self, "counter_modulus", default[self.counter_bits])
        if self.counter_bits and not 2 <= self.counter_modulus <= 1 << self.counter_bits or \
                not self.counter_bits and self.counter_modulus != 1:
            raise CodecError(f"counter_modulus {self.counter_modulus} does not fit a "
                             f"{self.counter_bits}-bit counter")
        if self.crc not in ("e2e_p01", "none"):
            raise CodecError("crc must be \"e2e_p01\" or \"none\"")
        if self.data_id_mode not in DATA_ID_MODES or not 0 <= self.data_id <= 0xFFFF:
            raise CodecError(f"data_id_mode must be one of {', '.join(DATA_ID_MODES)} and "
                             "data_id 0..0xFFFF")
        if self.data_id_mode == "nibble" and (self.counter_bits != ALIVE_COUNTER_BITS
                                              or self.crc == "none"):
            raise CodecError("data_id_mode \"nibble\" needs the CRC and a 4-bit counter "
                             "(the DataID nibble is the counter byte's other nibble)")
        if not self.axes or not 1 <= self.dlc <= 64:
            raise CodecError("a layout needs at least one axis and a dlc of 1..64")
        if sum(f.bits for f in self.status) > 32:
            raise CodecError("the status fields hold more than 32 bits")
        self._check_positions()

    def _check_positions(self) -> None:
        """Every field inside the frame, none overlapping another in the same frame."""
        protection = self._protection_bits()
        used: dict[int, set[int]] = {aid: set(protection) for aid in self.arbitration_ids}
        if protection and not 0 <= min(protection) <= max(protection) < 8 * self.dlc:
            raise CodecError("the counter or the CRC leaves the frame")
        for name, item in self.fields().items():
            if isinstance(item, CanSignal) and not 1 <= item.length <= 4 or \
                    isinstance(item, CanBitField) and not 1 <= item.bits <= 32:
                raise CodecError(f"{name} {item}: a signal is 1..4 bytes, a status "
                                 "field 1..32 bits")
            bits = item.bits_used()
            if min(bits) < 0 or max(bits) >= 8 * self.dlc or bits & used[item.arbitration_id]:
                raise CodecError(f"{name} {item} overlaps the counter, the CRC or another "
                                 "field, or leaves the frame")
            used[item.arbitration_id] |= bits

    def _protection_bits(self) -> set[int]:
        """Bits the counter, the CRC and a sent DataID nibble occupy in every frame."""
        bits: set[int] = set()
        if self.counter_bits:
            low = 8 * self.counter_byte
            whole_byte = self.counter_bits == 8 or self.data_id_mode == "nibble"
            width = 8 if whole_byte else 4
            first = low if whole_byte else low + self._shift
            bits |= set(range(first, first + width))
        if self.crc != "none":
            bits |= set(range(8 * self.crc_byte, 8 * self.crc_byte + 8))
        return bits

    @property
    def _shift(self) -> int:
        """Bit position of the counter in its byte."""
        return 4 if self.counter_bits == 4 and self.counter_nibble == "high" else 0

    @property
    def has_counter(self) -> bool:
        """Whether the frames carry a counter."""
        return self.counter_bits > 0

    @property
    def is_e2e_p01(self) -> bool:
        """Whether the frames carry AUTOSAR E2E Profile 1's CRC and alive counter."""
        return self.crc == "e2e_p01" and self.counter_bits == ALIVE_COUNTER_BITS and \
            self.counter_modulus == ALIVE_COUNTER_MODULUS

    @cached_property
    def arbitration_ids(self) -> tuple[int, ...]:
        """Identifiers of the frames that make one sample, sorted."""
        return tuple(sorted({s.arbitration_id for s in self.fields().values()}))

    @cached_property
    def _fields_by_frame(self) -> dict[int, tuple[tuple[str, CanSignal | CanBitField], ...]]:
        """The fields of each frame, by arbitration ID."""
        return {aid: tuple((n, f) for n, f in self.fields().items() if f.arbitration_id == aid)
                for aid in self.arbitration_ids}

    @property
    def n_accel_axes(self) -> int:
        """Accelerometer axes each sample carries (0: a gyro's layout)."""
        return len(self.accel)

    @property
    def accel_range_m_s2(self) -> float | None:
        """Largest acceleration magnitude every accelerometer signal holds, m/s^2 (None: no
        accelerometers)."""
        if not self.accel:
            return None
        return min(s.symmetric_range() for s in self.accel)

    def without_accel(self) -> CanFrameLayout:
        """The same layout read as a gyro's: the accelerometer signals (and the frames
        that carry nothing else) left out."""
        return replace(self, accel=())

    def signals(self) -> dict[str, CanSignal]:
        """The value signals by name: ``axisN``, ``temperature``, ``accelN``."""
        out = {f"axis{i}": s for i, s in enumerate(self.axes)}
        if self.temperature is not None:
            out["temperature"] = self.temperature
        out.update((f"accel{i}", s) for i, s in enumerate(self.accel))
        return out

    def fields(self) -> dict[str, CanSignal | CanBitField]:
        """The signals and the status fields (``statusN``) by name."""
        out: dict[str, CanSignal | CanBitField] = dict(self.signals())
        out.update((f"status{i}", f) for i, f in enumerate(self.status))
        return out

    def _crc(self, data: bytes | bytearray, counter: int) -> int:
        return p01_crc(data, self.crc_byte, self.data_id, self.data_id_mode, counter)

    def decode(self, arbitration_id: int, data: bytes) -> CanFrameValues:
        """Verified raw values of one frame.

        Raises
        ------
        FrameError
            Unknown identifier or wrong length.
        CrcError
            The frame fails its check: the CRC, a counter value the counter never takes
            (15 in Profile 1's), or a DataID nibble that is not the layout's.
        """
        fields = self._fields_by_frame.get(arbitration_id)
        if fields is None or len(data) != self.dlc:
            raise FrameError(f"frame 0x{arbitration_id:X} with {len(data)} bytes is not "
                             "in the layout")
        counter = 0
        if self.counter_bits:
            counter = (data[self.counter_byte] >> self._shift) & ((1 << self.counter_bits) - 1)
            if counter >= self.counter_modulus:
                raise CrcError(f"counter {counter} in frame 0x{arbitration_id:X}: the "
                               f"counter runs 0..{self.counter_modulus - 1}")
        if self.crc != "none":
            if self.data_id_mode == "nibble" and \
                    (data[self.counter_byte] >> (4 - self._shift)) & 0x0F != self._nibble:
                raise CrcError(f"DataID nibble mismatch in frame 0x{arbitration_id:X}")
            if self._crc(data, counter) != data[self.crc_byte]:
                raise CrcError(f"E2E Profile 1 CRC mismatch in frame 0x{arbitration_id:X}")
        raw = tuple((name, item.extract(data)) for name, item in fields)
        return CanFrameValues(arbitration_id, counter, raw)

    @property
    def _nibble(self) -> int:
        """The DataID nibble a ``nibble``-mode frame carries."""
        return (self.data_id >> 8) & 0x0F

    def encode(self, values: CanFrameValues) -> bytes:
        """Data bytes of a frame (the exact inverse of :meth:`decode`)."""
        buf = bytearray(self.dlc)
        fields = self.fields()
        for name, raw in values.raw:
            fields[name].insert(buf, raw)
        if not 0 <= values.counter < self.counter_modulus:
            raise CodecError(f"counter {values.counter} out of 0..{self.counter_modulus - 1}")
        if self.counter_bits:
            keep = 0xFF & ~(((1 << self.counter_bits) - 1) << self._shift)
            buf[self.counter_byte] = ((buf[self.counter_byte] & keep)
                                      | (values.counter << self._shift))
        if self.crc != "none":
            if self.data_id_mode == "nibble":
                buf[self.counter_byte] |= self._nibble << (4 - self._shift)
            buf[self.crc_byte] = self._crc(buf, values.counter)
        return bytes(buf)

    def to_reading(self, frames: Mapping[int, CanFrameValues]) -> Reading:
        """Reading of one sample from its frames (one per arbitration ID, same counter)."""
        raw: dict[str, int] = {}
        for f in frames.values():
            raw.update(f.raw)
        counter = next(iter(frames.values())).counter
        temp = self.temperature
        device_status = status = None
        if self.status:
            device_status, invalid, shift = 0, 0, 0
            for i, field in enumerate(self.status):
                device_status |= raw[f"status{i}"] << shift
                invalid |= (field.invalid_mask & field.mask) << shift
                shift += field.bits
            status = device_status & invalid
        return Reading(
            rate_deg_s=tuple(s.physical(raw[f"axis{i}"]) for i, s in enumerate(self.axes)),
            counter=counter, status=status or 0,
            temperature_c=None if temp is None else temp.physical(raw["temperature"]),
            accel_m_s2=tuple(s.physical(raw[f"accel{i}"]) for i, s in enumerate(self.accel))
            if self.accel else None,
            device_status=device_status)

    def from_reading(self, reading: Reading) -> list[CanFrameValues]:
        """Frames of one sample, rates (and accelerations: zero where the reading has
        none) quantized to each signal's scale; the status fields from the reading's
        ``device_status`` (0 where it has none)."""
        values = {f"axis{i}": s.quantize(r) for i, (s, r) in
                  enumerate(zip(self.axes, reading.rate_deg_s, strict=True))}
        if self.temperature is not None:
            values["temperature"] = self.temperature.quantize(reading.temperature_c or 0.0)
        if self.accel:
            accel = reading.accel_m_s2 or (0.0,) * len(self.accel)
            values.update((f"accel{i}", s.quantize(a))
                          for i, (s, a) in enumerate(zip(self.accel, accel, strict=True)))
        word = reading.device_status or 0
        for i, field in enumerate(self.status):
            values[f"status{i}"] = word & field.mask
            word >>= field.bits
        counter = reading.counter % self.counter_modulus
        fields = self.fields()
        return [CanFrameValues(aid, counter, tuple((n, v) for n, v in values.items()
                                                   if fields[n].arbitration_id == aid))
                for aid in self.arbitration_ids]

    @classmethod
    def from_table(cls, table: Mapping[str, Any]) -> CanFrameLayout:
        """Layout from a TOML ``[can]`` table (keys and defaults:
        :mod:`devices.codecs.can_layout_table`).

        Raises
        ------
        CodecError
            A missing, unknown or mistyped key, or a layout that does not fit together (a
            field overlapping another, the counter or the CRC; a counter wrap its width
            cannot hold), named in the message.
        """
        options = layout_options(table)
        try:
            return cls(**options)
        except TypeError as exc:
            raise CodecError(f"bad CAN layout table: {exc}") from exc


#: LSB of the shared layout's rates, deg/s (2^-13 = 1.22e-4 deg/s = 0.44 deg/h; range
#: +-4 deg/s). Its quantization noise (LSB / sqrt(12) = 3.5e-5 deg/s) is under 3 % of
#: a tactical-grade gyro's white noise per sample (a VG951, ARW 0.0076 deg/sqrt(h):
#: 1.3e-3 deg/s at 100 Hz, 2.8e-3 deg/s at 500 Hz). A coarser 1/256 deg/s LSB, 3.9e-3,
#: read that noise as mostly zero. For wider ranges (rate tables) give a profile's
#: ``[can]`` layout, e.g. one int32 frame per axis (:data:`PER_AXIS_LAYOUT`).
SHARED_RATE_LSB_DEG_S = 2.0**-13

#: One frame 0x180: the Profile 1 CRC in byte 0 (DataID 0x0180), X, Y, Z as int16
#: big-endian at :data:`SHARED_RATE_LSB_DEG_S` in bytes 1-6, an 8-bit counter in byte 7
#: (classic CAN: 6 data bytes leave 16 bits per axis). The 8-bit counter is not Profile 1's
#: 4-bit alive counter: it counts outages up to 256 samples without the time stamps.
SHARED_LAYOUT = CanFrameLayout(
    axes=tuple(CanSignal(0x180, 1 + 2 * i, 2, scale=SHARED_RATE_LSB_DEG_S) for i in range(3)),
    counter_byte=7, crc_byte=0, data_id=0x0180)

#: One frame per axis (0x181..0x183), int32 little-endian at 1e-6 deg/s, AUTOSAR E2E
#: Profile 1 (alive counter 0..14 in the low nibble of byte 6, CRC in byte 7, DataID
#: 0x0181); the X frame also carries the temperature (int16, 1/100 degC).
PER_AXIS_LAYOUT = CanFrameLayout(
    axes=tuple(CanSignal(0x181 + i, 0, 4, byte_order="little", scale=1e-6) for i in range(3)),
    temperature=CanSignal(0x181, 4, 2, byte_order="little", scale=0.01),
    counter_byte=6, counter_bits=4, crc_byte=7, data_id=0x0181)

#: LSB of the IMU layouts' int16 accelerations, m/s^2 (2^-10 = 0.98 mm/s^2 = 0.1 mg; range
#: +-32 m/s^2 = +-3.3 g, a static or slow bench with gravity on one axis). Its
#: quantization noise (LSB / sqrt(12) = 2.8e-4 m/s^2) is under 6 % of a tactical IMU's
#: white noise per sample (velocity random walk 0.07 m/s/sqrt(h): 3.7e-3 m/s^2 at 10 Hz).
SHARED_ACCEL_LSB_M_S2 = 2.0**-10

#: :data:`SHARED_LAYOUT` and a second frame 0x280 of the same form: CRC in byte 0,
#: acceleration X, Y, Z as int16 big-endian at :data:`SHARED_ACCEL_LSB_M_S2` in bytes 1-6,
#: the counter in byte 7 (the rate frame's counter: the two frames make one sample).
SHARED_IMU_LAYOUT = CanFrameLayout(
    axes=SHARED_LAYOUT.axes,
    accel=tuple(CanSignal(0x280, 1 + 2 * i, 2, scale=SHARED_ACCEL_LSB_M_S2) for i in range(3)),
    counter_byte=7, crc_byte=0, data_id=0x0180)

#: :data:`PER_AXIS_LAYOUT` and one frame per accelerometer axis (0x184..0x186), int32
#: little-endian at 1e-6 m/s^2 (range +-2147 m/s^2), Profile 1 as the rate frames.
PER_AXIS_IMU_LAYOUT = CanFrameLayout(
    axes=PER_AXIS_LAYOUT.axes, temperature=PER_AXIS_LAYOUT.temperature,
    accel=tuple(CanSignal(0x184 + i, 0, 4, byte_order="little", scale=1e-6) for i in range(3)),
    counter_byte=6, counter_bits=4, crc_byte=7, data_id=0x0181)
