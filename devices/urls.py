"""Device URLs: one string selects the transport, the protocol and its settings.

Real hardware and simulations go through the same adapters::

    serial:///dev/ttyUSB0?protocol=stim300&baud=921600&rate=2000
    sim+serial://STIM300?protocol=kvh1750&rate=1000&warp=10&drop=0.001&seed=1

A ``sim+`` URL starts a simulated device that speaks the protocol over a real transport
(a pty here) and returns the adapter connected to it. Its host part (or ``model=``) is
the noise model; the query keys of every simulation are those of :class:`SimParams`.
"""

from __future__ import annotations

import math
import tomllib
import uuid
from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import Any, Protocol
from urllib.parse import parse_qsl, unquote, urlsplit

from devices.can_raw import CanRateSource
from devices.canopen_node import CanopenRateSource
from devices.codecs.base import StreamCodec
from devices.codecs.can_frame import PER_AXIS_LAYOUT, SHARED_LAYOUT, CanFrameLayout
from devices.codecs.kvh1750 import HEADER as KVH_HEADER
from devices.codecs.kvh1750 import Kvh1750Codec
from devices.codecs.modbus_map import GYRO_FLOAT32_MAP, GYRO_INT32_MAP, ModbusRegisterMap
from devices.codecs.stim300 import Stim300Codec
from devices.codecs.xbus import PREAMBLE, XbusCodec
from devices.errors import DeviceConfigurationError
from devices.modbus import ModbusRateSource
from devices.protocols import RateSource
from devices.sim.can_device import CanBroadcastDevice
from devices.sim.canopen_device import GYRO_EDS, CanopenGyroNode
from devices.sim.clock import WarpClock
from devices.sim.faults import FaultConfig, Ledger, SimCore
from devices.sim.modbus_server import ModbusGyroServer
from devices.sim.serial_device import PtySerialDevice
from devices.sim.signal import SignalSource
from devices.stream import StreamRateSource
from devices.transports.can import CanTransport
from devices.transports.modbus import ModbusTransport
from devices.transports.serial import SerialTransport


@dataclass(frozen=True)
class SimParams:
    """Query keys of a simulated device URL (times in simulated seconds).

    Attributes
    ----------
    model : str
        Noise model: a preset name or a TOML file.
    rate : float
        Sample rate, Hz.
    warp : float
        Time-warp factor (simulated seconds per wall second).
    drop, corrupt, garbage : float
        Per-frame probabilities of a dropped frame, a flipped bit, junk before a frame.
    disconnect_every_s, disconnect_for_s : float
        Periodic disconnects.
    stall_every_s, stall_for_s : float
        Periodic output stalls (samples lost, link kept).
    drift_ppm : float
        Device clock error, ppm.
    seed : int or None
        Seed of the signal and of the faults.
    history : int
        Samples whose rates and lost indices the simulator keeps for tests (0: counts
        only, so that an overnight run stays in bounded memory).
    """

    model: str = "STIM300"
    rate: float = 500.0
    warp: float = 1.0
    drop: float = 0.0
    corrupt: float = 0.0
    garbage: float = 0.0
    disconnect_every_s: float = math.inf
    disconnect_for_s: float = 0.0
    stall_every_s: float = math.inf
    stall_for_s: float = 0.0
    drift_ppm: float = 0.0
    seed: int | None = None
    history: int = 0

    def faults(self) -> FaultConfig:
        """The fault knobs of these parameters."""
        return FaultConfig(
            drop=self.drop, corrupt=self.corrupt, garbage=self.garbage,
            disconnect_every_s=self.disconnect_every_s, disconnect_for_s=self.disconnect_for_s,
            stall_every_s=self.stall_every_s, stall_for_s=self.stall_for_s,
            drift_ppm=self.drift_ppm, seed=None if self.seed is None else self.seed + 1)


class Simulator(Protocol):
    """A running simulated device."""

    core: SimCore

    def stop(self) -> None:
        """Stop it and release its transport."""


@dataclass
class OpenedDevice:
    """The adapter a URL names and, for ``sim+`` URLs, the simulator behind it."""

    source: RateSource
    url: str
    simulator: Simulator | None = None

    @property
    def ledger(self) -> Ledger | None:
        """The simulator's ledger (samples generated, lost), None for real hardware."""
        return None if self.simulator is None else self.simulator.core.ledger

    def close(self) -> None:
        """Close the adapter, then stop the simulator."""
        try:
            self.source.close()
        finally:
            if self.simulator is not None:
                self.simulator.stop()

    def __enter__(self) -> OpenedDevice:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _number(key: str, text: str, kind: Callable[[str], Any]) -> Any:
    try:
        return kind(text)
    except ValueError as exc:
        raise DeviceConfigurationError(f"URL key {key}={text!r} is not a number") from exc


