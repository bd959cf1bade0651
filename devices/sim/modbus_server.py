"""A simulated register-map gyro (and a thermal chamber) served by pymodbus, TCP or RTU.

The server runs in its own thread and event loop, on 127.0.0.1 (TCP) or on one end of a
pty null modem (RTU); registers are filled on each request from the simulation
(pymodbus 3.x ``SimDevice`` action), so a poll always sees the newest sample. A
disconnect shuts the server down and the reconnect serves again on the same port.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket
import threading

from pymodbus.constants import ExcCodes
from pymodbus.server import ModbusBaseServer, ModbusSerialServer, ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from devices.codecs.base import Reading
from devices.codecs.modbus_map import ModbusRegisterMap, RegisterField
from devices.sim.faults import SimCore
from devices.sim.loop import wait_for_listener
from devices.sim.pty_bridge import PtyBridge

#: Where the simulated chamber keeps its temperature (device id ``env_device_id``).
CHAMBER_FIELD = RegisterField(0, "float32", 1.0)


def free_tcp_port() -> int:
    """A TCP port on 127.0.0.1 that was free a moment ago."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class ModbusGyroServer:
    """pymodbus TCP server with a gyro at ``device_id`` and a chamber at ``env_device_id``.

    Parameters
    ----------
    register_map : ModbusRegisterMap
        The gyro's registers (its encoder fills them).
    core : SimCore
        Signal, schedule, faults and ledger; ``drop`` is the probability of answering a
        poll with DEVICE_BUSY (a polled register holds its sample: nothing is lost).
    device_id, env_device_id : int
        Unit addresses of the gyro and of the chamber.
    port : int
        TCP port (0: pick a free one).
    rtu : bool
        Serve Modbus RTU on a pty null modem instead of TCP; the station opens
        :attr:`serial_port`.
    chamber_c : float
        Chamber temperature at t = 0, degC; it rises 0.01 degC per simulated second.
    """

    def __init__(self, register_map: ModbusRegisterMap, core: SimCore, *, device_id: int = 1,
                 env_device_id: int = 2, port: int = 0, rtu: bool = False,
                 chamber_c: float = 23.0, poll_s: float = 0.005) -> None:
        self.map = register_map
        self.core = core
        self.device_id = device_id
        self.env_device_id = env_device_id
        self.bridge = PtyBridge().start() if rtu else None
        self.port = 0 if rtu else (port or free_tcp_port())
        #: The station's end of the null modem (RTU only).
        self.serial_port = self.bridge.port_b if self.bridge is not None else ""
        self.chamber_c = chamber_c
        self.poll_s = poll_s
        self._latest: Reading | None = None
        self._loop = asyncio.new_event_loop()
        self._thread: threading.Thread | None = None
        self._stop: asyncio.Event | None = None
        self._ready = threading.Event()

    # -- register actions ------------------------------------------------------------
    async def _gyro_action(self, function_code: int, start_address: int, address: int,
                           count: int, registers: list[int], values: object) -> ExcCodes | None:
        readings = self.core.due()
        if readings:
            self._latest = readings[-1]
        if self._latest is None:
            return ExcCodes.DEVICE_BUSY
        if self.core.chance(self.core.faults.drop):
            return ExcCodes.DEVICE_BUSY  # a dropped poll: the sample stays for the next one
        start, n = self.map.span
        registers[start - start_address:start - start_address + n] = self.map.encode(self._latest)
        return None

    async def _chamber_action(self, function_code: int, start_address: int, address: int,
                              count: int, registers: list[int], values: object) -> None:
        value = self.chamber_c + 0.01 * self.core.device_time()
        a = CHAMBER_FIELD.address - start_address
        registers[a:a + CHAMBER_FIELD.n_registers] = CHAMBER_FIELD.pack(value)

    def _devices(self) -> list[SimDevice]:
        start, n = self.map.span
        return [
            SimDevice(self.device_id, simdata=[SimData(start, count=n, values=0,
                                                       datatype=DataType.REGISTERS)],
                      action=self._gyro_action),
            SimDevice(self.env_device_id,
                      simdata=[SimData(CHAMBER_FIELD.address, count=CHAMBER_FIELD.n_registers,
                                       values=0, datatype=DataType.REGISTERS)],
                      action=self._chamber_action),
        ]

    # -- serving ---------------------------------------------------------------------
    def _server(self) -> ModbusBaseServer:
        if self.bridge is not None:
            return ModbusSerialServer(self._devices(), port=self.bridge.port_a, baudrate=115200)
        return ModbusTcpServer(self._devices(), address=("127.0.0.1", self.port))

    async def _serve(self) -> None:
        self._stop = asyncio.Event()
        self._ready.set()
        server: ModbusBaseServer | None = None
        task: asyncio.Task[None] | None = None
        try:
            while not self._stop.is_set():
                down = self.core.link_down()
                if down and server is not None:
                    await server.shutdown()
                    server = task = None
                    self.core.ledger.disconnects += 1
                elif not down and server is None:
                    server = self._server()
                    task = asyncio.create_task(server.serve_forever())
                if down:
                    self.core.lose(self.core.due())
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(self._stop.wait(), self.poll_s)
        finally:
            if server is not None:
                await server.shutdown()
            if task is not None:
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError, Exception):
                    await task

    def start(self, timeout_s: float = 5.0) -> ModbusGyroServer:
        """Serve from a background thread; returns once the port accepts connections.

        Raises
        ------
        TimeoutError
            The server did not listen within ``timeout_s`` (s).
        """
        self._thread = threading.Thread(
            target=self._loop.run_until_complete, args=(self._serve(),), name="modbus-gyro",
            daemon=True)
        self._thread.start()
        self._ready.wait(timeout_s)
        if self.bridge is not None:
            return self  # a serial server is up once its loop runs
        wait_for_listener(self.port, timeout_s, "Modbus server", self.stop)
        return self

    def stop(self) -> None:
        """Shut the server down and join its thread."""
        if self._thread is not None and self._stop is not None:
            self._loop.call_soon_threadsafe(self._stop.set)
            self._thread.join(timeout=10)
        self._loop.close()
        if self.bridge is not None:
            self.bridge.stop()
