"""A simulated test fixture: a relay module and a temperature chamber on one pymodbus server.

Served on 127.0.0.1 from a thread of its own, it answers the station as the real ones
would (:mod:`devices.fixture` opens it by its URLs):

* device 1, the relay module: one coil per output (``n_outputs``); each output powers
  one simulated unit;
* device 2, the chamber controller: the set point in holding register 0 and the air
  temperature in input register 0 (:class:`~devices.codecs.fixture_map.ChamberMap`'s
  default, int16 at 0.1 degC); the air follows the set point through a first-order lag
  of ``chamber_tau_s``;
* device 247, the simulation wiring (:data:`~devices.codecs.fixture_map.SIM_WIRING`):
  what a simulated gyro wired to output ``k`` (URL key ``fixture=127.0.0.1:PORT/k``)
  reads to know when its supply came on and its die temperature, which follows the air
  through the unit's own lag and rises while powered
  (:class:`analysis.models.power_cycle.ThermalModel`).

Its time runs ``warp`` times faster than the wall clock, like the simulated gyros wired
to it; every value is advanced exactly to the moment of each request.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from collections.abc import Sequence
from dataclasses import dataclass

from pymodbus.constants import ExcCodes
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from analysis.models.power_cycle import ThermalModel, first_order_step
from devices.codecs.fixture_map import (
    SIM_WIRING,
    SIM_WIRING_DEVICE_ID,
    ChamberMap,
    OutletState,
    RelayMap,
)
from devices.errors import CodecError
from devices.sim.clock import WarpClock
from devices.sim.loop import wait_for_listener
from devices.sim.modbus_server import free_tcp_port

RELAY_DEVICE_ID = 1
CHAMBER_DEVICE_ID = 2


@dataclass
class _Outlet:
    powered: bool = False
    on_count: int = 0
    on_time_s: float = 0.0
    die_c: float = 25.0


class SimulatedFixture:
    """Relay module, chamber and simulation wiring of a simulated bench.

    Parameters
    ----------
    n_outputs : int
        Relay outputs (one per simulated unit).
    warp : float
        Fixture seconds per wall second (the simulated gyros' warp).
    ambient_c : float
        Starting air, die and set-point temperature, degC.
    chamber_tau_s : float
        Time constant of the air following the set point, s.
    thermal : ThermalModel
        Die temperature lag and self-heating of the units.
    port : int
        TCP port (0: a free one).
    on_counts : sequence of int
        Switch-ons each output has already made (default none): a fixture started again
        for a resumed sequence continues the count, so a unit switched on again draws the
        turn-on of its next switch-on (:func:`devices.sim.powered.turn_on_draw`), as a real
        unit powered again takes a new turn-on bias, not the one of its first.
    """

    def __init__(self, n_outputs: int = 4, *, warp: float = 1.0, ambient_c: float = 25.0,
                 chamber_tau_s: float = 600.0, thermal: ThermalModel | None = None,
                 port: int = 0, on_counts: Sequence[int] = ()) -> None:
        if not 1 <= n_outputs <= 64:
            raise ValueError(f"n_outputs must be in 1..64, got {n_outputs}")
        if len(on_counts) > n_outputs or any(c < 0 for c in on_counts):
            raise ValueError(f"on_counts must be at most {n_outputs} counts >= 0, got "
                             f"{list(on_counts)}")
        if not chamber_tau_s > 0:
            raise ValueError(f"chamber_tau_s must be > 0, got {chamber_tau_s}")
        self.clock = WarpClock(warp)
        self.relay_map = RelayMap(0, n_outputs)
        self.chamber_map = ChamberMap()
        self.thermal = thermal or ThermalModel()
        self.chamber_tau_s = chamber_tau_s
        self.port = port or free_tcp_port()
        counts = [*on_counts, *[0] * (n_outputs - len(on_counts))]
        self._outlets = [_Outlet(on_count=int(c), die_c=ambient_c) for c in counts]
        self._air_c = ambient_c
        self._setpoint_c = ambient_c
        self._t_s = 0.0
        self._lock = threading.Lock()
        self._loop = asyncio.new_event_loop()
        self._thread: threading.Thread | None = None
        self._stop: asyncio.Event | None = None

    # -- the physics -----------------------------------------------------------------
    def _advance(self) -> float:
        """Bring air and dies to now (call with the lock held); returns the time, s."""
        now = self.clock()
        dt = now - self._t_s
        if dt > 0:
            air_end = first_order_step(self._air_c, self._setpoint_c, self._setpoint_c,
                                       self.chamber_tau_s, dt)
            for o in self._outlets:
                o.die_c = self.thermal.step(o.die_c, self._air_c, air_end, o.powered, dt)
            self._air_c, self._t_s = air_end, now
        return self._t_s

    def _state(self, k: int) -> OutletState:
        o = self._outlets[k]
        target = self._air_c + self.thermal.self_heating_c * o.powered
        slope = (target - o.die_c) / self.thermal.unit_tau_s  # dT/dt of the lag, now
        return OutletState(o.powered, o.on_count, o.on_time_s, o.die_c, slope)

    def time_s(self) -> float:
        """Fixture time now, s."""
        with self._lock:
            return self._advance()

    def outlet(self, k: int) -> OutletState:
        """Output ``k``'s state now (the truth a test compares with)."""
        with self._lock:
            self._advance()
            return self._state(k)

    def air_c(self) -> float:
        """Air temperature of the chamber now, degC."""
        with self._lock:
            self._advance()
            return self._air_c

    def _switch(self, k: int, on: bool) -> None:
        with self._lock:
            now = self._advance()
            o = self._outlets[k]
            if on and not o.powered:
                o.on_count += 1
                o.on_time_s = now
            o.powered = on

    # -- register actions ------------------------------------------------------------
    async def _relay_action(self, function_code: int, start_address: int, address: int,
                            count: int, registers: list[int], values: object) -> ExcCodes | None:
        if function_code in (5, 15) and isinstance(values, list):
            first = address - self.relay_map.first_coil
            if first < 0 or first + len(values) > self.relay_map.n_outputs:
                return ExcCodes.ILLEGAL_ADDRESS
            for i, v in enumerate(values):
                self._switch(first + i, bool(v))
        return None

    async def _chamber_action(self, function_code: int, start_address: int, address: int,
                              count: int, registers: list[int], values: object
                              ) -> ExcCodes | None:
        m = self.chamber_map
        if function_code in (6, 16) and isinstance(values, list):
            try:
                setpoint = m.decode_setpoint([int(v) for v in values])
                m.encode_setpoint(setpoint)
            except CodecError:
                return ExcCodes.ILLEGAL_VALUE
            with self._lock:
                self._advance()
                self._setpoint_c = setpoint
            return None
        if function_code == 4:
            a = m.measured.address - start_address
            registers[a:a + m.measured.n_registers] = m.encode_measured(self.air_c())
        return None

    async def _wiring_action(self, function_code: int, start_address: int, address: int,
                             count: int, registers: list[int], values: object) -> None:
        with self._lock:
            now = self._advance()
            block = SIM_WIRING.encode(now, [self._state(k) for k in range(len(self._outlets))])
        registers[:len(block) - start_address] = block[start_address:]

    def _devices(self) -> list[SimDevice]:
        n = len(self._outlets)
        m = self.chamber_map
        wiring = SIM_WIRING.span(n - 1)[1]
        setpoint_words = m.encode_setpoint(self._setpoint_c)
        return [
            SimDevice(RELAY_DEVICE_ID, simdata=(
                [SimData(0, count=n, values=False, datatype=DataType.BITS)],
                [SimData(0, count=1, values=False, datatype=DataType.BITS)],
                [SimData(0, count=1, values=0, datatype=DataType.REGISTERS)],
                [SimData(0, count=1, values=0, datatype=DataType.REGISTERS)]),
                action=self._relay_action),
            SimDevice(CHAMBER_DEVICE_ID, simdata=(
                [SimData(0, count=1, values=False, datatype=DataType.BITS)],
                [SimData(0, count=1, values=False, datatype=DataType.BITS)],
                [SimData(m.setpoint.address, count=len(setpoint_words), values=setpoint_words,
                         datatype=DataType.REGISTERS)],
                [SimData(m.measured.address, count=m.measured.n_registers, values=0,
                         datatype=DataType.REGISTERS)]),
                action=self._chamber_action),
            SimDevice(SIM_WIRING_DEVICE_ID, simdata=(
                [SimData(0, count=1, values=False, datatype=DataType.BITS)],
                [SimData(0, count=1, values=False, datatype=DataType.BITS)],
                [SimData(0, count=1, values=0, datatype=DataType.REGISTERS)],
                [SimData(0, count=wiring, values=0, datatype=DataType.REGISTERS)]),
                action=self._wiring_action),
        ]

    # -- URLs --------------------------------------------------------------------------
    def power_url(self, output: int) -> str:
        """The URL of relay output ``output`` (:func:`devices.fixture.open_power_switch`)."""
        self.relay_map.coil(output)
        return f"modbus+tcp://127.0.0.1:{self.port}/{RELAY_DEVICE_ID}?coil={output}"

    @property
    def chamber_url(self) -> str:
        """The URL of the chamber controller (:func:`devices.fixture.open_chamber`)."""
        return f"modbus+tcp://127.0.0.1:{self.port}/{CHAMBER_DEVICE_ID}"

    def wiring(self, output: int) -> str:
        """The value of a simulated gyro's ``fixture=`` URL key for output ``output``."""
        self.relay_map.coil(output)
        return f"127.0.0.1:{self.port}/{output}"

    # -- serving ---------------------------------------------------------------------
    async def _serve(self, ready: threading.Event) -> None:
        self._stop = asyncio.Event()
        server = ModbusTcpServer(self._devices(), address=("127.0.0.1", self.port))
        task = asyncio.create_task(server.serve_forever())
        ready.set()
        try:
            await self._stop.wait()
        finally:
            await server.shutdown()
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task

    def start(self, timeout_s: float = 5.0) -> SimulatedFixture:
        """Serve from a background thread; returns once the port accepts connections.

        Raises
        ------
        TimeoutError
            The server did not listen within ``timeout_s`` (wall s).
        """
        ready = threading.Event()
        self._thread = threading.Thread(target=self._loop.run_until_complete,
                                        args=(self._serve(ready),), name="sim-fixture",
                                        daemon=True)
        self._thread.start()
        ready.wait(timeout_s)
        wait_for_listener(self.port, timeout_s, "simulated fixture", self.stop)
        return self

    def stop(self) -> None:
        """Shut the server down and join its thread."""
        if self._thread is not None and self._stop is not None:
            self._loop.call_soon_threadsafe(self._stop.set)
            self._thread.join(timeout=10)
        self._loop.close()

    def __enter__(self) -> SimulatedFixture:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