def parse_sim_params(host_model: str, query: dict[str, str]) -> SimParams:
    """Simulation parameters from a URL's host part and query (unknown keys are left).

    Raises
    ------
    DeviceConfigurationError
        A key has a value of the wrong type or out of range.
    """
    values: dict[str, Any] = {}
    if host_model:
        values["model"] = host_model
    for f in fields(SimParams):
        if f.name in query:
            text = query[f.name]
            values[f.name] = (text if f.name == "model" else
                              _number(f.name, text, int if f.name in ("seed", "history") else float))
    try:
        params = SimParams(**values)
        params.faults()
    except ValueError as exc:
        raise DeviceConfigurationError(str(exc)) from exc
    if not (params.rate > 0 and params.warp > 0):
        raise DeviceConfigurationError("rate and warp must be > 0")
    if params.history < 0:
        raise DeviceConfigurationError("history must be >= 0")
    return params


# -- serial protocols ----------------------------------------------------------------

SERIAL_PROTOCOLS = ("stim300", "kvh1750", "xbus")


def _stream_codec(protocol: str, query: dict[str, str], rate_hz: float
                  ) -> tuple[StreamCodec[Any], bytes, str]:
    """(codec, sync header, default model name) of a serial protocol."""
    if protocol == "stim300":
        ident = _number("datagram", query.get("datagram", "0x94"), lambda t: int(t, 0))
        return Stim300Codec(ident), bytes([ident]), "STIM300"
    if protocol == "kvh1750":
        return (Kvh1750Codec(query.get("unit", "deg"), query.get("output", "rate"),  # type: ignore[arg-type]
                             rate_hz), KVH_HEADER, "DSP-1750")
    if protocol == "xbus":
        return XbusCodec(), bytes([PREAMBLE]), "MTi"
    raise DeviceConfigurationError(f"unknown serial protocol {protocol!r}; "
                                   f"known: {', '.join(SERIAL_PROTOCOLS)}")


def _open_serial(path: str, query: dict[str, str], simulate: bool, host: str) -> OpenedDevice:
    protocol = query.get("protocol", "stim300")
    if simulate:
        params = parse_sim_params(query.get("model", host), query)
        codec, header, _ = _stream_codec(protocol, query, params.rate)
        core, clock = sim_core(params, codec.n_axes)
        device = PtySerialDevice(codec, core, header=header).start()
        source = StreamRateSource(SerialTransport(device.port), codec, model=params.model,
                                  serial_number=f"SIM-{params.seed or 0}",
                                  sample_rate_hz=params.rate, clock=clock,
                                  clock_scale=params.warp,
                                  max_latency_s=device.max_latency_s)
        return OpenedDevice(source, "", device)
    rate = _number("rate", query.get("rate", "2000"), float)
    codec, _, model = _stream_codec(protocol, query, rate)
    transport = SerialTransport(path, _number("baud", query.get("baud", "921600"), int))
    source = StreamRateSource(transport, codec, model=query.get("model", model),
                              serial_number=query.get("serial", "unknown"), sample_rate_hz=rate)
    return OpenedDevice(source, "")


# -- raw CAN -------------------------------------------------------------------------

def _profile_table(name: str, key: str) -> dict[str, Any]:
    try:
        with open(name, "rb") as fh:
            return dict(tomllib.load(fh)[key])
    except (OSError, KeyError, tomllib.TOMLDecodeError) as exc:
        raise DeviceConfigurationError(f"{key} layout {name!r}: not a built-in name, and "
                                       f"no [{key}] table in such a file ({exc})") from exc


def can_layout(name: str) -> CanFrameLayout:
    """A frame layout by name (``shared``, ``per_axis``) or from a profile TOML's ``[can]``.

    Raises
    ------
    DeviceConfigurationError
        Unknown name, unreadable file, or a file without a valid ``[can]`` table.
    """
    builtin = {"shared": SHARED_LAYOUT, "per_axis": PER_AXIS_LAYOUT}
    if name in builtin:
        return builtin[name]
    try:
        return CanFrameLayout.from_table(_profile_table(name, "can"))
    except ValueError as exc:
        raise DeviceConfigurationError(f"CAN layout {name!r}: {exc}") from exc


