"""Adapter for gyros (and IMUs) that broadcast rates (and accelerations) in periodic raw
CAN frames."""

from __future__ import annotations

import time
from collections.abc import Callable

from devices.batching import BatchBuilder, BusClock
from devices.codecs.can_frame import CanFrameLayout, CanFrameValues
from devices.errors import CodecError, CrcError, DeviceDisconnectedError
from devices.gaps import CounterTracker
from devices.protocols import ACCEL_AXIS_NAMES, DeviceDescription, SampleBatch
from devices.resolution import scale_resolution
from devices.transports.can import CanLink


class CanRateSource:
    """A rate source from an injected CAN transport and a frame layout.

    Frames of one sample (one per arbitration ID of the layout) are matched by their
    rolling counter and their time stamps (within half a counter period of each other,
    so that frames a whole number of wraps apart never make one sample: 7.5 samples with
    Profile 1's counter 0..14, half a sample with no counter); a sample with a frame
    missing is dropped and shows as a gap. A layout without a counter counts lost
    samples from the frames' time stamps alone (elapsed time x nominal rate: a gap is
    uncertain where the timing allows more than one count, ``missing_low`` <
    ``missing_high``).
    A node silent for ``silence_timeout_s`` (on the unit's clock: wall s for hardware,
    simulated s for a simulation) is reported lost (DeviceDisconnectedError) and
    "reconnect" is logged when its frames come back. A silence this thread did not see
    as it happened (a loaded host read the frames before and after it in one go) shows
    in the frames' time stamps: "disconnect" and "reconnect" are logged all the same.

    Parameters
    ----------
    transport : CanLink
        The bus.
    layout : CanFrameLayout
        Where the values sit in the frames.
    model, serial_number : str
        For :meth:`describe`.
    sample_rate_hz : float
        Nominal rate, Hz.
    clock : callable
        The unit's time base, s (``time.monotonic``; a simulation's warped clock).
    silence_timeout_s : float
        Node-loss limit, clock s.
    clock_scale : float
        Clock seconds per wall second (the time-warp factor of a simulation), to turn
        the bus's wall-clock frame time stamps into the clock's time base.
    max_latency_s : float
        How far a frame's time stamp may be from when the node sampled it, clock s (its
        send queue and the bus; a simulated node's lateness allowance): bounds the wrap
        count of a gap (``missing_low``, ``missing_high``).

    Notes
    -----
    A frame whose E2E check fails (CRC, a counter value outside its range) is a
    "crc_error" event. CRC-8 lets about one corrupted frame in 256 through: a counter
    that breaks the sequence is held until the next frame shows whether it was a gap or
    a corrupted counter (:class:`~devices.batching.BatchBuilder`).
    """

    def __init__(self, transport: CanLink, layout: CanFrameLayout, *, model: str,
                 serial_number: str, sample_rate_hz: float,
                 clock: Callable[[], float] = time.monotonic,
                 silence_timeout_s: float = 0.5, clock_scale: float = 1.0,
                 max_latency_s: float = 0.01) -> None:
        self.transport = transport
        self.layout = layout
        self.clock = clock
        self.silence_timeout_s = silence_timeout_s
        self.clock_scale = clock_scale
        has_temp = layout.temperature is not None
        word = scale_resolution(s.scale for s in layout.axes)
        self._description = DeviceDescription(
            model=model, serial_number=serial_number, protocol="can", transport="can",
            axes=("x", "y", "z")[:len(layout.axes)], sample_rate_hz=sample_rate_hz,
            has_counter=layout.has_counter, counter_modulus=layout.counter_modulus,
            has_device_time=False, has_temperature=has_temp, settings=transport.settings,
            accel_axes=ACCEL_AXIS_NAMES[:layout.n_accel_axes],
            lsb_deg_s=word.lsb_deg_s, lsb_relative=word.lsb_relative)
        # Without a counter (modulus 1) the time stamps alone count: the node is taken to
        # keep its schedule to a quarter of a sample period (as a 4-bit counter's count
        # needs it to a quarter of the counter's period).
        uncertainty_s = (max_latency_s if layout.has_counter
                         else min(max_latency_s, 0.25 / sample_rate_hz))
        self._builder = BatchBuilder(
            len(layout.axes), CounterTracker(layout.counter_modulus, sample_rate_hz,
                                             timing_uncertainty_s=uncertainty_s),
            has_device_time=False, has_temperature=has_temp,
            # (a 4-bit counter goes round too often for its order to say anything)
            check_continuity=layout.counter_modulus >= 64,
            n_accel_axes=layout.n_accel_axes, accel_limit_m_s2=layout.accel_range_m_s2)
        self._ids = set(layout.arbitration_ids)
        #: Incomplete samples by counter: the time stamp of their first frame (clock s)
        #: and their frames by arbitration ID.
        self._pending: dict[int, tuple[float, dict[int, CanFrameValues]]] = {}
        #: The farthest apart (clock s) two frames of one sample may be stamped: half a
        #: counter period, so that frames a wrap apart never join.
        self._join_s = layout.counter_modulus / sample_rate_hz / 2.0
        self._lost = False
        self._open = False
        self._last_frame_s = 0.0
        #: Time stamp of the node's latest valid frame (clock s; None: none since open).
        self._last_sent_s: float | None = None
        self._bus_clock = BusClock(clock, clock_scale)
        #: Frames stamped before this (clock s) are not read (see :meth:`quiet_until_now`).
        self._not_before_s = -float("inf")

    def describe(self) -> DeviceDescription:
        return self._description

    def open(self) -> None:
        self.transport.open()
        self._open = True
        self._bus_clock.sync()
        self._last_frame_s = self.clock()
        self._last_sent_s = None
        self._builder.event("connect", self._last_frame_s)

    def close(self) -> None:
        self.transport.close()
        self._open = False

    def _take(self, arbitration_id: int, data: bytes, now: float, sent: float) -> None:
        try:
            values = self.layout.decode(arbitration_id, data)
        except CrcError:
            self._builder.event("crc_error", now)
            return
        except CodecError:
            return  # another node's frame
        if self._lost:
            self._lost = False
            self._builder.event("reconnect", now)
        elif self._last_sent_s is not None and \
                sent - self._last_sent_s > self.silence_timeout_s:
            # Silent on the bus for longer than the limit, though not seen as it happened.
            self._builder.event("disconnect", self._last_sent_s + self.silence_timeout_s,
                                detail="node silent (frame time stamps)")
            self._builder.event("reconnect", now)
        self._last_frame_s = now
        self._last_sent_s = sent
        pending = self._pending.get(values.counter)
        if pending is not None and abs(sent - pending[0]) > self._join_s:
            # The counter came round again (an outage of whole wraps, a dropped frame on
            # each side of it): that older sample can no longer complete, and its frames
            # must not complete this one with another sample's values.
            del self._pending[values.counter]
            pending = None
        if pending is None:
            pending = self._pending[values.counter] = (sent, {})
        frames = pending[1]
        frames[arbitration_id] = values
        if set(frames) == self._ids:
            # Older incomplete samples can no longer complete: their loss shows as a gap.
            for counter in list(self._pending):
                del self._pending[counter]
                if counter == values.counter:
                    break
            self._builder.add(self.layout.to_reading(frames), now, sent)

    def read(self, timeout_s: float = 0.1, max_frames: int = 20_000) -> SampleBatch:
        """Samples received since the last call (see :meth:`RateSource.read`)."""
        if not self._open:
            self.open()
        msg = self.transport.recv(timeout_s)
        for _ in range(max_frames):
            if msg is None:
                break
            if not (msg.is_error_frame or msg.is_remote_frame):
                # The bus stamps each frame (wall clock, s) when it is sent or received:
                # that stamp, not when this thread got to it, times the gap arithmetic.
                sent = self._bus_clock(msg.timestamp)
                if sent >= self._not_before_s:
                    self._take(msg.arbitration_id, bytes(msg.data), self.clock(), sent)
            msg = self.transport.recv(0.0)
        now = self.clock()
        silent_s = now - self._last_frame_s
        if not self._lost and silent_s > self.silence_timeout_s:
            self._lost = True
            self._builder.event("disconnect", now, detail="node silent")
            raise DeviceDisconnectedError(f"CAN node silent for {self.silence_timeout_s} s")
        return self._builder.take(now)

    def quiet_until_now(self) -> None:
        """The station held a simulated node until now (the run starts): frames stamped
        before now are not read. The recorder's nodes start held
        (:func:`devices.urls.open_device` with ``held``), so none was sent before: their
        counter starts at 0 with the run. A guard all the same: a frame sent before a
        hold, read with those after it, would count the hold as counter wraps.

        Less half a sample period: the first sample falls due at the release, just
        after now, and the node and this adapter pair the bus's wall clock with the
        unit's clock each on its own (:class:`~devices.batching.BusClock`): its frames
        came stamped up to 6 us before now (2 runs in 8 of ``station record --unit
        "sim+can://STIM300?rate=100&layout=shared" --duration 5s``), which lost the
        run's first sample."""
        self._not_before_s = self.clock() - 0.5 / self._description.sample_rate_hz
        self._last_sent_s = None  # (the hold is no silence of the node)

    def limit_rates(self, limit_deg_s: float | None) -> None:
        """Samples beyond this magnitude (deg/s, any axis) are bad samples."""
        self._builder.rate_limit_deg_s = limit_deg_s

    def limit_accel(self, limit_m_s2: float | None) -> None:
        """Samples whose acceleration exceeds this magnitude (m/s^2, any axis) are bad
        samples (None: the layout's own range)."""
        self._builder.accel_limit_m_s2 = (limit_m_s2 if limit_m_s2 is not None
                                          else self.layout.accel_range_m_s2)
