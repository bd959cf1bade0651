"""Device URLs: one string selects the transport, the protocol and its settings.

Real hardware and simulations go through the same adapters::

    serial:///dev/ttyUSB0?protocol=stim300&baud=921600&rate=2000
    sim+serial://STIM300?protocol=kvh1750&rate=1000&warp=10&drop=0.001&seed=1

A ``sim+`` URL starts a simulated device that speaks the protocol over a real transport
(a pty here) and returns the adapter connected to it. Its host part (or ``model=``) is
the noise model; the query keys of every simulation are those of :class:`SimParams`.
"""

from __future__ import annotations

import uuid
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any, Protocol
from urllib.parse import unquote, urlencode, urlsplit

from devices.bus_layouts import can_layout, register_map
from devices.can_raw import CanRateSource
from devices.canopen_node import CanopenRateSource
from devices.codecs.base import Reading
from devices.codecs.can_frame import CanFrameLayout
from devices.codecs.kvh1750 import Kvh1750Codec
from devices.codecs.modbus_map import ModbusRegisterMap
from devices.codecs.stim300 import Stim300Codec
from devices.codecs.stim300_sheet import max_rate_hz
from devices.codecs.xbus import XbusCodec
from devices.errors import DeviceConfigurationError
from devices.modbus import ModbusRateSource
from devices.opened import OpenedDevice, SimulatedDevice, Simulator
from devices.replay import (
    recording_transport,
)
from devices.replay_urls import open_replay
from devices.serial_codecs import stream_codec
from devices.sim.can_device import CanBroadcastDevice, broadcast_latency_s
from devices.sim.canopen_device import GYRO_EDS, CanopenGyroNode
from devices.sim.clock import WarpClock
from devices.sim.kvh_unit import KvhMessageWriter
from devices.sim.modbus_server import ModbusGyroServer
from devices.sim.mti import MtiMessages
from devices.sim.params import (
    BENCH_KEYS,
    FAULT_KEYS,
    FIXTURE_KEYS,
    SimParams,
    parse_sim_params,
    query_number,
    sim_core,
)
from devices.sim.process import MulticastChannel, SimulatorProcess
from devices.sim.serial_device import PtySerialDevice
from devices.sim.stim300_unit import SimulatedStim300
from devices.stream import StreamRateSource
from devices.transports.can import CanTransport
from devices.transports.modbus import ModbusTransport
from devices.transports.serial import SerialTransport
from devices.url_query import (
    CAN_BUS_KEYS,
    HARDWARE_KEYS,
    SERIAL_PROTOCOL_KEYS,
    SIM_KEYS,
    SIM_SERIAL_PROTOCOL_KEYS,
    accel_switch,
    check_keys,
    parse_query,
)

#: URL keys that say how to run a simulation or record a session, not how to talk to the
#: device: a hardware URL of a served simulation and a capture's replay URL drop them.
_NOT_PROTOCOL_KEYS = frozenset({"model", "warp", "seed", "history", "interface", "capture",
                                *FAULT_KEYS, *BENCH_KEYS, *FIXTURE_KEYS,
                                *SIM_SERIAL_PROTOCOL_KEYS["xbus"]})


def _protocol_query(query: dict[str, str], **keys: str) -> str:
    """``query``'s protocol keys (layout, map, datagram, ...) with ``keys`` set, encoded."""
    kept = {k: v for k, v in query.items() if k not in _NOT_PROTOCOL_KEYS}
    kept.update(keys)
    return urlencode(kept)


def _hardware_url(params: SimParams, scheme: str, location: str, query: dict[str, str],
                  **keys: str) -> str | None:
    """The URL by which another process opens a running simulation as hardware (its
    protocol keys kept, the simulation's dropped), or None when it runs warped: a
    hardware adapter keeps wall time."""
    if params.warp != 1.0:
        return None
    return f"{scheme}://{location}?{_protocol_query(query, **keys, rate=f'{params.rate:g}')}"


def _captured(transport: Any, url_scheme: str, query: dict[str, str], rate_hz: float,
              warp: float) -> Any:
    """``transport``, recording a capture file when the URL has ``capture=FILE``.

    The capture's header keeps what a ``replay://FILE`` URL needs to rebuild the adapter:
    ``replay_url``, the scheme with the protocol keys, the rate (Hz) and the warp.
    """
    path = query.get("capture")
    if not path:
        return transport
    replay_url = f"{url_scheme}://?{_protocol_query(query, rate=f'{rate_hz:g}', warp=f'{warp:g}')}"
    try:
        return recording_transport(transport, path, settings={"replay_url": replay_url})
    except OSError as exc:
        raise DeviceConfigurationError(f"cannot write the capture file {path!r}: {exc}") from exc