def register_map(name: str) -> ModbusRegisterMap:
    """A register map by name (``int32``, ``float32``) or from a profile's ``[modbus]``.

    Raises
    ------
    DeviceConfigurationError
        Unknown name or bad table.
    """
    builtin = {"int32": GYRO_INT32_MAP, "float32": GYRO_FLOAT32_MAP}
    if name in builtin:
        return builtin[name]
    try:
        return ModbusRegisterMap.from_table(_profile_table(name, "modbus"))
    except ValueError as exc:
        raise DeviceConfigurationError(f"Modbus map {name!r}: {exc}") from exc


def sim_core(params: SimParams, n_axes: int) -> tuple[SimCore, WarpClock]:
    """The simulator core of a ``sim+`` URL and its time-warped clock.

    It keeps counts of what it generated and lost, and the rates and lost indices of
    the latest ``params.history`` samples only: memory is bounded whatever the run length.
    """
    clock = WarpClock(params.warp)
    signal = SignalSource(params.model, params.rate, n_axes=n_axes, seed=params.seed)
    return SimCore(signal, params.rate, clock, params.faults(), history=params.history), clock


def _open_can(path: str, query: dict[str, str], simulate: bool, host: str) -> OpenedDevice:
    layout = can_layout(query.get("layout", "shared"))
    if simulate:
        params = parse_sim_params(query.get("model", host), query)
        core, clock = sim_core(params, len(layout.axes))
        channel = f"gyro-sim-{uuid.uuid4().hex[:12]}"
        device = CanBroadcastDevice(
            CanTransport("virtual", channel, preserve_timestamps=True), layout, core).start()
        source = CanRateSource(CanTransport("virtual", channel), layout, model=params.model,
                               serial_number=f"SIM-{params.seed or 0}",
                               sample_rate_hz=params.rate, clock=clock,
                               clock_scale=params.warp)
        return OpenedDevice(source, "", device)
    kwargs: dict[str, Any] = {}
    if "bitrate" in query:
        kwargs["bitrate"] = _number("bitrate", query["bitrate"], int)
    transport = CanTransport(query.get("interface", "socketcan"), host or path.strip("/"),
                             **kwargs)
    source = CanRateSource(transport, layout, model=query.get("model", "CAN gyro"),
                           serial_number=query.get("serial", "unknown"),
                           sample_rate_hz=_number("rate", query.get("rate", "1000"), float))
    return OpenedDevice(source, "")


# -- CANopen ------------------------------------------------------------------------

def _open_canopen(path: str, query: dict[str, str], simulate: bool, host: str
                  ) -> OpenedDevice:
    node_id = _number("node", path.strip("/") or query.get("node", "5"), int)
    sync = query.get("tpdo", "event") == "sync"
    if simulate:
        params = parse_sim_params(query.get("model", host), query)
        core, clock = sim_core(params, 3)
        channel = f"gyro-sim-{uuid.uuid4().hex[:12]}"
        device = CanopenGyroNode(CanTransport("virtual", channel), core, node_id=node_id,
                                 serial_number=params.seed or 1).start()
        source = CanopenRateSource(CanTransport("virtual", channel), node_id, GYRO_EDS,
                                   sample_rate_hz=params.rate, model=params.model, clock=clock,
                                   clock_scale=params.warp, sync=sync)
        return OpenedDevice(source, "", device)
    transport = CanTransport(query.get("interface", "socketcan"), host)
    source = CanopenRateSource(transport, node_id, query.get("eds", str(GYRO_EDS)),
                               sample_rate_hz=_number("rate", query.get("rate", "100"), float),
                               model=query.get("model", "CANopen gyro"), sync=sync)
    return OpenedDevice(source, "")


# -- Modbus --------------------------------------------------------------------------

def _open_modbus_rtu(path: str, query: dict[str, str], simulate: bool, host: str
                     ) -> OpenedDevice:
    return _open_modbus(path, query, simulate, host, rtu=True)


def _open_modbus_tcp(path: str, query: dict[str, str], simulate: bool, host: str
                     ) -> OpenedDevice:
    return _open_modbus(path, query, simulate, host, rtu=False)


