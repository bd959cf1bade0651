"""Replaying a raw byte dump: what a unit sent, recorded by anything, through the adapter
of its protocol (docs/devices.md, "Raw byte dumps").

A dump (``cat /dev/ttyUSB0 > dump.bin``, a logic analyser's export, a public capture)
holds the device's bytes and nothing else: no times, no host commands. Its URL names the
protocol and its keys, as a serial URL does (``replay://dump.bin?protocol=xbus&rate=100``).
:func:`dump_steps` cuts the bytes where frames end and times each cut on the unit's own
clock: from the device's time stamps where the protocol carries them (Xbus
SampleTimeFine), from the counter steps at the nominal rate otherwise (STIM300, KVH).
:class:`DumpByteTransport` plays the cuts as a :class:`~devices.replay.ReplayByteTransport`
does a capture's reads, on that replay clock: an outage the device's time shows is a
proven silence to the adapter, exactly as on the wire, and none is invented. One step
holds one frame, so that a read returns one sample and stamps it with its own time (a read
of several would give them all the time of the last). The adapter
listens only (:class:`ListeningCodec`: a dump holds no answer to a greeting), and anything
it would write is dropped.
"""

from __future__ import annotations

import statistics
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from devices.capture import Read
from devices.codecs.base import DecodeResult, Reading, StreamCodec
from devices.errors import DeviceConfigurationError, FrameError
from devices.replay import ReplayByteTransport

#: Bytes handed to the decoder at a time while the dump is cut: below any frame's length,
#: so that a cut falls at most this many bytes after the end of its frame.
PIECE_BYTES = 8


class ListeningCodec:
    """A stream codec as it listens to a dump: the protocol's own in every respect but
    the greeting (none: a dump holds no answer to it) and the acknowledgement awaited.

    Parameters
    ----------
    codec : StreamCodec
        The protocol's codec; its other attributes (``weak_check``,
        ``rate_range_deg_s``) read through.
    """

    def __init__(self, codec: StreamCodec[Any]) -> None:
        self.codec = codec
        self.name = codec.name
        self.counter_modulus = codec.counter_modulus
        self.n_axes = codec.n_axes
        self.has_device_time = codec.has_device_time
        self.has_temperature = codec.has_temperature
        self.n_accel_axes = codec.n_accel_axes
        self.accel_range_m_s2 = codec.accel_range_m_s2

    def __getattr__(self, name: str) -> Any:
        if name == "codec":  # (not set yet: no recursion)
            raise AttributeError(name)
        return getattr(self.codec, name)

    def decode(self, data: bytes) -> DecodeResult[Any]:
        """The protocol's frames in ``data``."""
        return self.codec.decode(data)

    def encode(self, frame: Any) -> bytes:
        """The protocol's bytes of ``frame``."""
        return self.codec.encode(frame)

    def to_reading(self, frame: Any) -> Reading | None:
        """The protocol's reading of ``frame``."""
        return self.codec.to_reading(frame)

    def from_reading(self, reading: Reading) -> Any:
        """The protocol's frame of ``reading``."""
        return self.codec.from_reading(reading)

    def greeting(self) -> bytes:
        """Nothing: the dump's device streamed already and answers nothing."""
        return b""

    def acknowledges(self, frame: Any) -> bool:
        """No acknowledgement is awaited."""
        return False

    def answer(self, frame: Any) -> None:
        """A dump answers nothing."""
        return None


class DumpByteTransport(ReplayByteTransport):
    """A :class:`~devices.replay.ReplayByteTransport` of a dump's cuts (Read steps only):
    ``write()`` drops what the adapter writes (the dump's device heard nothing)."""

    def write(self, data: bytes) -> None:
        """Drop ``data`` (raises DeviceDisconnectedError while not open)."""
        self._check_open("write()")


@dataclass(frozen=True)
class DumpTiming:
    """How a dump is cut and timed.

    Attributes
    ----------
    steps : tuple of Read
        The dump's bytes, cut after frames, each due at its last reading's time (s on the
        unit's clock since the first reading).
    rate_hz : float
        The nominal rate: the URL's, else the device's time stamps' (Hz).
    readings : int
        Readings the protocol's decoder finds in the dump.
    time_source : str
        ``"device time"`` or ``"counter at the nominal rate"``: what the times come from.
    """

    steps: tuple[Read, ...]
    rate_hz: float
    readings: int
    time_source: str


