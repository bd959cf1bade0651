"""Modbus transport over pymodbus 3.x synchronous clients (TCP and RTU).

pymodbus 3.x took ``device_id=`` in place of ``slave=``/``unit=`` and dropped the payload
module; this wrapper is the only place that knows its client API.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Literal

from pymodbus.client import ModbusBaseSyncClient, ModbusSerialClient, ModbusTcpClient
from pymodbus.exceptions import ModbusException

from devices.errors import DeviceDisconnectedError, DeviceProtocolError

#: Exception code of a server that cannot answer now and asks to be polled again
#: (Modbus Application Protocol Specification V1.1b3, section 7, code 06).
SERVER_DEVICE_BUSY = 0x06


class ModbusExceptionResponse(DeviceProtocolError):
    """The server answered a request with a Modbus exception response.

    Attributes
    ----------
    exception_code : int or None
        Its exception code (Modbus Application Protocol V1.1b3, section 7), None where
        the response carries none.
    """

    def __init__(self, message: str, exception_code: int | None) -> None:
        super().__init__(message)
        self.exception_code = exception_code


class ModbusTransport:
    """A Modbus client to one server, TCP (``host:port``) or RTU (a serial port).

    Parameters
    ----------
    kind : {"tcp", "rtu"}
        Transport.
    target : str
        ``host`` for TCP, serial port path for RTU.
    port : int
        TCP port.
    baudrate : int
        RTU line rate, bit/s.
    timeout_s : float
        Response timeout, s.
    """

    def __init__(self, kind: Literal["tcp", "rtu"], target: str, *, port: int = 502,
                 baudrate: int = 19200, timeout_s: float = 0.5) -> None:
        if kind not in ("tcp", "rtu"):
            raise ValueError(f"Modbus transport must be tcp or rtu, got {kind!r}")
        self.kind = kind
        self.target = target
        self.port = port
        self.baudrate = baudrate
        self.timeout_s = timeout_s
        self._client: ModbusBaseSyncClient | None = None

    @property
    def settings(self) -> tuple[tuple[str, str], ...]:
        where = (("host", self.target), ("port", str(self.port))) if self.kind == "tcp" else (
            ("port", self.target), ("baudrate", str(self.baudrate)))
        return (("modbus", self.kind), *where)

    def open(self) -> None:
        self.close()
        if self.kind == "tcp":
            client: ModbusBaseSyncClient = ModbusTcpClient(
                self.target, port=self.port, timeout=self.timeout_s, retries=0)
        else:
            client = ModbusSerialClient(self.target, baudrate=self.baudrate,
                                        timeout=self.timeout_s, retries=0)
        if not client.connect():
            client.close()
            raise DeviceDisconnectedError(f"cannot connect to Modbus {self.kind} "
                                          f"{self.target}:{self.port}")
        self._client = client

    def close(self) -> None:
        client, self._client = self._client, None
        if client is not None:
            client.close()

    def _call(self, what: str, request: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        """One request through the client: a lost link is DeviceDisconnectedError (the
        client closed), a Modbus exception response ModbusExceptionResponse naming ``what``."""
        try:
            response = request(*args, **kwargs)
        except (ModbusException, OSError) as exc:  # OSError: a reset mid-request
            self.close()
            raise DeviceDisconnectedError(f"Modbus {self.target}: {exc}") from exc
        if response.isError():
            raise ModbusExceptionResponse(f"Modbus exception response to {what}: {response}",
                                          getattr(response, "exception_code", None))
        return response

    def read_coils(self, address: int, count: int, device_id: int) -> list[bool]:
        """Coils ``address .. address + count - 1`` of ``device_id`` (relay outputs).

        Raises
        ------
        DeviceDisconnectedError, DeviceProtocolError
            As :meth:`read_registers`.
        """
        client = self._connected()
        response = self._call(f"reading coils {address}+{count}", client.read_coils, address,
                              count=count, device_id=device_id)
        return [bool(b) for b in response.bits[:count]]

    def write_coil(self, address: int, value: bool, device_id: int) -> None:
        """Set coil ``address`` of ``device_id`` on or off (a relay output).

        Raises
        ------
        DeviceDisconnectedError, DeviceProtocolError
            As :meth:`read_registers`.
        """
        client = self._connected()
        self._call(f"writing coil {address}", client.write_coil, address, bool(value),
                   device_id=device_id)

    def write_registers(self, address: int, values: list[int], device_id: int) -> None:
        """Write holding registers ``address ..`` of ``device_id`` (function 16).

        Raises
        ------
        DeviceDisconnectedError, DeviceProtocolError
            As :meth:`read_registers`.
        """
        client = self._connected()
        self._call(f"writing registers {address}+{len(values)}", client.write_registers,
                   address, list(values), device_id=device_id)

    def _connected(self) -> ModbusTcpClient | ModbusSerialClient:
        if self._client is None:
            raise DeviceDisconnectedError("Modbus client is not connected")
        return self._client  # type: ignore[return-value]

    def read_registers(self, address: int, count: int, device_id: int,
                       table: Literal["holding", "input"] = "holding") -> list[int]:
        """Registers ``address .. address + count - 1`` of ``device_id``.

        Raises
        ------
        DeviceDisconnectedError
            No connection or no answer.
        DeviceProtocolError
            The server answered with a Modbus exception.
        """
        client = self._connected()
        request = (client.read_holding_registers if table == "holding"
                   else client.read_input_registers)
        response = self._call(f"reading {table} registers {address}+{count}", request,
                              address, count=count, device_id=device_id)
        return list(response.registers)