def _open_modbus(path: str, query: dict[str, str], simulate: bool, host: str, *, rtu: bool
                 ) -> OpenedDevice:
    regs = register_map(query.get("map", "int32"))
    oversample = _number("oversample", query.get("oversample", "2"), float)
    if simulate:
        params = parse_sim_params(query.get("model", host), query)
        core, clock = sim_core(params, len(regs.axes))
        server = ModbusGyroServer(regs, core, rtu=rtu).start()
        transport = (ModbusTransport("rtu", server.serial_port, baudrate=115200) if rtu
                     else ModbusTransport("tcp", "127.0.0.1", port=server.port))
        source = ModbusRateSource(transport, regs,
                                  device_id=server.device_id, model=params.model,
                                  serial_number=f"SIM-{params.seed or 0}",
                                  sample_rate_hz=params.rate, clock=clock,
                                  clock_scale=params.warp, oversample=oversample)
        return OpenedDevice(source, "", server)
    if rtu:  # modbus+rtu:///dev/ttyUSB0?unit=1&baud=19200
        unit = query.get("unit", "1")
        transport = ModbusTransport("rtu", path,
                                    baudrate=_number("baud", query.get("baud", "19200"), int))
    else:  # modbus+tcp://10.0.0.7:502/1
        hostname, _, port = host.partition(":")
        unit = path.strip("/") or query.get("unit", "1")
        transport = ModbusTransport("tcp", hostname, port=_number("port", port or "502", int))
    source = ModbusRateSource(transport, regs, device_id=_number("unit", unit, int),
                              model=query.get("model", "Modbus gyro"),
                              serial_number=query.get("serial", "unknown"),
                              sample_rate_hz=_number("rate", query.get("rate", "100"), float),
                              oversample=oversample)
    return OpenedDevice(source, "")


@dataclass(frozen=True)
class SupportedProtocol:
    """A protocol the station can record, its transport, and a URL of its simulation."""

    protocol: str
    transport: str
    sim_url: str
    description: str


_SIM_QUERY = "rate={rate}&warp={warp}&seed=1"

#: Every protocol and transport the station supports (``station devices`` prints them).
SUPPORTED: tuple[SupportedProtocol, ...] = (
    SupportedProtocol("stim300", "serial", "sim+serial://STIM300?protocol=stim300&datagram=0x94&"
                      + _SIM_QUERY.format(rate=500, warp=5),
                      "Safran Sensonor STIM300 binary datagram, CRC-32"),
    SupportedProtocol("kvh1750", "serial", "sim+serial://DSP-1750?protocol=kvh1750&"
                      + _SIM_QUERY.format(rate=500, warp=5),
                      "KVH DSP-1750 format A, 36 bytes, CRC-32"),
    SupportedProtocol("xbus", "serial", "sim+serial://MTI-630?protocol=xbus&"
                      + _SIM_QUERY.format(rate=400, warp=5),
                      "Xsens MTi Xbus MTData2, 8-bit checksum"),
    SupportedProtocol("can", "can", "sim+can://VG951?layout=shared&"
                      + _SIM_QUERY.format(rate=500, warp=5),
                      "raw CAN broadcast, configurable layout, CRC-8 SAE J1850 + counter"),
    SupportedProtocol("canopen", "canopen", "sim+canopen://VG951/5?"
                      + _SIM_QUERY.format(rate=100, warp=4),
                      "CANopen node (shipped EDS): SDO setup, NMT, TPDO1/2, heartbeat"),
    SupportedProtocol("modbus", "modbus+tcp", "sim+modbus+tcp://VG951?map=int32&"
                      + _SIM_QUERY.format(rate=50, warp=4),
                      "register-map gyro polled over Modbus TCP (INT32/FLOAT32)"),
    SupportedProtocol("modbus", "modbus+rtu", "sim+modbus+rtu://VG951?map=float32&"
                      + _SIM_QUERY.format(rate=20, warp=2),
                      "register-map gyro polled over Modbus RTU (a pty null modem here)"),
)


def open_device(url: str) -> OpenedDevice:
    """The adapter (and simulator) a device URL names; the adapter is not opened yet.

    Parameters
    ----------
    url : str
        ``[sim+]serial://...``, see the module docstring.

    Returns
    -------
    OpenedDevice
        Close it to release the adapter and stop any simulator.

    Raises
    ------
    DeviceConfigurationError
        Unknown scheme or protocol, or a malformed key.
    """
    parts = urlsplit(url)
    scheme = parts.scheme.lower()
    simulate = scheme.startswith("sim+")
    transport = scheme.removeprefix("sim+")
    query = dict(parse_qsl(parts.query, keep_blank_values=True))
    host = unquote(parts.netloc)
    openers: dict[str, Callable[[str, dict[str, str], bool, str], OpenedDevice]] = {
        "serial": _open_serial,
        "can": _open_can,
        "canopen": _open_canopen,
        "modbus+tcp": _open_modbus_tcp,
        "modbus+rtu": _open_modbus_rtu,
    }
    if transport not in openers:
        raise DeviceConfigurationError(
            f"unknown device URL scheme {parts.scheme!r} in {url!r}; known: "
            + ", ".join(f"{s}, sim+{s}" for s in openers))
    opened = openers[transport](unquote(parts.path), query, simulate, host)
    opened.url = url
    return opened
