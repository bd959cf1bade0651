"""Adapters for register-map devices over Modbus: a polled gyro and an environment channel."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Literal

from devices.batching import BatchBuilder
from devices.codecs.modbus_map import ModbusRegisterMap, RegisterField
from devices.errors import DeviceDisconnectedError, DeviceProtocolError
from devices.gaps import CounterTracker
from devices.protocols import ACCEL_AXIS_NAMES, DeviceDescription, SampleBatch
from devices.resolution import register_resolution
from devices.transports.modbus import SERVER_DEVICE_BUSY, ModbusExceptionResponse, ModbusTransport


class ModbusRateSource:
    """A register-map gyro polled over Modbus at (a multiple of) its sample rate.

    Each poll reads the whole register block; a sample counter that did not move means
    no new sample, one that jumped by k means k - 1 samples were never read (a gap).

    Parameters
    ----------
    transport : ModbusTransport
        The client.
    register_map : ModbusRegisterMap
        Where the values are.
    device_id : int
        Modbus unit address.
    model, serial_number : str
        For :meth:`describe`.
    sample_rate_hz : float
        Device sample rate, Hz.
    oversample : float
        Polls per sample period.
    clock : callable
        Station clock, s.
    clock_scale : float
        Clock seconds per wall second (a simulation's time warp): polls are paced in
        clock time.
    table : {"holding", "input"}
        Register table.
    """

    def __init__(self, transport: ModbusTransport, register_map: ModbusRegisterMap, *,
                 device_id: int = 1, model: str, serial_number: str, sample_rate_hz: float,
                 oversample: float = 2.0, clock: Callable[[], float] = time.monotonic,
                 clock_scale: float = 1.0, table: Literal["holding", "input"] = "holding"
                 ) -> None:
        self.transport = transport
        self.map = register_map
        self.device_id = device_id
        self.clock = clock
        self.table = table
        self._poll_wall_s = 1.0 / (sample_rate_hz * oversample * clock_scale)
        has_temp = register_map.temperature is not None
        word = register_resolution(register_map.axes)
        self._description = DeviceDescription(
            model=model, serial_number=serial_number, protocol="modbus",
            transport=f"modbus+{transport.kind}", axes=("x", "y", "z")[:len(register_map.axes)],
            sample_rate_hz=sample_rate_hz, has_counter=True,
            counter_modulus=register_map.counter_modulus, has_device_time=False,
            has_temperature=has_temp,
            settings=(*transport.settings, ("device_id", str(device_id))),
            accel_axes=ACCEL_AXIS_NAMES[:register_map.n_accel_axes],
            lsb_deg_s=word.lsb_deg_s, lsb_relative=word.lsb_relative)
        # A poll sees a sample up to one poll period after the device produced it.
        self._builder = BatchBuilder(
            len(register_map.axes), CounterTracker(
                register_map.counter_modulus, sample_rate_hz,
                timing_uncertainty_s=(self._poll_wall_s + 0.05) * clock_scale),
            has_device_time=False, has_temperature=has_temp,
            n_accel_axes=register_map.n_accel_axes)
        self._last_counter: int | None = None
        self._connected = False
        self._ever = False
        #: The station held the device until its run started and no sample came since.
        self._held_since_start = False

    def describe(self) -> DeviceDescription:
        return self._description

    def open(self) -> None:
        self.transport.open()
        self._builder.event("reconnect" if self._ever else "connect", self.clock())
        self._connected = self._ever = True

    def close(self) -> None:
        self.transport.close()
        self._connected = False

    def _poll(self) -> None:
        start, count = self.map.span
        try:
            registers = self.transport.read_registers(start, count, self.device_id, self.table)
        except DeviceProtocolError as exc:
            if not (self._held_since_start and isinstance(exc, ModbusExceptionResponse)
                    and exc.exception_code == SERVER_DEVICE_BUSY):
                self._builder.event("timeout", self.clock(), detail=str(exc))
            return
        self._held_since_start = False
        now = self.clock()
        reading = self.map.decode(registers)
        if reading.counter == self._last_counter:
            return
        self._last_counter = reading.counter
        self._builder.add(reading, now)

    def read(self, timeout_s: float = 0.1) -> SampleBatch:
        """Poll for ``timeout_s`` (wall s) and return the new samples."""
        if not self._connected:
            self.open()
        deadline = time.monotonic() + timeout_s
        next_poll = time.monotonic()
        try:
            while True:
                self._poll()
                next_poll += self._poll_wall_s
                now = time.monotonic()
                if now >= deadline:
                    break
                time.sleep(max(0.0, min(next_poll, deadline) - now))
        except DeviceDisconnectedError:
            self.transport.close()
            self._connected = False
            self._builder.event("disconnect", self.clock())
            raise
        return self._builder.take(self.clock())

    def quiet_until_now(self) -> None:
        """The station held the device until now (a simulated unit, held until its run
        starts): it has no sample yet. Until its first, a SERVER DEVICE BUSY answer
        is that device, not a fault, and is not logged."""
        self._held_since_start = True

    def limit_rates(self, limit_deg_s: float | None) -> None:
        """Samples beyond this magnitude (deg/s, any axis) are bad samples."""
        self._builder.rate_limit_deg_s = limit_deg_s

    def limit_accel(self, limit_m_s2: float | None) -> None:
        """Samples whose acceleration exceeds this magnitude (m/s^2, any axis) are bad
        samples (the product profile's accelerometer range; None: no limit)."""
        self._builder.accel_limit_m_s2 = limit_m_s2


class ModbusEnvironmentChannel:
    """One environment value (a chamber's or a reference sensor's temperature) over Modbus.

    Parameters
    ----------
    transport : ModbusTransport
        The client (may be shared with nothing else: one client per server).
    field : RegisterField
        Where the value is, degC per LSB in ``scale``.
    device_id : int
        Modbus unit address.
    name, unit : str
        What it is and its unit (``"chamber"``, ``"degC"``).
    clock : callable
        Station clock, s.
    """

    def __init__(self, transport: ModbusTransport, field: RegisterField, *, device_id: int = 1,
                 name: str = "chamber", unit: str = "degC",
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.transport = transport
        self.field = field
        self.device_id = device_id
        self.name = name
        self.unit = unit
        self.clock = clock

    def open(self) -> None:
        self.transport.open()

    def close(self) -> None:
        self.transport.close()

    def read(self) -> tuple[float, float]:
        """(station time s, value in :attr:`unit`)."""
        registers = self.transport.read_registers(self.field.address, self.field.n_registers,
                                                  self.device_id)
        return self.clock(), self.field.unpack(registers)
