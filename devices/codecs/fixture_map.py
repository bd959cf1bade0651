"""Register maps of a test fixture's power relays and temperature chamber (pure codecs).

A relay module switches each unit's supply with one Modbus coil per output; a
temperature chamber's controller takes its set point in a holding register and reports
the air temperature in an input register, each an integer in tenths of a degree (or a
float) as :class:`~devices.codecs.modbus_map.RegisterField` packs it. These maps convert
between registers and engineering values both ways, refuse a set point outside the
chamber's range, and describe the *simulation wiring*: the input registers a simulated
fixture adds so that a simulated gyro knows when its supply came on and how warm its die
is (:data:`SIM_WIRING`; a real fixture has none of these).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from devices.codecs.modbus_map import RegisterField
from devices.errors import CodecError


@dataclass(frozen=True)
class RelayMap:
    """A relay module's outputs: output ``k`` is coil ``first_coil + k``.

    Attributes
    ----------
    first_coil : int
        Coil address of output 0.
    n_outputs : int
        Outputs on the module.
    """

    first_coil: int = 0
    n_outputs: int = 16

    def __post_init__(self) -> None:
        if self.first_coil < 0 or self.n_outputs < 1 or self.first_coil + self.n_outputs > 0x10000:
            raise CodecError(f"relay map with coils {self.first_coil}..+{self.n_outputs} "
                             f"outside 0..65535")

    def coil(self, output: int) -> int:
        """The coil address of ``output``.

        Raises
        ------
        CodecError
            An output the module does not have.
        """
        if not 0 <= output < self.n_outputs:
            raise CodecError(f"relay output {output} outside 0..{self.n_outputs - 1}")
        return self.first_coil + output


@dataclass(frozen=True)
class ChamberMap:
    """A chamber controller's set point (holding register) and air temperature (input).

    Attributes
    ----------
    setpoint : RegisterField
        Set point, degC per LSB in ``scale`` (holding register).
    measured : RegisterField
        Measured air temperature, degC per LSB (input register).
    min_c, max_c : float
        The range of set points the chamber accepts, degC.
    """

    setpoint: RegisterField = RegisterField(0, "int16", 0.1)
    measured: RegisterField = RegisterField(0, "int16", 0.1)
    min_c: float = -70.0
    max_c: float = 180.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.min_c) and math.isfinite(self.max_c)
                and self.min_c < self.max_c):
            raise CodecError(f"chamber range {self.min_c}..{self.max_c} degC is not a range")

    def encode_setpoint(self, temperature_c: float) -> list[int]:
        """Registers of a set point (degC).

        Raises
        ------
        CodecError
            Not finite, outside the chamber's range, or not representable by the field.
        """
        if not (math.isfinite(temperature_c) and self.min_c <= temperature_c <= self.max_c):
            raise CodecError(f"set point {temperature_c} degC outside the chamber's range "
                             f"{self.min_c:g}..{self.max_c:g} degC")
        words = self.setpoint.pack(temperature_c)
        if abs(self.setpoint.unpack(words) - temperature_c) > abs(self.setpoint.scale):
            raise CodecError(f"set point {temperature_c} degC does not fit a "
                             f"{self.setpoint.kind} register at {self.setpoint.scale:g} "
                             f"degC per LSB")
        return words

    def decode_setpoint(self, registers: Sequence[int]) -> float:
        """The set point (degC) held in ``registers``."""
        return self.setpoint.unpack(registers)

    def encode_measured(self, temperature_c: float) -> list[int]:
        """Registers of a measured temperature (degC), as the controller reports it."""
        return self.measured.pack(temperature_c)

    def decode_measured(self, registers: Sequence[int]) -> float:
        """The measured air temperature (degC) in ``registers``."""
        return self.measured.unpack(registers)

    @classmethod
    def from_keys(cls, keys: Mapping[str, Any]) -> ChamberMap:
        """A map from URL keys: ``setpoint``, ``measured`` (register addresses), ``kind``
        (``int16``, ``uint16``, ``int32``, ``float32``), ``scale`` (degC per LSB),
        ``word_order``, ``min_c``, ``max_c``; missing keys take the defaults.

        Raises
        ------
        CodecError
            A value of the wrong type or out of range.
        """
        default = cls()
        try:
            kind = str(keys.get("kind", default.setpoint.kind))
            scale = float(keys.get("scale", 1.0 if kind == "float32" else default.setpoint.scale))
            order = str(keys.get("word_order", "big"))
            return cls(RegisterField(int(keys.get("setpoint", 0)), kind, scale, order),  # type: ignore[arg-type]
                       RegisterField(int(keys.get("measured", 0)), kind, scale, order),  # type: ignore[arg-type]
                       float(keys.get("min_c", default.min_c)),
                       float(keys.get("max_c", default.max_c)))
        except (TypeError, ValueError) as exc:
            raise CodecError(f"bad chamber register keys: {exc}") from exc


@dataclass(frozen=True)
class OutletState:
    """What the simulation wiring says of one relay output and the unit on it.

    Attributes
    ----------
    powered : bool
        Whether the output is on.
    on_count : int
        How many times it was switched on (since the fixture started, plus the count it
        was started with).
    on_time_s : float
        Fixture time of the latest switch-on, s.
    die_c : float
        Die temperature of the unit on it, degC.
    die_slope_c_per_s : float
        Its rate of change, degC per s.
    """

    powered: bool
    on_count: int
    on_time_s: float
    die_c: float
    die_slope_c_per_s: float


@dataclass(frozen=True)
class SimWiringMap:
    """Input registers of a simulated fixture that only simulated units read.

    The fixture's time (s, in ms) is at ``now``; output ``k``'s block starts at
    ``first + k * stride``: powered (uint16), switch-on count (uint16), time of the
    latest switch-on (uint32, ms), die temperature (float32, degC), its slope (float32,
    degC/s).
    """

    now: RegisterField = RegisterField(0, "uint32", 1e-3)
    first: int = 16
    stride: int = 8

    def _fields(self, output: int) -> tuple[RegisterField, ...]:
        base = self.first + output * self.stride
        return (RegisterField(base, "uint16"), RegisterField(base + 1, "uint16"),
                RegisterField(base + 2, "uint32", 1e-3), RegisterField(base + 4, "float32"),
                RegisterField(base + 6, "float32"))

    def span(self, output: int) -> tuple[int, int]:
        """(first address, count) of the block holding the time and ``output``'s state."""
        return 0, self.first + (output + 1) * self.stride

    def encode(self, now_s: float, outlets: Sequence[OutletState]) -> list[int]:
        """The block (from address 0) holding the time and every outlet's state."""
        block = [0] * (self.first + len(outlets) * self.stride)
        block[0:2] = self.now.pack(now_s)
        for k, state in enumerate(outlets):
            values = (float(state.powered), float(state.on_count % 0x10000), state.on_time_s,
                      state.die_c, state.die_slope_c_per_s)
            for f, v in zip(self._fields(k), values, strict=True):
                block[f.address:f.address + f.n_registers] = f.pack(v)
        return block

    def decode(self, registers: Sequence[int], output: int) -> tuple[float, OutletState]:
        """(fixture time s, ``output``'s state) from a block read at :meth:`span`.

        Raises
        ------
        FrameError
            Too few registers, or one out of 0..65535.
        """
        now = self.now.unpack(registers)
        powered, count, on_time, die, slope = (f.unpack(registers[f.address:])
                                               for f in self._fields(output))
        return now, OutletState(bool(powered), int(count), on_time, die, slope)


#: Where a simulated fixture serves its wiring (device id :data:`SIM_WIRING_DEVICE_ID`).
SIM_WIRING = SimWiringMap()
#: The Modbus device id of the simulation wiring on a simulated fixture's server.
SIM_WIRING_DEVICE_ID = 247
