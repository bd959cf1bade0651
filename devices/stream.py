"""Adapter for byte-stream gyros (STIM300, KVH DSP-1750, Xsens Xbus): transport + codec."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from devices.batching import BatchBuilder
from devices.codecs.base import StreamCodec
from devices.errors import (
    DeviceDisconnectedError,
    DeviceProtocolError,
    DeviceTimeoutError,
    FrameError,
)
from devices.gaps import CounterTracker
from devices.protocols import DeviceDescription, SampleBatch
from devices.transports.serial import ByteTransport


class StreamRateSource:
    """A rate source built from an injected byte transport and a pure stream codec.

    Parameters
    ----------
    transport : ByteTransport
        Opened by :meth:`open`, reopened after a disconnect by the next :meth:`read`.
    codec : StreamCodec
        The protocol; the adapter never touches bytes otherwise.
    model, serial_number : str
        For :meth:`describe`.
    sample_rate_hz : float
        Nominal output rate, Hz.
    transport_name : str
        Transport key for :meth:`describe` (``"serial"``).
    clock : callable
        Station clock returning seconds (``time.monotonic``; a time-warped clock for
        simulations so that elapsed times are in device seconds).
    silence_timeout_s : float
        Raise :class:`DeviceTimeoutError` when no valid frame arrived for this long
        (wall s).
    ack_timeout_s : float
        How long :meth:`open` waits for the codec's acknowledgement, s (wall time).
    """

    def __init__(self, transport: ByteTransport, codec: StreamCodec[Any], *, model: str,
                 serial_number: str, sample_rate_hz: float, transport_name: str = "serial",
                 clock: Callable[[], float] = time.monotonic, silence_timeout_s: float = 5.0,
                 ack_timeout_s: float = 2.0) -> None:
        self.transport = transport
        self.codec = codec
        self.clock = clock
        self.silence_timeout_s = silence_timeout_s
        self.ack_timeout_s = ack_timeout_s
        self._description = DeviceDescription(
            model=model, serial_number=serial_number, protocol=codec.name,
            transport=transport_name, axes=("x", "y", "z")[:codec.n_axes],
            sample_rate_hz=sample_rate_hz, has_counter=True,
            counter_modulus=codec.counter_modulus, has_device_time=codec.has_device_time,
            has_temperature=codec.has_temperature, settings=transport.settings,
        )
        self._builder = BatchBuilder(
            codec.n_axes, CounterTracker(codec.counter_modulus, sample_rate_hz),
            has_device_time=codec.has_device_time, has_temperature=codec.has_temperature)
        self._rest = b""
        self._connected = False
        self._ever_connected = False
        self._last_frame_wall = 0.0
        self._flowing = False
        self._last_sent_s = 0.0

    def describe(self) -> DeviceDescription:
        return self._description

    def open(self) -> None:
        """Open the transport and send the codec's greeting; wait for its acknowledgement.

        Raises
        ------
        DeviceDisconnectedError
            The port is not there.
        DeviceProtocolError
            The device did not acknowledge the greeting in time.
        """
        self.transport.open()
        self._rest = b""
        greeting = self.codec.greeting()
        if greeting:
            self.transport.write(greeting)
            self._await_ack()
        self._builder.event("reconnect" if self._ever_connected else "connect", self.clock())
        self._connected = self._ever_connected = True
        self._last_frame_wall = time.monotonic()
        self._flowing = False

    def _await_ack(self) -> None:
        deadline = time.monotonic() + self.ack_timeout_s
        while time.monotonic() < deadline:
            result = self.codec.decode(self._rest + self.transport.read(0.05))
            self._rest = result.rest
            for i, frame in enumerate(result.frames):
                if self.codec.acknowledges(frame):
                    # Frames after the acknowledgement are data: keep them for read().
                    tail = b"".join(self.codec.encode(f) for f in result.frames[i + 1:])
                    self._rest = tail + self._rest
                    return
        self.transport.close()
        raise DeviceProtocolError(f"{self.codec.name}: no acknowledgement within "
                                  f"{self.ack_timeout_s} s")

    def close(self) -> None:
        self.transport.close()
        self._connected = False

    def read(self, timeout_s: float = 0.1) -> SampleBatch:
        """Samples decoded since the last call (see :meth:`RateSource.read`)."""
        if not self._connected:
            self.open()
        try:
            data = self.transport.read(timeout_s)
        except DeviceDisconnectedError:
            self.transport.close()
            self._connected = False
            self._builder.event("disconnect", self.clock())
            raise
        now = self.clock()
        result = self.codec.decode(self._rest + data)
        self._rest = result.rest
        if result.crc_failures:
            self._builder.event("crc_error", now, result.crc_failures)
        if result.discarded_bytes:
            self._builder.event("resync", now, result.discarded_bytes, "bytes skipped")
        readings = []
        for frame in result.frames:
            try:
                reading = self.codec.to_reading(frame)
            except FrameError as exc:
                self._builder.event("resync", now, 1, str(exc))
                continue
            if reading is not None:
                readings.append(reading)
        # Send times for the gap arithmetic (CounterTracker). After a silence (an empty
        # read, a reopen) the device resumed just now: frames read together left it one
        # period apart, the last one now. While data keeps flowing, the host may be
        # behind (a backlog in the port buffer), so the frames continue the previous
        # ones: only the counter counts losses there, not the time the host took.
        period = 1.0 / self._description.sample_rate_hz
        for i, reading in enumerate(readings):
            if self._flowing:
                self._last_sent_s += period
            else:
                self._last_sent_s = now - (len(readings) - 1 - i) * period
            self._builder.add(reading, now, self._last_sent_s)
        self._flowing = bool(readings)
        wall = time.monotonic()
        if readings:
            self._last_frame_wall = wall
        if wall - self._last_frame_wall > self.silence_timeout_s:
            self._last_frame_wall = wall
            raise DeviceTimeoutError(f"{self.codec.name}: no valid frame for "
                                     f"{self.silence_timeout_s} s")
        return self._builder.take()