def _unit_model(host: str, params: SimParams) -> str:
    """The model a simulated unit describes itself as: the URL's host part (the product,
    ``sim+serial://ADIS16405?model=profiles/models/mems-typical.toml``), else the noise
    model's name (a preset, or a model file's stem), never a file path."""
    return host or Path(params.model).stem


def _no_capture(query: dict[str, str], what: str) -> None:
    if "capture" in query:
        raise DeviceConfigurationError(f"capture= records serial and raw CAN links, not {what}")


def _sim_params(host: str, query: dict[str, str], held: bool) -> SimParams:
    """The simulation parameters of a ``sim+`` URL; ``held``: its device starts held
    (:attr:`SimParams.held`)."""
    return replace(parse_sim_params(query.get("model", host), query), held=held)


# -- serial protocols ----------------------------------------------------------------

def _simulate_serial(path: str, query: dict[str, str], host: str, *, held: bool = False
                     ) -> OpenedDevice:
    protocol = query.get("protocol", "stim300")
    params = _sim_params(host, query, held)
    if protocol == "stim300" and _unit_model(host, params) != "STIM300":
        # another model borrowing the datagram layout: its counter counts its datagrams
        query = {"counter": "datagram", **query}
    codec, header, _ = stream_codec(protocol, query, params.rate)
    core, clock = sim_core(params, codec.n_axes, n_accel_axes=codec.n_accel_axes)
    message: Callable[[Reading], bytes] | None = None
    if isinstance(codec, Kvh1750Codec):  # the unit's messages, from the ICD's tables
        message = KvhMessageWriter(codec.message_format or "A", codec.tempunits,
                                   codec.angle_unit, codec.output, params.rate)
    elif isinstance(codec, Stim300Codec):  # the unit speaks from its data sheet
        message = SimulatedStim300(
            codec.identifier, codec.rate_hz, int(query.get("accel_range", "10")), codec.crlf,
            query.get("gyro_output", "rate"),
            query.get("accel_output", "acceleration")).datagram
    mti = None
    if isinstance(codec, XbusCodec):  # an MTi's messages, from the protocol document
        gnss_hz = query_number("gnss", query.get("gnss", "0"), float)
        try:
            mti = MtiMessages(params.rate, gnss_hz=gnss_hz, accel=bool(codec.n_accel_axes),
                              high_rate=codec.high_rate)
        except ValueError as exc:
            raise DeviceConfigurationError(f"URL key gnss: {exc}") from exc
    device = PtySerialDevice(codec, core, header=header, message=message, mti=mti).start()
    transport = _captured(SerialTransport(device.port), "serial", query, params.rate,
                          params.warp)
    source = StreamRateSource(transport, codec, model=_unit_model(host, params),
                              serial_number=params.serial_number,
                              sample_rate_hz=params.rate, clock=clock,
                              clock_scale=params.warp, max_latency_s=device.max_latency_s)
    return SimulatedDevice(source, hardware_url=_hardware_url(params, "serial", device.port,
                                                              query), simulator=device)


def _open_serial(path: str, query: dict[str, str], host: str) -> OpenedDevice:
    protocol = query.get("protocol", "stim300")
    rate = query_number("rate", query.get("rate", "2000"), float)
    codec, _, model = stream_codec(protocol, query, rate)
    baud = query_number("baud", query.get("baud", "921600"), int)
    if isinstance(codec, Stim300Codec) and codec.rate_hz is not None:
        top = max_rate_hz(codec.identifier, baud)
        if top is not None and rate > top:
            raise DeviceConfigurationError(
                f"a STIM300 sends datagram 0x{codec.identifier:02X} at {baud} bit/s at up "
                f"to {top} samples/s (TS1524 Table 5-12), not {rate:g}")
    transport = _captured(SerialTransport(path, baud), "serial", query, rate, 1.0)
    source = StreamRateSource(transport, codec, model=query.get("model", model),
                              serial_number=query.get("serial", "unknown"), sample_rate_hz=rate)
    return OpenedDevice(source)


# -- raw CAN -------------------------------------------------------------------------

