"""Collecting decoded readings into a :class:`~devices.protocols.SampleBatch`.

Every adapter, whatever its transport, feeds readings here; the gap accounting and the
batch layout are therefore the same for all protocols.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from devices.codecs.base import Reading
from devices.gaps import CounterTracker
from devices.protocols import NO_DEVICE_STATUS, DeviceEvent, EventKind, Gap, SampleBatch


class BusClock:
    """Maps a bus's wall-clock frame time stamps (``time.time()`` s) to a unit's clock.

    Parameters
    ----------
    clock : callable
        The unit's time base, s (``time.monotonic``; a simulation's warped clock, whose
        origin is its start and which runs ``clock_scale`` times faster than the wall).
    clock_scale : float
        Clock seconds per wall second.

    Notes
    -----
    :meth:`sync` reads the wall clock and the unit's clock together once (the least
    disturbed of a few readings), so that a stamp maps to
    ``clock_ref + (stamp - wall_ref) * clock_scale``: the clock's origin and rate both
    count, and a thread preempted between two clock readings shifts no frame.
    """

    def __init__(self, clock: Callable[[], float], clock_scale: float = 1.0) -> None:
        if not clock_scale > 0:
            raise ValueError(f"clock_scale must be > 0, got {clock_scale}")
        self.clock = clock
        self.clock_scale = clock_scale
        self._wall_ref = 0.0
        self._clock_ref = 0.0
        self.sync()

    def sync(self, tries: int = 5) -> None:
        """Pair a wall-clock reading with a unit-clock reading."""
        best: tuple[float, float, float] | None = None
        for _ in range(tries):
            w0 = time.time()
            c = self.clock()
            w1 = time.time()
            if best is None or w1 - w0 < best[0]:
                best = (w1 - w0, (w0 + w1) / 2, c)
        assert best is not None
        _, self._wall_ref, self._clock_ref = best

    def __call__(self, stamp_wall_s: float) -> float:
        """The unit-clock time (s) of a wall-clock time stamp (s)."""
        return self._clock_ref + (stamp_wall_s - self._wall_ref) * self.clock_scale

    def wall(self, clock_s: float) -> float:
        """The wall-clock time stamp (s) of a unit-clock instant (s): the inverse."""
        return self._wall_ref + (clock_s - self._clock_ref) / self.clock_scale


@dataclass(frozen=True)
class _Held:
    """A reading held back until the next one shows whether its counter fits."""

    reading: Reading
    receive_time_s: float
    sent_time_s: float | None
    elapsed_s: float | None
    elapsed_range_s: tuple[float, float] | None


class BatchBuilder:
    """Accumulates readings, unwraps their counters and records gaps and link events.

    It also screens each reading (the recorder's sanity checks): a rate (or an
    acceleration) that is not a finite number, or beyond ``rate_limit_deg_s`` (or
    ``accel_limit_m_s2``), makes a bad sample, left out and
    counted (a ``bad_sample`` event; the counter then declares it missing). With
    ``check_continuity`` (protocols whose checksum lets some corrupted frames through:
    an 8-bit sum, a CRC-8) a reading whose counter does not follow the previous one is
    held until the next: if that one follows the previous reading and not the held one,
    the held counter was corrupted and the reading is a bad sample; otherwise the jump
    was a gap.

    Parameters
    ----------
    n_axes : int
        Columns of the rate array.
    tracker : CounterTracker
        The device's counter tracker (kept across reconnects so gaps span them).
    has_device_time, has_temperature : bool
        Whether the batch carries those arrays (None otherwise).
    check_continuity : bool
        Hold readings whose counter jumps until the next one confirms the jump.
    rate_limit_deg_s : float or None
        Measurement range, deg/s: a larger magnitude on any axis is a bad sample.
    n_accel_axes : int
        Columns of the acceleration array (0: the batches carry none).
    accel_limit_m_s2 : float or None
        Accelerometer range, m/s^2: a larger magnitude on any axis is a bad sample.
    """

    def __init__(self, n_axes: int, tracker: CounterTracker, *, has_device_time: bool,
                 has_temperature: bool, check_continuity: bool = False,
                 rate_limit_deg_s: float | None = None, n_accel_axes: int = 0,
                 accel_limit_m_s2: float | None = None) -> None:
        self.n_axes = n_axes
        self.n_accel_axes = n_accel_axes
        self.accel_limit_m_s2 = accel_limit_m_s2
        self.tracker = tracker
        self.has_device_time = has_device_time
        self.has_temperature = has_temperature
        self.check_continuity = check_continuity
        self.rate_limit_deg_s = rate_limit_deg_s
        #: Clock s a held reading waits for the next one before it is taken as it is.
        self.hold_s = max(0.05, 4.0 / tracker.sample_rate_hz)
        self._held: _Held | None = None
        self._clear()

    def _clear(self) -> None:
        self._rates: list[tuple[float, ...]] = []
        self._counters: list[int] = []
        self._times: list[float] = []
        self._status: list[int] = []
        self._device_status: list[int] = []
        self._any_device_status = False
        self._device_time: list[float] = []
        self._temperature: list[float] = []
        self._accel: list[tuple[float, ...]] = []
        self._gaps: list[Gap] = []
        self._events: list[DeviceEvent] = []
        self._crc_errors = 0

    def _implausible(self, reading: Reading) -> str:
        """Why a reading cannot be a gyro's sample ("" if it can)."""
        rates = reading.rate_deg_s
        if len(rates) != self.n_axes or not all(math.isfinite(r) for r in rates):
            return "rate not a finite number"
        limit = self.rate_limit_deg_s
        if limit is not None and any(abs(r) > limit for r in rates):
            return f"rate beyond the {limit:g} deg/s range"
        if self.n_accel_axes:
            accel = reading.accel_m_s2
            if accel is None or len(accel) != self.n_accel_axes or \
                    not all(math.isfinite(a) for a in accel):
                return "acceleration not a finite number"
            alimit = self.accel_limit_m_s2
            if alimit is not None and any(abs(a) > alimit for a in accel):
                return f"acceleration beyond the {alimit:g} m/s^2 range"
        return ""

    def add(self, reading: Reading, receive_time_s: float, sent_time_s: float | None = None,
            *, elapsed_s: float | None = None,
            elapsed_range_s: tuple[float, float] | None = None) -> None:
        """Append one reading received at ``receive_time_s`` (station clock, s).

        ``sent_time_s`` is the best estimate of when the device sent it (station clock,
        s), used to count the wraps of a long gap; default: the receive time.
        ``elapsed_s`` instead is the adapter's estimate of the time since the previous
        reading (s), ``elapsed_range_s`` its bounds (see :meth:`CounterTracker.update`).
        """
        why = self._implausible(reading)
        if why:
            self.event("bad_sample", receive_time_s, 1, why)
            return
        item = _Held(reading, receive_time_s, sent_time_s, elapsed_s, elapsed_range_s)
        if not self.check_continuity:
            self._accept(item)
            return
        held, self._held = self._held, None
        if held is None:
            if self.tracker.residue_step(reading.counter) == 1:
                self._accept(item)
            else:
                self._held = item
            return
        modulus = self.tracker.modulus
        from_held = self.tracker.samples_between(held.reading.counter, reading.counter)
        # Time enough between the last sample and this one for the counter to have gone
        # round: the order of counters says nothing, the jump is taken for a gap.
        span = (_sum(held.elapsed_s, elapsed_s) if elapsed_s is not None else
                (receive_time_s if sent_time_s is None else sent_time_s)
                - self.tracker.last_time_s)
        if from_held == 1 or span is None or \
                span * self.tracker.sample_rate_hz >= modulus / 2 or \
                self.tracker.residue_step(reading.counter) >= \
                self.tracker.residue_step(held.reading.counter):
            self._accept(held)  # the jump was a gap: this reading follows it
            self.add(reading, receive_time_s, sent_time_s, elapsed_s=elapsed_s,
                     elapsed_range_s=elapsed_range_s)
            return
        self.event("bad_sample", held.receive_time_s, 1, "counter out of sequence")
        self.add(reading, receive_time_s, sent_time_s, elapsed_s=_sum(held.elapsed_s, elapsed_s),
                 elapsed_range_s=_sum_range(held.elapsed_range_s, elapsed_range_s))

    def _accept(self, item: _Held) -> None:
        reading = item.reading
        counter, gap = self.tracker.update(
            reading.counter,
            item.receive_time_s if item.sent_time_s is None else item.sent_time_s,
            reading.device_time_s, elapsed_s=item.elapsed_s,
            elapsed_range_s=item.elapsed_range_s)
        if gap is not None:
            self._gaps.append(gap)
        self._rates.append(reading.rate_deg_s)
        self._counters.append(counter)
        self._times.append(item.receive_time_s)
        self._status.append(reading.status)
        if reading.device_status is None:
            self._device_status.append(NO_DEVICE_STATUS)
        else:
            self._device_status.append(reading.device_status)
            self._any_device_status = True
        self._device_time.append(np.nan if reading.device_time_s is None
                                 else reading.device_time_s)
        self._temperature.append(np.nan if reading.temperature_c is None
                                 else reading.temperature_c)
        if self.n_accel_axes and reading.accel_m_s2 is not None:
            self._accel.append(reading.accel_m_s2)

    def event(self, kind: EventKind, receive_time_s: float, count: int = 1,
              detail: str = "") -> None:
        """Record a link event; CRC errors also add to the batch's ``crc_errors``."""
        if kind == "crc_error":
            self._crc_errors += count
        self._events.append(DeviceEvent(kind, receive_time_s, count, detail))

    def take(self, now_s: float | None = None) -> SampleBatch:
        """The batch collected since the last call (possibly empty).

        ``now_s`` (the adapter's clock, s): a reading held for longer than
        :attr:`hold_s` without a next one to judge it by is taken as it is.
        """
        held = self._held
        if held is not None and now_s is not None and now_s - held.receive_time_s > self.hold_s:
            self._held = None
            self._accept(held)
        n = len(self._counters)
        rates = np.asarray(self._rates, dtype=np.float64).reshape(n, self.n_axes)
        batch = SampleBatch(
            rate_deg_s=rates,
            counter=np.asarray(self._counters, dtype=np.int64),
            receive_time_s=np.asarray(self._times, dtype=np.float64),
            status=np.asarray(self._status, dtype=np.uint32),
            device_time_s=(np.asarray(self._device_time, dtype=np.float64)
                           if self.has_device_time else None),
            temperature_c=(np.asarray(self._temperature, dtype=np.float64)
                           if self.has_temperature else None),
            gaps=tuple(self._gaps), events=tuple(self._events), crc_errors=self._crc_errors,
            accel_m_s2=(np.asarray(self._accel, dtype=np.float64).reshape(n, self.n_accel_axes)
                        if self.n_accel_axes else None),
            device_status=(np.asarray(self._device_status, dtype=np.int64)
                           if self._any_device_status else None),
        )
        self._clear()
        return batch


def _sum(a: float | None, b: float | None) -> float | None:
    return None if a is None or b is None else a + b


def _sum_range(a: tuple[float, float] | None, b: tuple[float, float] | None
               ) -> tuple[float, float] | None:
    return None if a is None or b is None else (a[0] + b[0], a[1] + b[1])
