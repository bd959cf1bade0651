"""``replay://`` device URLs: a capture the station recorded (``capture=FILE``), or a raw
byte dump of what a unit sent (``protocol=``), played back through the protocol's adapter."""

from __future__ import annotations

from pathlib import Path
from urllib.parse import parse_qsl, urlsplit

from devices.bus_layouts import can_layout
from devices.can_raw import CanRateSource
from devices.dump_replay import DumpByteTransport, ListeningCodec, dump_steps, load_dump
from devices.errors import DeviceConfigurationError
from devices.opened import OpenedDevice
from devices.protocols import RateSource
from devices.replay import (
    CaptureFormatError,
    ReplayByteTransport,
    ReplayCanTransport,
    load_capture,
    replay_transport,
)
from devices.serial_codecs import stream_codec
from devices.sim.params import query_number
from devices.stream import StreamRateSource
from devices.url_query import accel_switch


def _open_dump(file: str, query: dict[str, str]) -> OpenedDevice:
    """``replay://FILE?protocol=P``: a raw byte dump of what a unit sent, through the
    adapter of the URL's protocol, on the device's own time or the nominal rate
    (:mod:`devices.dump_replay`)."""
    protocol = query["protocol"]
    rate = query_number("rate", query["rate"], float) if "rate" in query else None
    try:  # (a codec that needs the rate refuses None; dump_steps a dump it cannot time)
        codec, _, model = stream_codec(protocol, query, rate)
    except DeviceConfigurationError as exc:
        raise DeviceConfigurationError(f"{file}: {exc}") from exc
    timing = dump_steps(load_dump(file), codec, rate, source=file)
    settings = (("protocol", protocol), ("rate", f"{timing.rate_hz:g}"),
                ("time", timing.time_source))
    transport = DumpByteTransport(timing.steps, settings=settings, source=file,
                                  realtime=query.get("realtime", "0") == "1")
    source = StreamRateSource(transport, ListeningCodec(codec), model=query.get("model", model),
                              serial_number=query.get("serial", f"replay of {file}"),
                              sample_rate_hz=timing.rate_hz, clock=transport.clock)
    return OpenedDevice(source, clock=transport.clock, replayed=True,
                        time_base=f"the replayed dump's clock (s since its first sample, "
                                  f"from the {timing.time_source})")


def open_replay(path: str, query: dict[str, str], host: str) -> OpenedDevice:
    """``replay://FILE``: a capture recorded with ``capture=FILE``, played back through
    the adapter of the protocol it was recorded with, on the recorded time base; with
    ``protocol=``, a raw byte dump (:func:`_open_dump`)."""
    file = host + path
    if "protocol" in query:
        return _open_dump(file, query)
    if not Path(file).is_file():
        raise DeviceConfigurationError(f"replay://{file}: no such file")
    try:
        capture = load_capture(file)
    except CaptureFormatError as exc:
        raise DeviceConfigurationError(
            f"{exc} (a raw byte dump of what a unit sent takes the URL keys protocol= "
            f"and rate=: replay://{file}?protocol=xbus&rate=100)") from exc
    recorded = dict(capture.settings).get("replay_url")
    if recorded is None:
        raise DeviceConfigurationError(
            f"{file}: the capture does not say how it was recorded (no replay_url in its "
            f"header): record it with a device URL's capture=FILE key, or replay it in "
            f"code with devices.replay.replay_transport")
    parts = urlsplit(recorded)
    keys = dict(parse_qsl(parts.query))
    rate = query_number("rate", keys.get("rate", "0"), float)
    warp = query_number("warp", keys.get("warp", "1"), float)
    transport = replay_transport(capture, realtime=query.get("realtime", "0") == "1")
    unit_clock = transport.clock if warp == 1.0 else (lambda: warp * transport.clock())
    name = f"replay of {file}"
    source: RateSource
    if isinstance(transport, ReplayByteTransport) and parts.scheme == "serial":
        codec, _, model = stream_codec(keys.get("protocol", "stim300"), keys, rate)
        source = StreamRateSource(transport, codec, model=keys.get("model", model),
                                  serial_number=name, sample_rate_hz=rate, clock=unit_clock,
                                  clock_scale=warp)
    elif isinstance(transport, ReplayCanTransport) and parts.scheme == "can":
        source = CanRateSource(transport, can_layout(keys.get("layout", "shared"),
                                                     accel_switch(keys)),
                               model=keys.get("model", "CAN gyro"), serial_number=name,
                               sample_rate_hz=rate, clock=unit_clock, clock_scale=warp)
    else:
        raise DeviceConfigurationError(
            f"{file}: a {capture.kind} capture whose header says it was recorded over "
            f"{parts.scheme!r}: serial and raw CAN captures replay, as they were recorded")
    return OpenedDevice(source, clock=unit_clock, replayed=True,
                        time_base="the replayed capture's clock (s since it started)")
