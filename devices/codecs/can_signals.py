"""The values of a raw CAN frame (pure): a signal (whole bytes, raw x scale + offset), a
status bit field, and the raw contents of one verified frame. :mod:`devices.codecs.can_frame`
places them in a layout."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from devices.errors import CodecError


@dataclass(frozen=True)
class CanSignal:
    """One value in a frame: physical value = raw * ``scale`` + ``offset``.

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
    offset : float
        Physical value of raw 0, in the same unit (an offset-binary signal: the Bosch
        MM7.10 sends a rate as uint16 x 0.005 - 163.84 deg/s).
    """

    arbitration_id: int
    start_byte: int
    length: int
    signed: bool = True
    byte_order: Literal["big", "little"] = "big"
    scale: float = 1.0
    offset: float = 0.0

    def __post_init__(self) -> None:
        if self.byte_order not in ("big", "little"):
            raise CodecError(f"byte_order must be \"big\" or \"little\", not "
                             f"{self.byte_order!r}")
        if not (math.isfinite(self.scale) and self.scale != 0.0 and math.isfinite(self.offset)):
            raise CodecError(f"scale must be finite and non-zero, offset finite: {self}")

    def extract(self, data: bytes) -> int:
        """The raw value in ``data``."""
        return int.from_bytes(data[self.start_byte:self.start_byte + self.length],
                              self.byte_order, signed=self.signed)

    def insert(self, buf: bytearray, raw: int) -> None:
        """Write the raw value into ``buf``."""
        try:
            buf[self.start_byte:self.start_byte + self.length] = raw.to_bytes(
                self.length, self.byte_order, signed=self.signed)
        except OverflowError as exc:
            raise CodecError(f"value {raw} does not fit {self.length} bytes") from exc

    def raw_range(self) -> tuple[int, int]:
        """The smallest and largest raw value."""
        bits = 8 * self.length
        return ((-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if self.signed
                else (0, (1 << bits) - 1))

    def physical(self, raw: int) -> float:
        """Physical value of a raw value."""
        return raw * self.scale + self.offset

    def quantize(self, value: float) -> int:
        """Nearest raw value of ``value`` (physical units), clipped to the width."""
        lo, hi = self.raw_range()
        return max(lo, min(hi, round((value - self.offset) / self.scale)))

    def symmetric_range(self) -> float:
        """Largest magnitude M with -M..M inside the signal's range (where the range
        holds no sign change: the largest magnitude in it), physical units."""
        a, b = sorted(self.physical(r) for r in self.raw_range())
        return min(-a, b) if a < 0.0 < b else max(abs(a), abs(b))

    def bits_used(self) -> set[int]:
        """Bits of the frame it occupies (bit 8 k + i is bit i of byte k)."""
        return set(range(8 * self.start_byte, 8 * (self.start_byte + self.length)))


@dataclass(frozen=True)
class CanBitField:
    """A status field: ``bits`` bits from ``start_bit`` of a frame, least significant
    first (bit 8 k + i is bit i of byte k, the numbering of a DBC file's little-endian
    signals).

    Attributes
    ----------
    arbitration_id : int
        CAN identifier of the frame carrying it.
    start_bit, bits : int
        Position of its least significant bit, and width (1..32).
    invalid_mask : int
        The bits of the field that, set, say the sample is not valid (default: any).
    """

    arbitration_id: int
    start_bit: int
    bits: int
    invalid_mask: int = -1

    @property
    def mask(self) -> int:
        """All ones over the field's width."""
        return (1 << self.bits) - 1

    def extract(self, data: bytes) -> int:
        """The field's value in ``data``."""
        return (int.from_bytes(data, "little") >> self.start_bit) & self.mask

    def insert(self, buf: bytearray, raw: int) -> None:
        """Write the field's value into ``buf``."""
        if not 0 <= raw <= self.mask:
            raise CodecError(f"status value {raw} does not fit {self.bits} bits")
        word = int.from_bytes(buf, "little") & ~(self.mask << self.start_bit)
        buf[:] = (word | raw << self.start_bit).to_bytes(len(buf), "little")

    def bits_used(self) -> set[int]:
        """Bits of the frame it occupies."""
        return set(range(self.start_bit, self.start_bit + self.bits))


@dataclass(frozen=True)
class CanFrameValues:
    """The raw contents of one verified frame (counter 0 where the layout has none)."""

    arbitration_id: int
    counter: int
    raw: tuple[tuple[str, int], ...]
