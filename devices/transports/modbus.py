"""Modbus transport over pymodbus 3.x synchronous clients (TCP and RTU).

pymodbus 3.x took ``device_id=`` in place of ``slave=``/``unit=`` and dropped the payload
module; this wrapper is the only place that knows its client API.
"""

from __future__ import annotations

from typing import Literal

from pymodbus.client import ModbusBaseSyncClient, ModbusSerialClient, ModbusTcpClient
from pymodbus.exceptions import ModbusException

from devices.errors import DeviceDisconnectedError, DeviceProtocolError


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
        if self._client is None:
            raise DeviceDisconnectedError("Modbus client is not connected")
        request = (self._client.read_holding_registers if table == "holding"
                   else self._client.read_input_registers)
        try:
            response = request(address, count=count, device_id=device_id)
        except (ModbusException, OSError) as exc:  # OSError: a reset mid-request
            self.close()
            raise DeviceDisconnectedError(f"Modbus {self.target}: {exc}") from exc
        if response.isError():
            raise DeviceProtocolError(f"Modbus exception response {response}")
        return list(response.registers)
