"""CAN transport over python-can: SocketCAN on a bench, the ``virtual`` bus in tests."""

from __future__ import annotations

from typing import Any, Protocol

import can

from devices.errors import DeviceDisconnectedError


class CanLink(Protocol):
    """What :class:`~devices.can_raw.CanRateSource` uses of a CAN transport (this
    module's :class:`CanTransport`, or a recording or replaying one)."""

    interface: str
    channel: str

    @property
    def settings(self) -> tuple[tuple[str, str], ...]:
        """Settings as text for the run metadata."""

    def open(self) -> None:
        """Open the bus; DeviceDisconnectedError if it is not there."""

    def close(self) -> None:
        """Close the bus; safe to call twice."""

    def recv(self, timeout_s: float) -> can.Message | None:
        """Next frame, waiting at most ``timeout_s`` (wall s); None on timeout."""

    def send(self, arbitration_id: int, data: bytes, timestamp: float = 0.0) -> None:
        """Send a standard-ID data frame."""


class CanTransport:
    """A python-can bus opened on demand.

    Parameters
    ----------
    interface : str
        python-can interface (``"socketcan"``, ``"virtual"``, ``"udp_multicast"``, ...).
    channel : str
        Channel (``"can0"``, a virtual channel name, a multicast group).
    bus_kwargs
        Further arguments of :class:`can.Bus` (``bitrate``, ...).
    """

    def __init__(self, interface: str, channel: str, **bus_kwargs: Any) -> None:
        self.interface = interface
        self.channel = channel
        self.bus_kwargs = bus_kwargs
        self.bus: can.BusABC | None = None

    @property
    def settings(self) -> tuple[tuple[str, str], ...]:
        return (("interface", self.interface), ("channel", self.channel),
                *((k, str(v)) for k, v in self.bus_kwargs.items()))

    def open(self) -> None:
        self.close()
        try:
            self.bus = can.Bus(interface=self.interface, channel=self.channel, **self.bus_kwargs)
        except (can.CanError, OSError, ValueError) as exc:
            raise DeviceDisconnectedError(f"cannot open CAN {self.interface}:{self.channel}: "
                                          f"{exc}") from exc

    def close(self) -> None:
        bus, self.bus = self.bus, None
        if bus is not None:
            bus.shutdown()

    def _bus(self) -> can.BusABC:
        if self.bus is None:
            raise DeviceDisconnectedError(f"CAN {self.channel} is not open")
        return self.bus

    def recv(self, timeout_s: float) -> can.Message | None:
        """Next message, waiting at most ``timeout_s`` (s); None on timeout."""
        try:
            return self._bus().recv(timeout_s)
        except (can.CanError, OSError) as exc:
            raise DeviceDisconnectedError(f"CAN {self.channel}: {exc}") from exc

    def send(self, arbitration_id: int, data: bytes, timestamp: float = 0.0) -> None:
        """Send a standard-ID data frame (``timestamp``: wall-clock s, kept by buses opened
        with ``preserve_timestamps=True``, as a simulated device's is)."""
        msg = can.Message(arbitration_id=arbitration_id, data=data, is_extended_id=False,
                          timestamp=timestamp)
        try:
            self._bus().send(msg)
        except (can.CanError, OSError) as exc:
            raise DeviceDisconnectedError(f"CAN {self.channel}: {exc}") from exc
