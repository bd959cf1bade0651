"""MTData2 data items of the Xsens MT Low Level Communication Protocol (pure).

What each part follows (the Xsens "MT Low Level Communication Protocol" document, as
einride/xsens-go implements it: ``dataidentifier.go``, ``precision.go``,
``fixedpoint.go``, ``coordinatesystem.go``, ``measurementdata.go``):

* **Data identifier** (uint16, big-endian): bits 15-11 the group and bits 7-4 the type
  (mask ``0xF8F0``, bits 10-8 reserved), bits 3-2 the coordinate system (``0x000C``:
  0 East-North-Up, 4 North-East-Down, 8 North-West-Up), bits 1-0 the precision
  (``0x0003``). The coordinate system applies to orientation and velocity only; a
  rate of turn or an acceleration is in the sensor frame whatever the bits say.
* **Precision**: 0 float32 (4 bytes), 1 fixed point 12.20 (4 bytes), 2 fixed point
  16.32 (6 bytes), 3 float64 (8 bytes); every value big-endian.
* **Fixed point**: FP12.20 is ``round(x * 2**20)`` as a signed 32-bit integer
  (range -2048 .. 2047.9999990); FP16.32 is ``round(x * 2**32)`` as a signed 48-bit
  integer sent as its 32-bit fraction part first, then its 16-bit integer part, each
  big-endian (range -32768 .. 32767.9999999998).
* **StatusWord** (0xE020, uint32) bits: 0 self-test passed, 1 filter valid, 2 GNSS fix,
  3-4 no-rotation update, 5 representative motion, 8-10 accelerometer clipping x/y/z,
  11-13 gyroscope clipping x/y/z, 14-16 magnetometer clipping x/y/z, 19 clipping
  indication (any sensor), 21 SyncIn, 22 SyncOut, 23-25 filter mode. A healthy
  MTi-G-710 reads 0x5, 0x7 or 0x1800005: the bits are 1 where things are good.
* **StatusByte** (0xE010, uint8): bits 0-7 of the StatusWord.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from devices.errors import FrameError

# -- data identifiers (groups and types: bits 15-11 and 7-4) -------------------------
TEMPERATURE = 0x0810
UTC_TIME = 0x1010
PACKET_COUNTER = 0x1020
SAMPLE_TIME_FINE = 0x1060
ACCELERATION = 0x4020
ACCELERATION_HR = 0x4040
GNSS_PVT_DATA = 0x7010
RATE_OF_TURN = 0x8020
RATE_OF_TURN_HR = 0x8040
STATUS_BYTE = 0xE010
STATUS_WORD = 0xE020

TYPE_MASK = 0xF8F0
COORDINATE_SYSTEM_MASK = 0x000C
PRECISION_MASK = 0x0003

# -- precisions (bits 1-0) -------------------------------------------------------------
FLOAT32 = 0x0
FP1220 = 0x1
FP1632 = 0x2
FLOAT64 = 0x3
PRECISION_NAMES = {FLOAT32: "Float32", FP1220: "FP12.20", FP1632: "FP16.32",
                   FLOAT64: "Float64"}
#: Bytes of one value in each precision.
PRECISION_SIZE = {FLOAT32: 4, FP1220: 4, FP1632: 6, FLOAT64: 8}
FP1220_SCALE = float(1 << 20)
FP1632_SCALE = float(1 << 32)

# -- coordinate systems (bits 3-2) -------------------------------------------------------
COORDINATE_SYSTEMS = {0x0: "EastNorthUp", 0x4: "NorthEastDown", 0x8: "NorthWestUp"}

# -- StatusWord bits ---------------------------------------------------------------------
SELFTEST_PASSED = 1 << 0
FILTER_VALID = 1 << 1
GNSS_FIX = 1 << 2
ACCEL_CLIPPING = 0b111 << 8
GYRO_CLIPPING = 0b111 << 11
MAG_CLIPPING = 0b111 << 14
CLIPPING_INDICATION = 1 << 19
FILTER_MODE_WITH_GNSS = 0b011 << 23


@dataclass(frozen=True)
class DataId:
    """A data identifier split into its fields.

    Attributes
    ----------
    data_type : int
        Group and type (``identifier & 0xF8F0``), e.g. 0x8020 RateOfTurn.
    coordinate_system : int
        Bits 3-2 (0 ENU, 4 NED, 8 NWU; 0xC is not defined).
    precision : int
        Bits 1-0 (0 float32, 1 FP12.20, 2 FP16.32, 3 float64).
    """

    data_type: int
    coordinate_system: int
    precision: int

    @classmethod
    def of(cls, identifier: int) -> DataId:
        """The fields of a uint16 data identifier."""
        return cls(identifier & TYPE_MASK, identifier & COORDINATE_SYSTEM_MASK,
                   identifier & PRECISION_MASK)

    def name(self) -> str:
        """Type and precision as ``0x8020 (FP12.20)``."""
        return f"0x{self.data_type:04X} ({PRECISION_NAMES[self.precision]})"


def decode_values(value: bytes, precision: int, count: int, what: str) -> tuple[float, ...]:
    """``count`` big-endian values of one precision.

    Parameters
    ----------
    value : bytes
        The item's value bytes.
    precision : int
        0 float32, 1 FP12.20, 2 FP16.32, 3 float64.
    count : int
        Values expected (3 for a vector, 1 for a scalar).
    what : str
        The item, for the error message.

    Raises
    ------
    FrameError
        The value is not ``count`` values of that precision long.
    """
    size = PRECISION_SIZE[precision]
    if len(value) != size * count:
        raise FrameError(f"MTData2 item {what} of {len(value)} bytes, not {count} x {size} "
                         f"({PRECISION_NAMES[precision]}): not a usable item")
    if precision == FLOAT32:
        return struct.unpack(f">{count}f", value)
    if precision == FLOAT64:
        return struct.unpack(f">{count}d", value)
    if precision == FP1220:
        return tuple(v / FP1220_SCALE for v in struct.unpack(f">{count}i", value))
    out = []
    for i in range(count):
        fraction, whole = struct.unpack(">Ih", value[6 * i:6 * i + 6])
        out.append(((whole << 32) | fraction) / FP1632_SCALE)
    return tuple(out)


def status_word_flags(word: int, *, accel: bool) -> int:
    """The station's status of a sample from its StatusWord: 0 where the unit says the
    sample is good, else the bits that flag it (a failed self-test shows as bit 0).

    Bad: self-test not passed (bit 0 clear), a gyroscope clipping (bits 11-13) and,
    where the accelerations are part of the sample, an accelerometer clipping
    (bits 8-10). Filter valid, GNSS fix and the filter mode concern the orientation
    and position outputs, not the rate of turn; the magnetometer flags and the
    any-sensor clipping indication (bit 19) concern no part of the sample.
    """
    bad = (~word & SELFTEST_PASSED) | (word & GYRO_CLIPPING)
    return bad | (word & ACCEL_CLIPPING) if accel else bad


def status_byte_flags(byte: int) -> int:
    """The station's status from a StatusByte (bits 0-7 of the StatusWord: no clipping
    flags): bit 0 where the self-test did not pass, else 0."""
    return ~byte & SELFTEST_PASSED
