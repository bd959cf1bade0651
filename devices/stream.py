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
from devices.gaps import CounterTracker, counter_samples
from devices.protocols import ACCEL_AXIS_NAMES, DeviceDescription, SampleBatch
from devices.rateless import RatelessMessages
from devices.resolution import UNKNOWN_RESOLUTION, codec_resolution
from devices.stream_timing import StreamTiming
from devices.transports.serial import LINE_DISCIPLINE_BYTES, ByteTransport


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
        The unit's time base, s: ``time.monotonic`` for hardware, the simulation's
        time-warped clock for a simulated unit (elapsed times are then device seconds).
    clock_scale : float
        Clock seconds per wall second (a simulation's time warp; 1 for hardware): turns
        a read's wall-clock timeout into clock time.
    silence_timeout_s : float
        Raise :class:`DeviceTimeoutError` when no valid frame arrived for this long
        (clock s: wall s for hardware, simulated s for a simulation).
    ack_timeout_s : float
        How long :meth:`open` waits for the codec's acknowledgement, s (wall time).
    max_latency_s : float
        Longest the device holds a sample before sending it, clock s (a USB adapter's
        latency timer; a simulator's loop period and lateness allowance).

    Notes
    -----
    How a gap's wrap count is decided (docs/devices.md, "Samples, counters, gaps"): the
    counter residue is exact; whole wraps can only hide in a *proven silence* (an empty
    read, a reopen), never in the time a host that fell behind took to read
    (:class:`~devices.stream_timing.StreamTiming`); the wrap count is the one nearest
    the elapsed time, a tie going to fewer wraps (:meth:`CounterTracker.update`).
    """

    #: Longest a loaded host may hold back bytes that are already on the wire (wall s:
    #: kernel work queues, thread switches); silences are trusted only beyond it.
    host_jitter_s = 0.025

    def __init__(self, transport: ByteTransport, codec: StreamCodec[Any], *, model: str,
                 serial_number: str, sample_rate_hz: float, transport_name: str = "serial",
                 clock: Callable[[], float] = time.monotonic, clock_scale: float = 1.0,
                 silence_timeout_s: float = 5.0, ack_timeout_s: float = 2.0,
                 max_latency_s: float = 0.05) -> None:
        if not clock_scale > 0:
            raise ValueError(f"clock_scale must be > 0, got {clock_scale}")
        self.transport = transport
        self.codec = codec
        self.clock = clock
        self.clock_scale = clock_scale
        self.silence_timeout_s = silence_timeout_s
        self.ack_timeout_s = ack_timeout_s
        # The counter may advance by a step per sample (a STIM300 counts its 2000 Hz
        # internal samples): the tracker counts in samples, and so does the description.
        self._counter_step: int = getattr(codec, "counter_step", 1)
        tracker = CounterTracker(codec.counter_modulus, sample_rate_hz,
                                 counter_step=self._counter_step)
        word = codec_resolution(codec.name) or UNKNOWN_RESOLUTION
        self._description = DeviceDescription(
            model=model, serial_number=serial_number, protocol=codec.name,
            transport=transport_name, axes=("x", "y", "z")[:codec.n_axes],
            sample_rate_hz=sample_rate_hz, has_counter=True,
            counter_modulus=tracker.modulus, has_device_time=codec.has_device_time,
            has_temperature=codec.has_temperature, settings=transport.settings,
            accel_axes=ACCEL_AXIS_NAMES[:codec.n_accel_axes],
            lsb_deg_s=word.lsb_deg_s, lsb_relative=word.lsb_relative,
        )
        self._builder = BatchBuilder(
            codec.n_axes, tracker,
            has_device_time=codec.has_device_time, has_temperature=codec.has_temperature,
            check_continuity=getattr(codec, "weak_check", False),
            rate_limit_deg_s=getattr(codec, "rate_range_deg_s", None),
            n_accel_axes=codec.n_accel_axes, accel_limit_m_s2=codec.accel_range_m_s2)
        # Counter steps of messages that carry no sample (an MTi-G's GNSS messages).
        self._rateless = RatelessMessages(codec, codec.counter_modulus, sample_rate_hz)
        self._rest = b""
        self._connected = False
        self._ever_connected = False
        self._last_frame_s = 0.0
        self._last_raw: int | None = None
        self._timing = StreamTiming(sample_rate_hz, max_latency_s,
                                    self.host_jitter_s * clock_scale)

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
        wall_start, clock_start = time.monotonic(), self.clock()
        try:
            self.transport.open()
        except DeviceDisconnectedError:
            # No port now: whatever arrives later was sent after this moment.
            self._timing.quiet_until(self._attempt_time(wall_start, clock_start))
            raise
        # Opening flushes the input buffer: what we read was sent after this moment.
        self._timing.quiet_until(self._attempt_time(wall_start, clock_start))
        self._rest = b""
        greeting = self.codec.greeting()
        if greeting:
            self.transport.write(greeting)
            self._await_ack()
        now = self.clock()
        self._builder.event("reconnect" if self._ever_connected else "connect", now)
        self._connected = self._ever_connected = True
        self._last_frame_s = now

    def _attempt_time(self, wall_start: float, clock_start: float) -> float:
        """When an open attempt found the port missing or flushed it, on the unit's clock.

        A quick call (under ``host_jitter_s`` of wall time) did so at its end to within
        that: its end is taken, which is also when a replayed capture's clock shows the
        recorded attempt. A slow call (a preempted thread, a slow USB enumeration) may
        have done so anywhere in it: its start is taken, so that no silence is claimed
        that bytes could have broken (an ambiguous count goes to fewer wraps).
        """
        clock_end = self.clock()
        quick = time.monotonic() - wall_start <= self.host_jitter_s
        return clock_end if quick else clock_start

    def _await_ack(self) -> None:
        deadline = time.monotonic() + self.ack_timeout_s
        kept: list[bytes] = []
        while time.monotonic() < deadline:
            result = self.codec.decode(self._rest + self.transport.read(0.05))
            self._rest = result.rest
            self._log_damage(result.crc_failures, result.discarded_bytes, self.clock())
            for i, frame in enumerate(result.frames):
                if self.codec.acknowledges(frame):
                    # Every other frame, before the acknowledgement or after it, is kept
                    # for read(): data frames are samples the device sent.
                    rest = result.frames[:i] + result.frames[i + 1:]
                    kept += [self.codec.encode(f) for f in rest]
                    self._rest = b"".join(kept) + self._rest
                    return
            kept += [self.codec.encode(f) for f in result.frames]
        self.transport.close()
        raise DeviceProtocolError(f"{self.codec.name}: no acknowledgement within "
                                  f"{self.ack_timeout_s} s")

    def _log_damage(self, crc_failures: int, discarded_bytes: int, now: float) -> None:
        if crc_failures:
            self._builder.event("crc_error", now, crc_failures)
        if discarded_bytes:
            self._builder.event("resync", now, discarded_bytes, "bytes skipped")

    def close(self) -> None:
        self.transport.close()
        self._connected = False

    def read(self, timeout_s: float = 0.1) -> SampleBatch:
        """Samples decoded since the last call (see :meth:`RateSource.read`)."""
        if not self._connected:
            self.open()
        # Wait in slices of 1/16 counter period: each empty slice proves the silence so
        # far, so a silence's end is known to within half a slice.
        wrap_s = self._builder.tracker.modulus / self._description.sample_rate_hz
        slice_s = min(timeout_s, max(0.002, wrap_s / 16.0 / self.clock_scale))
        deadline = time.monotonic() + timeout_s
        while True:
            started = self.clock()
            try:
                data = self.transport.read(slice_s)
            except DeviceDisconnectedError:
                self.transport.close()
                self._connected = False
                self._builder.event("disconnect", self.clock())
                raise
            now = self.clock()
            # The transport returns nothing only after waiting its whole timeout (wall
            # s), and returns bytes no later than the end of that wait.
            window_s = slice_s * self.clock_scale
            wait_end = min(now, started + window_s)
            self._timing.read_done(started, wait_end, window_s / 2.0, bool(data),
                                   drained=len(data) < LINE_DISCIPLINE_BYTES)
            if data or time.monotonic() >= deadline:
                break
        result = self.codec.decode(self._rest + data)
        self._rest = result.rest
        self._log_damage(result.crc_failures, result.discarded_bytes, now)
        readings = []
        for frame in result.frames:
            try:
                reading = self.codec.to_reading(frame)
            except FrameError as exc:
                self._builder.event("resync", now, 1, str(exc))
                continue
            if reading is not None:
                readings.append(self._rateless.sample(reading))
            else:
                # A message the device counted that holds no sample (an MTi-G's GNSS
                # PVT message): its counter step is no lost sample (devices/rateless.py).
                self._rateless.skip(frame)
        # Whole counter wraps can hide only in a proven silence (StreamTiming); while
        # bytes keep coming the counter counts alone. The send-time bounds say whether
        # the count is certain.
        steps = []
        for reading in readings:
            last, self._last_raw = self._last_raw, reading.counter
            steps.append(1 if last is None else counter_samples(
                last, reading.counter, self.codec.counter_modulus, self._counter_step))
        bounds = self._timing.send_bounds(steps, now)
        period = 1.0 / self._description.sample_rate_hz
        for i, reading in enumerate(readings):
            latest = wait_end - (len(readings) - 1 - i) * period
            # Less a quarter of a counter period, and at least the host's own delivery
            # jitter: bytes a loaded host delivered late (its kernel or a thread switch
            # held them back, not the device) must not make a wrap.
            elapsed = max(0.0, self._timing.elapsed_before(latest) - max(
                wrap_s / 4.0, self.host_jitter_s * self.clock_scale))
            self._builder.add(reading, now, elapsed_s=elapsed, elapsed_range_s=bounds[i])
            self._timing.sent(steps[i], latest)
        if readings:
            self._last_frame_s = now
        if now - self._last_frame_s > self.silence_timeout_s:
            self._last_frame_s = now
            self._rateless.refuse_if_rateless()
            raise DeviceTimeoutError(f"{self.codec.name}: no valid frame for "
                                     f"{self.silence_timeout_s} s")
        return self._builder.take(now)

    def quiet_until_now(self) -> None:
        """Nothing was sent before now (the station held the device): what comes next
        was sent after it."""
        self._timing.quiet_until(self.clock())

    def limit_rates(self, limit_deg_s: float | None) -> None:
        """Samples beyond this magnitude (deg/s, any axis) are bad samples (the
        measurement range, from the product profile; None keeps the protocol's own)."""
        self._builder.rate_limit_deg_s = (limit_deg_s if limit_deg_s is not None
                                          else getattr(self.codec, "rate_range_deg_s", None))

    def limit_accel(self, limit_m_s2: float | None) -> None:
        """Samples whose acceleration exceeds this magnitude (m/s^2, any axis) are bad
        samples (the accelerometer range, from the product profile; None keeps the
        codec's own)."""
        self._builder.accel_limit_m_s2 = (limit_m_s2 if limit_m_s2 is not None
                                          else self.codec.accel_range_m_s2)