def _start_can_broadcast(params: SimParams, layout: CanFrameLayout, bus: MulticastChannel,
                         clock: WarpClock) -> CanBroadcastDevice:
    """Run in a simulator process: a raw-CAN gyro on a ``udp_multicast`` bus."""
    core, _ = sim_core(params, len(layout.axes), clock, n_accel_axes=layout.n_accel_axes)
    return CanBroadcastDevice(bus.transport(), layout, core).start()


def _start_canopen_node(params: SimParams, node_id: int, accel: bool, bus: MulticastChannel,
                        clock: WarpClock) -> CanopenGyroNode:
    """Run in a simulator process: a CANopen gyro (or IMU) node on a ``udp_multicast`` bus."""
    core, _ = sim_core(params, 3, clock, n_accel_axes=3 if accel else 0)
    return CanopenGyroNode(bus.transport(), core, node_id=node_id,
                           serial_number=params.seed or 1).start()


def _node_in_a_process(start: Callable[..., Any], params: SimParams, *args: Any,
                       describe: str, loopback: bool
                       ) -> tuple[SimulatorProcess, WarpClock, MulticastChannel]:
    """Start ``start(params, *args, bus, clock)`` in a child process on a fresh
    ``udp_multicast`` bus; returns the running simulator, the shared clock and the bus."""
    bus = MulticastChannel.fresh(loopback=loopback)
    clock = WarpClock(params.warp)
    simulator = SimulatorProcess(partial(start, params, *args, bus, clock), clock,
                                 describe=f"{describe} on {bus.group}:{bus.port}").start()
    return simulator, clock, bus


def _sim_bus(query: dict[str, str]) -> str:
    """The bus a simulated CAN device uses: ``virtual`` (this process, the default) or
    ``udp_multicast`` (the device runs in a process of its own)."""
    interface = query.get("interface", "virtual")
    if interface not in ("virtual", "udp_multicast"):
        raise DeviceConfigurationError(
            f"a simulated CAN device runs on interface=virtual (in this process) or "
            f"interface=udp_multicast (in a process of its own), not {interface!r}")
    return interface


def _loopback_only(query: dict[str, str]) -> bool:
    """``bind=loopback`` (the default): a ``udp_multicast`` bus stays on 127.0.0.1;
    ``bind=all`` opens it on every interface (and warns when it opens)."""
    bind = query.get("bind", "loopback")
    if bind not in ("loopback", "all"):
        raise DeviceConfigurationError(f"URL key bind={bind!r}: use bind=loopback (this "
                                       f"host only, the default) or bind=all")
    return bind == "loopback"


def _can_bus_kwargs(query: dict[str, str]) -> dict[str, Any]:
    """python-can bus arguments a hardware URL may set: ``bitrate`` (bit/s), ``port``
    (the UDP port of a ``udp_multicast`` bus)."""
    return {key: query_number(key, query[key], int) for key in ("bitrate", "port")
            if key in query}


def _simulate_can(path: str, query: dict[str, str], host: str, *, held: bool = False
                  ) -> OpenedDevice:
    layout = can_layout(query.get("layout", "shared"), accel_switch(query))
    params = _sim_params(host, query, held)
    simulator: Simulator
    multicast = _sim_bus(query) == "udp_multicast"
    if multicast:
        simulator, clock, bus = _node_in_a_process(_start_can_broadcast, params, layout,
                                                   describe="CAN gyro",
                                                   loopback=_loopback_only(query))
        transport = bus.transport()
        reach = _hardware_url(params, "can", bus.group, query, interface="udp_multicast",
                              port=str(bus.port))
    else:
        reach = None
        core, clock = sim_core(params, len(layout.axes), n_accel_axes=layout.n_accel_axes)
        channel = f"gyro-sim-{uuid.uuid4().hex[:12]}"
        simulator = CanBroadcastDevice(
            CanTransport("virtual", channel, preserve_timestamps=True), layout, core,
            max_lag_wall_s=1.0, stamped=True).start()
        transport = CanTransport("virtual", channel)
    # In this process the node stamps each frame when it fell due; across processes
    # the kernel stamps it when it arrives, up to the node's latency later.
    latency = (broadcast_latency_s(layout, params.rate, params.warp) if multicast
               else 0.005 * params.warp)
    source = CanRateSource(_captured(transport, "can", query, params.rate, params.warp),
                           layout, model=_unit_model(host, params),
                           serial_number=params.serial_number,
                           sample_rate_hz=params.rate, clock=clock,
                           clock_scale=params.warp, max_latency_s=latency)
    return SimulatedDevice(source, hardware_url=reach, simulator=simulator)


