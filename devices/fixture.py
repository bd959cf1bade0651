"""The fixture around the gyros: supply relays and a temperature chamber, over Modbus.

Adapters built from a :class:`~devices.transports.modbus.ModbusTransport` and a pure map
(:mod:`devices.codecs.fixture_map`), and the URLs that name them::

    modbus+tcp://10.0.0.5:502/1?coil=3                 relay output (coil 3 of unit 1)
    modbus+rtu:///dev/ttyUSB1?unit=2&baud=19200&coil=0
    modbus+tcp://10.0.0.6:502/1?setpoint=300&measured=100&kind=int16&scale=0.1
                                                        chamber controller

Every write is read back: a relay that did not switch or a controller that did not take
the set point is a :class:`~devices.errors.DeviceProtocolError`, never a silent test at
the wrong condition.
"""

from __future__ import annotations

import time
from urllib.parse import unquote, urlsplit

from devices.codecs.fixture_map import ChamberMap, RelayMap
from devices.errors import CodecError, DeviceConfigurationError, DeviceProtocolError
from devices.sim.params import query_number
from devices.transports.modbus import ModbusTransport
from devices.url_query import check_keys, parse_query


def _where(transport: ModbusTransport, device_id: int) -> str:
    place = (f"{transport.target}:{transport.port}" if transport.kind == "tcp"
             else transport.target)
    return f"modbus+{transport.kind} {place} unit {device_id}"


class ModbusPowerSwitch:
    """One relay output (a coil) of a Modbus relay module.

    Parameters
    ----------
    transport : ModbusTransport
        The client.
    output : int
        Relay output switching this unit's supply.
    relay_map : RelayMap
        Where the outputs' coils are.
    device_id : int
        Modbus unit address of the module.
    """

    def __init__(self, transport: ModbusTransport, output: int, *,
                 relay_map: RelayMap | None = None, device_id: int = 1) -> None:
        self.transport = transport
        self.map = relay_map or RelayMap()
        self.coil = self.map.coil(output)
        self.output = output
        self.device_id = device_id

    def open(self) -> None:
        self.transport.open()

    def close(self) -> None:
        self.transport.close()

    def set_power(self, on: bool) -> float:
        before = time.time()
        self.transport.write_coil(self.coil, on, self.device_id)
        switched = (before + time.time()) / 2.0  # the module acted inside the exchange
        if self.is_powered() != on:
            raise DeviceProtocolError(f"{self.describe()}: switched {'on' if on else 'off'} "
                                      f"but reads back {'off' if on else 'on'}")
        return switched

    def is_powered(self) -> bool:
        return self.transport.read_coils(self.coil, 1, self.device_id)[0]

    def describe(self) -> str:
        return f"{_where(self.transport, self.device_id)} coil {self.coil}"


class ModbusChamber:
    """A temperature chamber's controller: set point in a holding register, air
    temperature in an input register.

    Parameters
    ----------
    transport : ModbusTransport
        The client.
    chamber_map : ChamberMap
        Where and how the values are.
    device_id : int
        Modbus unit address of the controller.
    """

    def __init__(self, transport: ModbusTransport, *, chamber_map: ChamberMap | None = None,
                 device_id: int = 1) -> None:
        self.transport = transport
        self.map = chamber_map or ChamberMap()
        self.device_id = device_id

    def open(self) -> None:
        self.transport.open()

    def close(self) -> None:
        self.transport.close()

    def set_temperature(self, temperature_c: float) -> None:
        words = self.map.encode_setpoint(temperature_c)
        self.transport.write_registers(self.map.setpoint.address, words, self.device_id)
        held = self.setpoint_c()
        if abs(held - temperature_c) > abs(self.map.setpoint.scale):
            raise DeviceProtocolError(f"{self.describe()}: set point {temperature_c:g} degC "
                                      f"written, {held:g} degC read back")

    def setpoint_c(self) -> float:
        f = self.map.setpoint
        return self.map.decode_setpoint(
            self.transport.read_registers(f.address, f.n_registers, self.device_id, "holding"))

    def temperature_c(self) -> float:
        f = self.map.measured
        return self.map.decode_measured(
            self.transport.read_registers(f.address, f.n_registers, self.device_id, "input"))

    def describe(self) -> str:
        return (f"{_where(self.transport, self.device_id)} set point register "
                f"{self.map.setpoint.address}, measured register {self.map.measured.address}")


_LINK_KEYS = {"modbus+tcp": frozenset({"unit", "timeout"}),
              "modbus+rtu": frozenset({"unit", "baud", "timeout"})}
_CHAMBER_KEYS = frozenset({"setpoint", "measured", "kind", "scale", "word_order", "min_c",
                           "max_c"})


def _link(url: str, extra: frozenset[str]) -> tuple[ModbusTransport, int, dict[str, str]]:
    parts = urlsplit(url)
    scheme = parts.scheme.lower()
    if scheme not in _LINK_KEYS:
        raise DeviceConfigurationError(
            f"{url!r}: a power switch or chamber is reached by modbus+tcp://HOST:PORT/UNIT "
            f"or modbus+rtu:///dev/PORT?unit=N (scheme {parts.scheme!r})")
    query = parse_query(parts.query, url)
    check_keys(query, _LINK_KEYS[scheme] | extra, url)
    timeout = query_number("timeout", query.get("timeout", "1.0"), float)
    host = unquote(parts.netloc)
    if scheme == "modbus+tcp":
        hostname, _, port = host.partition(":")
        if not hostname:
            raise DeviceConfigurationError(f"{url!r}: no host (modbus+tcp://HOST:PORT/UNIT)")
        unit = parts.path.strip("/") or query.get("unit", "1")
        transport = ModbusTransport("tcp", hostname, port=query_number("port", port or "502", int),
                                    timeout_s=timeout)
    else:
        unit = query.get("unit", "1")
        transport = ModbusTransport("rtu", unquote(parts.path),
                                    baudrate=query_number("baud", query.get("baud", "19200"), int),
                                    timeout_s=timeout)
    return transport, query_number("unit", unit, int), query


def open_power_switch(url: str) -> ModbusPowerSwitch:
    """The power switch a URL names (not opened yet): ``modbus+tcp://HOST:PORT/UNIT?coil=N``
    (``coil``: the relay output, default 0) or ``modbus+rtu:///dev/PORT?unit=N&coil=K``.

    Raises
    ------
    DeviceConfigurationError
        Unknown scheme, a missing host, an unknown, repeated or malformed key.
    """
    transport, unit, query = _link(url, frozenset({"coil"}))
    try:
        return ModbusPowerSwitch(transport, query_number("coil", query.get("coil", "0"), int),
                                 device_id=unit)
    except CodecError as exc:
        raise DeviceConfigurationError(f"{url!r}: {exc}") from exc


def open_chamber(url: str) -> ModbusChamber:
    """The chamber a URL names (not opened yet): ``modbus+tcp://HOST:PORT/UNIT`` with the
    register keys of :meth:`ChamberMap.from_keys` (default: set point holding register 0,
    air temperature input register 0, int16 at 0.1 degC, range -70..180 degC).

    Raises
    ------
    DeviceConfigurationError
        Unknown scheme, a missing host, an unknown, repeated or malformed key.
    """
    transport, unit, query = _link(url, _CHAMBER_KEYS)
    try:
        return ModbusChamber(transport, chamber_map=ChamberMap.from_keys(query), device_id=unit)
    except CodecError as exc:
        raise DeviceConfigurationError(f"{url!r}: {exc}") from exc
