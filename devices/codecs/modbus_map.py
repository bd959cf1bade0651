"""Register map of a Modbus gyro or environment sensor (pure codec).

Each value sits in one or two 16-bit registers (big-endian within a register, as Modbus
says); 32-bit values take two registers whose order (``word_order``) varies by vendor.
:class:`ModbusRegisterMap` converts between a contiguous register block and a
:class:`~devices.codecs.base.Reading`, both ways.
"""

from __future__ import annotations

import math
import operator
import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, Literal, SupportsIndex

from devices.codecs.base import Reading
from devices.errors import CodecError, FrameError

Kind = Literal["int16", "uint16", "int32", "uint32", "float32"]
_FORMATS: dict[str, str] = {"int16": ">h", "uint16": ">H", "int32": ">i", "uint32": ">I",
                            "float32": ">f"}


def _register(word: object, address: int) -> int:
    """A register as received: an integer in 0..65535, else FrameError."""
    if not isinstance(word, SupportsIndex):
        raise FrameError(f"register {address}: {word!r} is not an integer")
    value = operator.index(word)
    if isinstance(word, bool) or not 0 <= value <= 0xFFFF:
        raise FrameError(f"register {address}: value {word!r} out of 0..65535")
    return value


@dataclass(frozen=True)
class RegisterField:
    """One value in the register map.

    Attributes
    ----------
    address : int
        First register (0-based protocol address).
    kind : {"int16", "uint16", "int32", "uint32", "float32"}
        Wire type; 32-bit kinds take two registers.
    scale : float
        Physical unit per LSB (1.0 for float32 in physical units).
    word_order : {"big", "little"}
        ``"big"``: high word first (ABCD); ``"little"``: low word first (CDAB).
    """

    address: int
    kind: Kind = "int32"
    scale: float = 1.0
    word_order: Literal["big", "little"] = "big"

    def __post_init__(self) -> None:
        if self.kind not in _FORMATS or self.word_order not in ("big", "little"):
            raise CodecError(f"unsupported register field {self}")
        if not 0 <= self.address <= 0xFFFF - self.n_registers + 1:
            raise CodecError(f"register address {self.address} out of range")

    @property
    def n_registers(self) -> int:
        return 1 if self.kind.endswith("16") else 2

    def unpack(self, registers: Sequence[int]) -> float:
        """The value (physical units) of this field's registers, the first of
        ``registers`` at :attr:`address`.

        Raises
        ------
        FrameError
            Too few registers, or one that is not an integer in 0..65535.
        """
        words = [_register(w, self.address + i)
                 for i, w in enumerate(registers[:self.n_registers])]
        if len(words) < self.n_registers:
            raise FrameError(f"register {self.address}: {self.n_registers} registers "
                             f"needed, got {len(words)}")
        if self.word_order == "little":
            words.reverse()
        raw = b"".join(w.to_bytes(2, "big") for w in words)
        value = struct.unpack(_FORMATS[self.kind], raw)[0]
        return float(value * self.scale)

    def pack(self, value: float) -> list[int]:
        """Registers of ``value`` (physical units), integers rounded and clipped."""
        if self.kind == "float32":
            raw = struct.pack(">f", value / self.scale)
        else:
            bits = 16 * self.n_registers
            signed = self.kind.startswith("int")
            lo, hi = ((-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if signed
                      else (0, (1 << bits) - 1))
            q = value / self.scale
            raw = struct.pack(_FORMATS[self.kind],
                              max(lo, min(hi, round(q) if math.isfinite(q) else 0)))
        words = [int.from_bytes(raw[i:i + 2], "big") for i in range(0, len(raw), 2)]
        return words[::-1] if self.word_order == "little" else words


@dataclass(frozen=True)
class ModbusRegisterMap:
    """Where a register-map gyro keeps its rates, sample counter, temperature and status.

    Attributes
    ----------
    axes : tuple of RegisterField
        Rate per axis, deg/s per LSB in ``scale``.
    counter : RegisterField
        Sample counter (uint16 or uint32), incremented once per new sample.
    temperature : RegisterField or None
        Temperature, degC per LSB.
    status : RegisterField or None
        Status word (0 = good).
    accel : tuple of RegisterField
        Acceleration per accelerometer axis of an IMU, m/s^2 per LSB in ``scale`` (empty:
        a gyro, or accelerometers left out).
    """

    axes: tuple[RegisterField, ...]
    counter: RegisterField
    temperature: RegisterField | None = None
    status: RegisterField | None = None
    accel: tuple[RegisterField, ...] = ()

    def fields(self) -> list[RegisterField]:
        return [f for f in (*self.axes, self.counter, self.temperature, self.status,
                            *self.accel) if f is not None]

    @property
    def n_accel_axes(self) -> int:
        """Accelerometer axes each sample carries (0: a gyro's map)."""
        return len(self.accel)

    def without_accel(self) -> ModbusRegisterMap:
        """The same map read as a gyro's (its accelerometer registers not read)."""
        return replace(self, accel=())

    @property
    def counter_modulus(self) -> int:
        return 1 << (16 * self.counter.n_registers)

    @property
    def span(self) -> tuple[int, int]:
        """(first address, register count) of the block holding every field."""
        start = min(f.address for f in self.fields())
        end = max(f.address + f.n_registers for f in self.fields())
        return start, end - start

    def decode(self, registers: Sequence[int]) -> Reading:
        """Reading from the block read at :attr:`span` (the exact inverse of :meth:`encode`).

        Raises
        ------
        FrameError
            Block too short, or a register out of 0..65535.
        """
        start, count = self.span
        try:
            if len(registers) < count:
                raise FrameError(f"expected {count} registers, got {len(registers)}")
            registers[0:0]
        except TypeError:
            raise FrameError(f"expected a block of {count} registers, got "
                             f"{type(registers).__name__}") from None

        def value(f: RegisterField) -> float:
            return f.unpack(registers[f.address - start:])

        # A register map's status register reads 0 when the gyro is good (a map of ours:
        # a device whose register says otherwise needs a map that turns it round).
        word = None if self.status is None else int(value(self.status))
        return Reading(
            rate_deg_s=tuple(value(a) for a in self.axes),
            counter=int(value(self.counter)),
            status=0 if word is None else word,
            temperature_c=None if self.temperature is None else value(self.temperature),
            accel_m_s2=tuple(value(a) for a in self.accel) if self.accel else None,
            device_status=word)

    def encode(self, reading: Reading) -> list[int]:
        """Register block (at :attr:`span`) holding ``reading``."""
        start, count = self.span
        block = [0] * count

        def put(f: RegisterField | None, v: float) -> None:
            if f is not None:
                block[f.address - start:f.address - start + f.n_registers] = f.pack(v)

        for f, r in zip(self.axes, reading.rate_deg_s, strict=True):
            put(f, r)
        put(self.counter, reading.counter % self.counter_modulus)
        put(self.temperature, reading.temperature_c or 0.0)
        put(self.status, reading.status)
        for f, a in zip(self.accel, reading.accel_m_s2 or (0.0,) * len(self.accel),
                        strict=True):
            put(f, a)
        return block

    @classmethod
    def from_table(cls, table: Mapping[str, Any]) -> ModbusRegisterMap:
        """Register map from a profile's ``[modbus]`` table (keys as the attributes).

        Raises
        ------
        CodecError
            Missing or malformed keys.
        """
        try:
            def field(t: Mapping[str, Any] | None) -> RegisterField | None:
                return None if t is None else RegisterField(**t)

            return cls(axes=tuple(RegisterField(**a) for a in table["axes"]),
                       counter=RegisterField(**table["counter"]),
                       temperature=field(table.get("temperature")),
                       status=field(table.get("status")),
                       accel=tuple(RegisterField(**a) for a in table.get("accel", ())))
        except (KeyError, TypeError) as exc:
            raise CodecError(f"bad Modbus register table: {exc}") from exc


#: Gyro: X, Y, Z as INT32 (high word first) at 1e-6 deg/s from register 0, sample
#: counter uint16 at 6, temperature int16 at 0.01 degC at 7, status at 8.
GYRO_INT32_MAP = ModbusRegisterMap(
    axes=tuple(RegisterField(2 * i, "int32", 1e-6) for i in range(3)),
    counter=RegisterField(6, "uint16"), temperature=RegisterField(7, "int16", 0.01),
    status=RegisterField(8, "uint16"))

#: Gyro: X, Y, Z as FLOAT32 deg/s, low word first (CDAB) from register 100.
GYRO_FLOAT32_MAP = ModbusRegisterMap(
    axes=tuple(RegisterField(100 + 2 * i, "float32", 1.0, "little") for i in range(3)),
    counter=RegisterField(106, "uint32", 1.0, "little"),
    temperature=RegisterField(108, "float32", 1.0, "little"))

#: IMU: :data:`GYRO_INT32_MAP` and acceleration X, Y, Z as INT32 (high word first) at
#: 1e-6 m/s^2 from register 9 (range +-2147 m/s^2).
IMU_INT32_MAP = replace(GYRO_INT32_MAP,
                        accel=tuple(RegisterField(9 + 2 * i, "int32", 1e-6) for i in range(3)))

#: IMU: :data:`GYRO_FLOAT32_MAP` and acceleration X, Y, Z as FLOAT32 m/s^2, low word first
#: (CDAB), from register 110.
IMU_FLOAT32_MAP = replace(GYRO_FLOAT32_MAP, accel=tuple(
    RegisterField(110 + 2 * i, "float32", 1.0, "little") for i in range(3)))