def _open_can(path: str, query: dict[str, str], host: str) -> OpenedDevice:
    layout = can_layout(query.get("layout", "shared"), accel_switch(query))
    rate = query_number("rate", query.get("rate", "1000"), float)
    transport = CanTransport(query.get("interface", "socketcan"), host or path.strip("/"),
                             loopback_only=_loopback_only(query), **_can_bus_kwargs(query))
    source = CanRateSource(_captured(transport, "can", query, rate, 1.0), layout,
                           model=query.get("model", "CAN gyro"),
                           serial_number=query.get("serial", "unknown"), sample_rate_hz=rate)
    return OpenedDevice(source)


# -- CANopen ------------------------------------------------------------------------

def _canopen_node(path: str, query: dict[str, str]) -> tuple[int, bool]:
    """(node id, whether TPDOs go on SYNC) of a CANopen URL."""
    _no_capture(query, "CANopen (the canopen library drives the bus itself)")
    node_id = query_number("node", path.strip("/") or query.get("node", "5"), int)
    return node_id, query.get("tpdo", "event") == "sync"


def _simulate_canopen(path: str, query: dict[str, str], host: str, *, held: bool = False
                      ) -> OpenedDevice:
    node_id, sync = _canopen_node(path, query)
    accel = bool(accel_switch(query))  # (the node's TPDO3/4 are off until mapped: accel=1)
    params = _sim_params(host, query, held)
    simulator: Simulator
    if _sim_bus(query) == "udp_multicast":
        simulator, clock, bus = _node_in_a_process(_start_canopen_node, params, node_id, accel,
                                                   describe=f"CANopen node {node_id}",
                                                   loopback=_loopback_only(query))
        transport = bus.transport()
        reach = _hardware_url(params, "canopen", f"{bus.group}/{node_id}", query,
                              interface="udp_multicast", port=str(bus.port))
    else:
        reach = None
        core, clock = sim_core(params, 3, n_accel_axes=3 if accel else 0)
        channel = f"gyro-sim-{uuid.uuid4().hex[:12]}"
        simulator = CanopenGyroNode(CanTransport("virtual", channel), core,
                                    node_id=node_id, serial_number=params.seed or 1).start()
        transport = CanTransport("virtual", channel)
    source = CanopenRateSource(transport, node_id, GYRO_EDS, sample_rate_hz=params.rate,
                               model=_unit_model(host, params), clock=clock,
                               clock_scale=params.warp, sync=sync, accel=accel)
    return SimulatedDevice(source, hardware_url=reach, simulator=simulator)


def _open_canopen(path: str, query: dict[str, str], host: str) -> OpenedDevice:
    node_id, sync = _canopen_node(path, query)
    transport = CanTransport(query.get("interface", "socketcan"), host,
                             loopback_only=_loopback_only(query), **_can_bus_kwargs(query))
    rate = query_number("rate", query.get("rate", "100"), float)
    source = CanopenRateSource(transport, node_id, query.get("eds", str(GYRO_EDS)),
                               sample_rate_hz=rate, model=query.get("model", "CANopen gyro"),
                               sync=sync, accel=bool(accel_switch(query)))
    return OpenedDevice(source)


# -- Modbus --------------------------------------------------------------------------

def _modbus_setup(query: dict[str, str]) -> tuple[ModbusRegisterMap, float]:
    """(register map, oversampling factor) of a Modbus URL."""
    _no_capture(query, "Modbus (pymodbus drives the link itself)")
    return (register_map(query.get("map", "int32"), accel_switch(query)),
            query_number("oversample", query.get("oversample", "2"), float))


def _simulate_modbus(path: str, query: dict[str, str], host: str, *, rtu: bool,
                     held: bool = False) -> OpenedDevice:
    regs, oversample = _modbus_setup(query)
    params = _sim_params(host, query, held)
    core, clock = sim_core(params, len(regs.axes), n_accel_axes=regs.n_accel_axes)
    server = ModbusGyroServer(regs, core, rtu=rtu).start()
    transport = (ModbusTransport("rtu", server.serial_port, baudrate=115200) if rtu
                 else ModbusTransport("tcp", "127.0.0.1", port=server.port))
    source = ModbusRateSource(transport, regs,
                              device_id=server.device_id, model=_unit_model(host, params),
                              serial_number=params.serial_number,
                              sample_rate_hz=params.rate, clock=clock,
                              clock_scale=params.warp, oversample=oversample)
    reach = (_hardware_url(params, "modbus+rtu", server.serial_port, query,
                           unit=str(server.device_id), baud="115200") if rtu
             else _hardware_url(params, "modbus+tcp", f"127.0.0.1:{server.port}/"
                                f"{server.device_id}", query))
    return SimulatedDevice(source, hardware_url=reach, simulator=server)


