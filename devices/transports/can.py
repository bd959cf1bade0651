"""CAN transport over python-can: SocketCAN on a bench, the ``virtual`` bus in tests."""

from __future__ import annotations

import socket
import struct
import warnings
from typing import Any, Protocol

import can
from can.interfaces.udp_multicast.bus import GeneralPurposeUdpMulticastBus, UdpMulticastBus

from devices.errors import DeviceDisconnectedError, ExposedBusWarning

#: The interface simulated devices and their recorders meet on: loopback only.
LOOPBACK = "127.0.0.1"


class CanLink(Protocol):
    """What :class:`~devices.can_raw.CanRateSource` uses of a CAN transport (this
    module's :class:`CanTransport`, or a recording or replaying one)."""

    @property
    def interface(self) -> str:
        """The python-can interface (``socketcan``, ``virtual``, ``udp_multicast``)."""

    @property
    def channel(self) -> str:
        """The bus channel (``can0``, a virtual channel's name, a multicast group)."""

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


class _LoopbackGroup(GeneralPurposeUdpMulticastBus):
    """python-can's multicast socket, on the loopback interface only.

    The socket is bound to the group's address (so no unicast datagram sent to the port
    reaches it), joins the group on 127.0.0.1 only (a frame multicast on the LAN is not
    taken), and sends on 127.0.0.1 with a time to live of 0 (nothing leaves the host).
    """

    def _create_socket(self, address_family: socket.AddressFamily) -> socket.socket:
        if address_family != socket.AF_INET:
            raise OSError("a loopback-only bus takes an IPv4 multicast group")
        sock = socket.socket(address_family, socket.SOCK_DGRAM)
        try:
            sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, struct.pack("@I", 0))
            sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF,
                            socket.inet_aton(LOOPBACK))
            sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            if hasattr(socket, "SO_REUSEPORT"):
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
            try:
                # Linux only (not in every platform's socket module)
                sock.setsockopt(socket.SOL_SOCKET, getattr(socket, "SO_TIMESTAMPNS", -1), 1)
                self.timestamp_nanosecond = True
            except (OSError, AttributeError):
                self.timestamp_nanosecond = False
            sock.bind((self.group, self.port))
            sock.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
                            socket.inet_aton(self.group) + socket.inet_aton(LOOPBACK))
        except OSError:
            sock.close()
            raise
        return sock


class LoopbackMulticastBus(UdpMulticastBus):
    """python-can's ``udp_multicast`` bus confined to this host (see :class:`_LoopbackGroup`)."""

    def __init__(self, channel: str, port: int = 43113, **kwargs: Any) -> None:
        can.BusABC.__init__(self, channel, **kwargs)
        self._multicast = _LoopbackGroup(channel, port, 0)
        self._can_protocol = can.CanProtocol.CAN_FD


class CanTransport:
    """A python-can bus opened on demand.

    Parameters
    ----------
    interface : str
        python-can interface (``"socketcan"``, ``"virtual"``, ``"udp_multicast"``, ...).
    channel : str
        Channel (``"can0"``, a virtual channel name, a multicast group).
    loopback_only : bool
        For ``udp_multicast``: meet on 127.0.0.1 only (the default). False takes
        python-can's own socket (every interface, the default route), which anyone on the
        network can send frames to: it warns (:class:`ExposedBusWarning`).
    bus_kwargs
        Further arguments of :class:`can.Bus` (``bitrate``, ...).
    """

    def __init__(self, interface: str, channel: str, *, loopback_only: bool = True,
                 **bus_kwargs: Any) -> None:
        self.interface = interface
        self.channel = channel
        self.loopback_only = loopback_only
        self.bus_kwargs = bus_kwargs
        self.bus: can.BusABC | None = None

    @property
    def settings(self) -> tuple[tuple[str, str], ...]:
        bind = (("bind", "loopback" if self.loopback_only else "all"),
                ) if self.interface == "udp_multicast" else ()
        return (("interface", self.interface), ("channel", self.channel), *bind,
                *((k, str(v)) for k, v in self.bus_kwargs.items()))

    def _make_bus(self) -> can.BusABC:
        if self.interface != "udp_multicast":
            return can.Bus(interface=self.interface, channel=self.channel, **self.bus_kwargs)
        if self.loopback_only:
            return LoopbackMulticastBus(self.channel, **self.bus_kwargs)
        warnings.warn(f"CAN bus udp_multicast {self.channel} is open on every network "
                      f"interface (bind=all): any host on the network can send it frames",
                      ExposedBusWarning, stacklevel=3)
        return can.Bus(interface=self.interface, channel=self.channel, **self.bus_kwargs)

    def open(self) -> None:
        self.close()
        try:
            self.bus = self._make_bus()
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
