"""Raw CAN frame layout of a gyro or IMU that broadcasts its rates (pure codec).

A :class:`CanFrameLayout` says where each value sits: arbitration ID (one per axis or
one shared), byte offset, width, signedness, byte order and scale; an IMU's layout also
places its accelerations (m/s^2 per LSB). Every frame of the
layout carries end-to-end protection as in AUTOSAR E2E profile 1: a rolling counter in
the low bits of ``counter_byte`` and a CRC-8/SAE-J1850 in ``crc_byte`` computed over the
``data_id`` (low byte, then high byte) and every other data byte. Layouts load from a
profile's TOML table (:meth:`CanFrameLayout.from_table`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any, Literal

from devices.codecs.base import Reading
from devices.codecs.crc import crc8_sae_j1850
from devices.errors import CodecError, CrcError, FrameError


@dataclass(frozen=True)
class CanSignal:
    """One value in a frame.

    Attributes
    ----------
    arbitration_id : int
        CAN identifier of the frame carrying it.
    start_byte, length : int
        Byte offset and width (1..4 bytes).
    signed : bool
        Two's complement when true.
    byte_order : {"big", "little"}
        Byte order on the wire.
    scale : float
        Physical unit per LSB (deg/s for rates, m/s^2 for accelerations, degC for
        temperature).
    """

    arbitration_id: int
    start_byte: int
    length: int
    signed: bool = True
    byte_order: Literal["big", "little"] = "big"
    scale: float = 1.0

    def extract(self, data: bytes) -> int:
        return int.from_bytes(data[self.start_byte:self.start_byte + self.length],
                              self.byte_order, signed=self.signed)

    def insert(self, buf: bytearray, raw: int) -> None:
        try:
            buf[self.start_byte:self.start_byte + self.length] = raw.to_bytes(
                self.length, self.byte_order, signed=self.signed)
        except OverflowError as exc:
            raise CodecError(f"value {raw} does not fit {self.length} bytes") from exc

    def quantize(self, value: float) -> int:
        """Nearest raw value of ``value`` (physical units), clipped to the width."""
        bits = 8 * self.length
        lo, hi = (
            (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if self.signed else (0, (1 << bits) - 1)
        )
        return max(lo, min(hi, round(value / self.scale)))


@dataclass(frozen=True)
class CanFrameValues:
    """The raw contents of one verified frame."""

    arbitration_id: int
    counter: int
    raw: tuple[tuple[str, int], ...]


@dataclass(frozen=True)
class CanFrameLayout:
    """Where a broadcasting gyro puts its rates, counter and CRC.

    Attributes
    ----------
    axes : tuple of CanSignal
        One rate signal per axis, deg/s per LSB in ``scale``.
    temperature : CanSignal or None
        Temperature signal, degC per LSB.
    accel : tuple of CanSignal
        One acceleration signal per accelerometer axis of an IMU, m/s^2 per LSB in
        ``scale`` (empty: a gyro, or accelerometers left out).
    counter_byte, counter_bits : int
        Rolling counter position (low bits of that byte) and width (4 or 8 bits).
    crc_byte : int
        Position of the CRC-8/SAE-J1850.
    data_id : int
        16-bit E2E data identifier folded into the CRC.
    dlc : int
        Data length of every frame.
    """

    axes: tuple[CanSignal, ...]
    temperature: CanSignal | None = None
    accel: tuple[CanSignal, ...] = ()
    counter_byte: int = 6
    counter_bits: int = 8
    crc_byte: int = 7
    data_id: int = 0
    dlc: int = 8

    def __post_init__(self) -> None:
        if self.counter_bits not in (4, 8):
            raise CodecError("counter_bits must be 4 or 8")
        reserved = {self.counter_byte, self.crc_byte}
        for sig in self.signals().values():
            used = set(range(sig.start_byte, sig.start_byte + sig.length))
            if not 1 <= sig.length <= 4 or max(used) >= self.dlc or used & reserved:
                raise CodecError(f"signal {sig} overlaps the counter/CRC or leaves the frame")

    @property
    def counter_modulus(self) -> int:
        return 1 << self.counter_bits

    @property
    def arbitration_ids(self) -> tuple[int, ...]:
        """Identifiers of the frames that make one sample, sorted."""
        return tuple(sorted({s.arbitration_id for s in self.signals().values()}))

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
        return min(s.scale * ((1 << (8 * s.length - 1)) - 1 if s.signed
                              else (1 << 8 * s.length) - 1) for s in self.accel)

    def without_accel(self) -> CanFrameLayout:
        """The same layout read as a gyro's: the accelerometer signals (and the frames
        that carry nothing else) left out."""
        return replace(self, accel=())

    def signals(self) -> dict[str, CanSignal]:
        out = {f"axis{i}": s for i, s in enumerate(self.axes)}
        if self.temperature is not None:
            out["temperature"] = self.temperature
        out.update((f"accel{i}", s) for i, s in enumerate(self.accel))
        return out

    def _crc(self, data: bytes) -> int:
        body = bytes(b for i, b in enumerate(data) if i != self.crc_byte)
        return crc8_sae_j1850(self.data_id.to_bytes(2, "little") + body)

    def decode(self, arbitration_id: int, data: bytes) -> CanFrameValues:
        """Verified raw values of one frame.

        Raises
        ------
        FrameError
            Unknown identifier or wrong length.
        CrcError
            CRC-8 mismatch.
        """
        if arbitration_id not in self.arbitration_ids or len(data) != self.dlc:
            raise FrameError(f"frame 0x{arbitration_id:X} with {len(data)} bytes is not "
                             "in the layout")
        if self._crc(data) != data[self.crc_byte]:
            raise CrcError(f"CRC-8 mismatch in frame 0x{arbitration_id:X}")
        counter = data[self.counter_byte] & (self.counter_modulus - 1)
        raw = tuple((name, sig.extract(data)) for name, sig in self.signals().items()
                    if sig.arbitration_id == arbitration_id)
        return CanFrameValues(arbitration_id, counter, raw)

    def encode(self, values: CanFrameValues) -> bytes:
        """Data bytes of a frame (the exact inverse of :meth:`decode`)."""
        buf = bytearray(self.dlc)
        signals = self.signals()
        for name, raw in values.raw:
            signals[name].insert(buf, raw)
        if not 0 <= values.counter < self.counter_modulus:
            raise CodecError(f"counter {values.counter} out of 0..{self.counter_modulus - 1}")
        buf[self.counter_byte] = values.counter
        buf[self.crc_byte] = self._crc(bytes(buf))
        return bytes(buf)

    def to_reading(self, frames: Mapping[int, CanFrameValues]) -> Reading:
        """Reading of one sample from its frames (one per arbitration ID, same counter)."""
        raw: dict[str, int] = {}
        for f in frames.values():
            raw.update(f.raw)
        counter = next(iter(frames.values())).counter
        temp = self.temperature
        return Reading(
            rate_deg_s=tuple(raw[f"axis{i}"] * s.scale for i, s in enumerate(self.axes)),
            counter=counter,
            temperature_c=None if temp is None else raw["temperature"] * temp.scale,
            accel_m_s2=tuple(raw[f"accel{i}"] * s.scale for i, s in enumerate(self.accel))
            if self.accel else None)

    def from_reading(self, reading: Reading) -> list[CanFrameValues]:
        """Frames of one sample, rates (and accelerations: zero where the reading has
        none) quantized to each signal's scale."""
        values = {f"axis{i}": s.quantize(r) for i, (s, r) in
                  enumerate(zip(self.axes, reading.rate_deg_s, strict=True))}
        if self.temperature is not None:
            values["temperature"] = self.temperature.quantize(reading.temperature_c or 0.0)
        if self.accel:
            accel = reading.accel_m_s2 or (0.0,) * len(self.accel)
            values.update((f"accel{i}", s.quantize(a))
                          for i, (s, a) in enumerate(zip(self.accel, accel, strict=True)))
        counter = reading.counter % self.counter_modulus
        signals = self.signals()
        return [CanFrameValues(aid, counter, tuple((n, v) for n, v in values.items()
                                                   if signals[n].arbitration_id == aid))
                for aid in self.arbitration_ids]

    @classmethod
    def from_table(cls, table: Mapping[str, Any]) -> CanFrameLayout:
        """Layout from a profile's ``[can]`` table.

        Example::

            counter_byte = 6
            counter_bits = 8
            crc_byte = 7
            data_id = 0x1234
            [[can.axes]]
            arbitration_id = 0x180
            start_byte = 0
            length = 2
            signed = true
            byte_order = "big"
            scale = 0.00390625
            [[can.accel]]           # an IMU: one per accelerometer axis, m/s^2 per LSB
            arbitration_id = 0x280
            start_byte = 1
            length = 2
            scale = 0.0009765625

        Raises
        ------
        CodecError
            Missing or malformed keys.
        """
        try:
            axes = tuple(CanSignal(**a) for a in table["axes"])
            temp = table.get("temperature")
            return cls(axes=axes, temperature=None if temp is None else CanSignal(**temp),
                       accel=tuple(CanSignal(**a) for a in table.get("accel", ())),
                       **{k: int(table[k]) for k in ("counter_byte", "counter_bits", "crc_byte",
                                                     "data_id", "dlc") if k in table})
        except (KeyError, TypeError, ValueError) as exc:
            raise CodecError(f"bad CAN layout table: {exc}") from exc