def _open_modbus(path: str, query: dict[str, str], host: str, *, rtu: bool) -> OpenedDevice:
    regs, oversample = _modbus_setup(query)
    if rtu:  # modbus+rtu:///dev/ttyUSB0?unit=1&baud=19200
        unit = query.get("unit", "1")
        transport = ModbusTransport("rtu", path,
                                    baudrate=query_number("baud", query.get("baud", "19200"), int))
    else:  # modbus+tcp://10.0.0.7:502/1
        hostname, _, port = host.partition(":")
        unit = path.strip("/") or query.get("unit", "1")
        transport = ModbusTransport("tcp", hostname, port=query_number("port", port or "502", int))
    source = ModbusRateSource(transport, regs, device_id=query_number("unit", unit, int),
                              model=query.get("model", "Modbus gyro"),
                              serial_number=query.get("serial", "unknown"),
                              sample_rate_hz=query_number("rate", query.get("rate", "100"), float),
                              oversample=oversample)
    return OpenedDevice(source)


@dataclass(frozen=True)
class SupportedProtocol:
    """A protocol the station can record, its transport, a URL of its simulation, and the
    form of a real device's URL (names in capitals, such as ``FILE.eds``, are to be filled in)."""

    protocol: str
    transport: str
    sim_url: str
    description: str
    hardware_url: str = ""


_SIM_QUERY = "rate={rate}&warp={warp}&seed=1"

#: Every protocol and transport the station supports (``station devices`` prints them).
SUPPORTED: tuple[SupportedProtocol, ...] = (
    SupportedProtocol("stim300", "serial", "sim+serial://STIM300?protocol=stim300&datagram=0x94&"
                      + _SIM_QUERY.format(rate=500, warp=5),
                      "Safran Sensonor STIM300 binary datagram, CRC-32",
                      "serial:///dev/ttyUSB0?protocol=stim300&datagram=0x94&baud=921600&rate=2000"),
    SupportedProtocol("kvh1750", "serial", "sim+serial://DSP-1750?protocol=kvh1750&"
                      + _SIM_QUERY.format(rate=500, warp=5),
                      "KVH DSP-1750 formats A, B, C (36, 40, 38 bytes; format=, tempunits=), "
                      "CRC-32",
                      "serial:///dev/ttyUSB0?protocol=kvh1750&unit=rad&output=delta&tempunits=C&rate=1000"),
    SupportedProtocol("xbus", "serial", "sim+serial://MTI-630?protocol=xbus&"
                      + _SIM_QUERY.format(rate=400, warp=5),
                      "Xsens MTi Xbus MTData2, 8-bit checksum",
                      "serial:///dev/ttyUSB0?protocol=xbus&rate=400"),
    SupportedProtocol("can", "can", "sim+can://VG951?layout=shared&"
                      + _SIM_QUERY.format(rate=500, warp=5),
                      "raw CAN broadcast, configurable layout (an IMU: layout=shared_imu; "
                      "a unit's own: a layout file), AUTOSAR E2E Profile 1 CRC + counter",
                      "can://can0?interface=socketcan&layout=PROFILE.toml&rate=1000"),
    SupportedProtocol("canopen", "canopen", "sim+canopen://VG951/5?"
                      + _SIM_QUERY.format(rate=100, warp=4),
                      "CANopen node (shipped EDS): SDO setup, NMT, TPDO1/2 (an IMU: accel=1 "
                      "maps TPDO3/4), heartbeat",
                      "canopen://can0/5?rate=100&eds=FILE.eds"),
    SupportedProtocol("modbus", "modbus+tcp", "sim+modbus+tcp://VG951?map=int32&"
                      + _SIM_QUERY.format(rate=50, warp=4),
                      "register-map gyro polled over Modbus TCP (INT32/FLOAT32; an IMU: "
                      "map=int32_imu)",
                      "modbus+tcp://10.0.0.7:502/1?map=int32&rate=100"),
    SupportedProtocol("modbus", "modbus+rtu", "sim+modbus+rtu://VG951?map=float32&"
                      + _SIM_QUERY.format(rate=20, warp=2),
                      "register-map gyro polled over Modbus RTU (a pty null modem here)",
                      "modbus+rtu:///dev/ttyUSB0?unit=1&baud=19200&map=float32"),
)


