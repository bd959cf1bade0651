"""Byte-stream transport over pyserial (a real port, a pty, or any pyserial URL)."""

from __future__ import annotations

from typing import Protocol

import serial

from devices.errors import DeviceDisconnectedError

#: The most bytes a tty read hands over at once (the line discipline's buffer, 4096 on
#: Linux): a read that got that many may have left older bytes in the port.
LINE_DISCIPLINE_BYTES = 4096


class ByteTransport(Protocol):
    """A byte stream that can be opened again after it is lost."""

    def open(self) -> None:
        """Open (or reopen) the link; raises DeviceDisconnectedError if it is not there."""

    def close(self) -> None:
        """Close the link; safe to call twice."""

    def read(self, timeout_s: float) -> bytes:
        """Bytes available, waiting up to ``timeout_s`` (wall s) for the first.

        Empty only after waiting the whole timeout with nothing arriving: the stream
        adapter takes an empty read as proof of a silence that long.
        """

    def write(self, data: bytes) -> None:
        """Send ``data``."""

    @property
    def settings(self) -> tuple[tuple[str, str], ...]:
        """Settings as text for the run metadata."""


class SerialTransport:
    """A serial port opened by path or pyserial URL (``/dev/ttyUSB0``, a pty, ``loop://``).

    Parameters
    ----------
    port : str
        Device path or pyserial URL.
    baudrate : int
        Line rate, bit/s (ignored by ptys).
    """

    def __init__(self, port: str, baudrate: int = 921600) -> None:
        self.port = port
        self.baudrate = baudrate
        self._serial: serial.SerialBase | None = None

    @property
    def settings(self) -> tuple[tuple[str, str], ...]:
        return (("port", self.port), ("baudrate", str(self.baudrate)))

    def open(self) -> None:
        self.close()
        try:
            self._serial = serial.serial_for_url(self.port, baudrate=self.baudrate, timeout=0)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise DeviceDisconnectedError(f"cannot open {self.port}: {exc}") from exc

    def close(self) -> None:
        port, self._serial = self._serial, None
        if port is not None:
            try:
                port.close()
            except (serial.SerialException, OSError):
                pass

    def _port(self) -> serial.SerialBase:
        if self._serial is None:
            raise DeviceDisconnectedError(f"{self.port} is not open")
        return self._serial

    def read(self, timeout_s: float) -> bytes:
        port = self._port()
        try:
            port.timeout = timeout_s
            first = port.read(1)
            if not first:
                return b""
            port.timeout = 0
            return bytes(first + port.read(port.in_waiting or 0))
        except (serial.SerialException, OSError, TypeError) as exc:
            # pyserial raises TypeError from a port closed under it by another thread.
            raise DeviceDisconnectedError(f"{self.port}: {exc}") from exc

    def write(self, data: bytes) -> None:
        try:
            self._port().write(data)
        except (serial.SerialException, OSError) as exc:
            raise DeviceDisconnectedError(f"{self.port}: {exc}") from exc