#: LSB of the shared layout's rates, deg/s (2^-13 = 1.22e-4 deg/s = 0.44 deg/h; range
#: +-4 deg/s). Its quantization noise (LSB / sqrt(12) = 3.5e-5 deg/s) is under 3 % of
#: a tactical-grade gyro's white noise per sample (a VG951, ARW 0.0076 deg/sqrt(h):
#: 1.3e-3 deg/s at 100 Hz, 2.8e-3 deg/s at 500 Hz). A coarser 1/256 deg/s LSB, 3.9e-3,
#: read that noise as mostly zero. For wider ranges (rate tables) give a profile's
#: ``[can]`` layout, e.g. one int32 frame per axis (:data:`PER_AXIS_LAYOUT`).
SHARED_RATE_LSB_DEG_S = 2.0**-13

#: One frame 0x180: CRC in byte 0, X, Y, Z as int16 big-endian at
#: :data:`SHARED_RATE_LSB_DEG_S` in bytes 1-6, an 8-bit counter in byte 7 (classic CAN:
#: 6 data bytes leave 16 bits per axis).
SHARED_LAYOUT = CanFrameLayout(
    axes=tuple(CanSignal(0x180, 1 + 2 * i, 2, scale=SHARED_RATE_LSB_DEG_S) for i in range(3)),
    counter_byte=7, crc_byte=0, data_id=0x0180)

#: One frame per axis (0x181..0x183), int32 little-endian at 1e-6 deg/s, 4-bit counter;
#: the X frame also carries the temperature (int16, 1/100 degC).
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
#: little-endian at 1e-6 m/s^2 (range +-2147 m/s^2).
PER_AXIS_IMU_LAYOUT = CanFrameLayout(
    axes=PER_AXIS_LAYOUT.axes, temperature=PER_AXIS_LAYOUT.temperature,
    accel=tuple(CanSignal(0x184 + i, 0, 4, byte_order="little", scale=1e-6) for i in range(3)),
    counter_byte=6, counter_bits=4, crc_byte=7, data_id=0x0181)