def _allowed_keys(transport: str, simulate: bool, query: dict[str, str]) -> frozenset[str]:
    """The query keys a URL of ``transport`` takes (a simulation's, or hardware's)."""
    base = SIM_KEYS if simulate else HARDWARE_KEYS
    if transport == "serial":
        protocol = query.get("protocol", "stim300")
        own = SERIAL_PROTOCOL_KEYS.get(protocol, frozenset())
        if simulate:
            own |= SIM_SERIAL_PROTOCOL_KEYS.get(protocol, frozenset())
        return base | own | {"protocol", "capture"} | (set() if simulate else {"baud"})
    if transport == "can":
        bus = {"interface", "bind"} if simulate else CAN_BUS_KEYS
        return base | bus | {"layout", "capture", "accel"}
    if transport == "canopen":
        bus = {"interface", "bind"} if simulate else CAN_BUS_KEYS | {"eds"}
        return base | bus | {"node", "tpdo", "capture", "accel"}
    if transport in ("modbus+tcp", "modbus+rtu"):
        link = {"unit", "port" if transport == "modbus+tcp" else "baud"}
        return base | {"map", "oversample", "capture", "accel"} | (set() if simulate else link)
    if "protocol" in query:  # replay://DUMP?protocol=P: a raw byte dump
        own = SERIAL_PROTOCOL_KEYS.get(query["protocol"], frozenset())
        return HARDWARE_KEYS | own | {"protocol", "realtime"}
    return frozenset({"realtime"})  # replay://FILE (a capture)


def open_device(url: str, *, held: bool = False) -> OpenedDevice:
    """The adapter (and simulator) a device URL names; the adapter is not opened yet.

    Parameters
    ----------
    url : str
        ``[sim+]serial://...``, see the module docstring.
    held : bool
        A simulated device starts held (paused) and samples nothing until it is resumed
        (:meth:`~devices.opened.SimulatedDevice.resume`): the recorder's units, whose
        samples start with the run. No effect on hardware.

    Returns
    -------
    OpenedDevice
        Close it to release the adapter and stop any simulator.

    Raises
    ------
    DeviceConfigurationError
        Unknown scheme or protocol, a malformed, repeated or unknown query key.
    """
    parts = urlsplit(url)
    scheme = parts.scheme.lower()
    simulate = scheme.startswith("sim+")
    transport = scheme.removeprefix("sim+")
    query = parse_query(parts.query, url)
    host = unquote(parts.netloc)
    if transport not in _OPENERS:
        raise DeviceConfigurationError(
            f"unknown device URL scheme {parts.scheme!r} in {url!r}; known: "
            + ", ".join(f"{s}, sim+{s}" if s in _SIMULATORS else s for s in _OPENERS))
    check_keys(query, _allowed_keys(transport, simulate, query), url)
    if simulate and transport not in _SIMULATORS:
        raise DeviceConfigurationError("replay://FILE plays a capture file back; there is "
                                       "no sim+replay")
    path = unquote(parts.path)
    opened = (_SIMULATORS[transport](path, query, host, held=held) if simulate
              else _OPENERS[transport](path, query, host))
    opened.url = url
    return opened


_Opener = Callable[[str, dict[str, str], str], OpenedDevice]


class _SimOpener(Protocol):
    def __call__(self, path: str, query: dict[str, str], host: str, *, held: bool
                 ) -> OpenedDevice: ...

#: The adapter of each transport's hardware URL (path, query, host).
_OPENERS: dict[str, _Opener] = {
    "serial": _open_serial,
    "can": _open_can,
    "canopen": _open_canopen,
    "modbus+tcp": partial(_open_modbus, rtu=False),
    "modbus+rtu": partial(_open_modbus, rtu=True),
    "replay": open_replay,
}
#: A simulated device and the adapter talking to it, of each ``sim+`` transport.
_SIMULATORS: dict[str, _SimOpener] = {
    "serial": _simulate_serial,
    "can": _simulate_can,
    "canopen": _simulate_canopen,
    "modbus+tcp": partial(_simulate_modbus, rtu=False),
    "modbus+rtu": partial(_simulate_modbus, rtu=True),
}