def _cut(data: bytes, codec: StreamCodec[Any]) -> list[tuple[int, list[Reading]]]:
    """(end offset, readings completed) of each piece of ``data`` that completes one."""
    out: list[tuple[int, list[Reading]]] = []
    rest = b""
    for start in range(0, len(data), PIECE_BYTES):
        end = min(start + PIECE_BYTES, len(data))
        result = codec.decode(rest + data[start:end])
        rest = result.rest
        readings = []
        for frame in result.frames:
            try:
                reading = codec.to_reading(frame)
            except FrameError:
                continue  # the adapter logs it (a resync); it times nothing
            if reading is not None:
                readings.append(reading)
        if readings:
            out.append((end, readings))
    return out


def _step(counter: int, last: int, modulus: int) -> int:
    return (counter - last) % modulus or modulus


def device_time_rate(readings: Iterable[Reading], modulus: int) -> float | None:
    """The rate (Hz) the device's time stamps show: the median of device-time step per
    counter step over consecutive readings (None: fewer than two time stamps)."""
    periods = []
    last: Reading | None = None
    for reading in readings:
        if last is not None and reading.device_time_s is not None and \
                last.device_time_s is not None:
            dt = reading.device_time_s - last.device_time_s
            if dt > 0:
                periods.append(dt / _step(reading.counter, last.counter, modulus))
        last = reading
    if not periods:
        return None
    return 1.0 / statistics.median(periods)


def dump_steps(data: bytes, codec: StreamCodec[Any], rate_hz: float | None, *,
               source: str = "the dump") -> DumpTiming:
    """Cut ``data`` after its frames and time the cuts (module docstring).

    A reading's time is the previous one's plus the device-time step where both carry a
    device time and it goes forward, else plus its counter steps at ``rate_hz``.

    Parameters
    ----------
    data : bytes
        The dump.
    codec : StreamCodec
        Its protocol.
    rate_hz : float or None
        Nominal rate, Hz; None takes the device's time stamps' (a protocol with device
        time only).
    source : str
        The dump's name, for messages.

    Raises
    ------
    DeviceConfigurationError
        No rate given and the protocol carries no device time (or the dump's readings
        none); a rate that is not > 0; no sample of the protocol in the dump.
    """
    cuts = _cut(data, codec)
    readings = [r for _, rs in cuts for r in rs]
    if not readings:
        raise DeviceConfigurationError(
            f"{source}: no {codec.name} sample decodes in its {len(data)} bytes: check the "
            f"URL's protocol= and its keys")
    modulus = codec.counter_modulus
    # counter units a sample (a STIM300's counter counts its 2000 Hz internal samples)
    counter_step: int = getattr(codec, "counter_step", 1)
    if rate_hz is None:
        rate_hz = device_time_rate(readings, modulus) if codec.has_device_time else None
        if rate_hz is None:
            why = ("carries no device time" if not codec.has_device_time
                   else "sends no two device time stamps in it")
            raise DeviceConfigurationError(
                f"{source}: protocol {codec.name} {why}: give the unit's nominal output rate "
                f"(URL key rate=HZ)")
        rate_hz = round(rate_hz, 6)
    if not rate_hz > 0:
        raise DeviceConfigurationError(f"{source}: rate={rate_hz:g} must be > 0 Hz")
    steps: list[Read] = []
    t, start, by_device = 0.0, 0, 0
    last: Reading | None = None
    for end, batch in cuts:
        for reading in batch:
            if last is not None:
                dt = (None if reading.device_time_s is None or last.device_time_s is None
                      else reading.device_time_s - last.device_time_s)
                if dt is not None and dt > 0:
                    t += dt
                    by_device += 1
                else:
                    samples = round(_step(reading.counter, last.counter, modulus) / counter_step)
                    t += samples / rate_hz
            last = reading
        steps.append(Read(data[start:end], t))
        start = end
    if start < len(data):  # bytes after the last reading: the adapter counts them too
        steps.append(Read(data[start:], t))
    source_of_time = ("device time" if readings and by_device >= (len(readings) - 1) / 2
                      else "counter at the nominal rate")
    return DumpTiming(tuple(steps), float(rate_hz), len(readings), source_of_time)


def load_dump(path: str | Path) -> bytes:
    """The bytes of a dump file.

    Raises
    ------
    DeviceConfigurationError
        No such file, or it does not read (one line, naming it).
    """
    try:
        return Path(path).read_bytes()
    except OSError as exc:
        raise DeviceConfigurationError(f"cannot read the byte dump {path}: "
                                       f"{exc.strerror or exc}") from exc
