"""Reading one unit: its adapter, its simulator if it has one, and its event batches.

A :class:`UnitWorker` runs in the unit's own process (:mod:`station.recording.unit_process`): it
reads the device on the unit's own time base (a simulation's warped clock,
``time.monotonic`` for hardware), reconnects with exponential backoff after a
disconnect, turns every adapter batch into an :class:`~station.model.documents.EventBatch`
and hands it to ``send``. It stops at the run's duration, when asked, or when a replayed
capture ends.

A simulated unit (a ``sim+`` URL) starts held (paused: ``open_device(url, held=True)``)
and samples from when the recorder listens, as a bench gyro switched on by the operator
(its first sample, counter 0, falls due at the run's start), and ends exactly: its
faults are turned off, it is told to stop after a sample index a little ahead, and the
unit reads up to that sample; where the last frames were lost, it is held and the samples
after the last one received are declared missing by its own count
(:func:`trailing_gap_count`). Every sample it generated is then recorded or declared
missing.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np

from devices.errors import DeviceError, DeviceTimeoutError, NoRateError
from devices.gaps import RATE_TOLERANCE
from devices.opened import OpenedDevice
from devices.protocols import DeviceDescription, HeldQuiet, SampleBatch, Simulated
from devices.replay import EndOfReplayError
from station.model.documents import EventBatch, LogEntry, UnitTally, utc_now

#: Stop reasons a unit reports in its ``end`` log entry.
END_DURATION = "duration"
END_STOPPED = "stopped"
END_OF_REPLAY = "end of the replayed capture"


@dataclass(frozen=True)
class ReadSettings:
    """How a unit reads (times in wall s unless said).

    Attributes
    ----------
    duration_s : float
        Run length, s on the unit's own time base.
    read_timeout_s : float
        Wait per adapter read.
    backoff_initial_s, backoff_max_s : float
        Reconnect delays: doubled after each failed attempt up to the maximum.
    batch_s : float
        Longest a unit holds its batches before sending them on (they travel between
        processes: fewer, larger messages).
    rate_limit_deg_s : float or None
        Measurement range (from the product profile): a larger rate is a bad sample.
    accel_limit_m_s2 : float or None
        Accelerometer range, m/s^2 (the profile's ``accel_range_g``; None: the
        protocol's own): a larger acceleration is a bad sample.
    """

    duration_s: float
    read_timeout_s: float = 0.05
    backoff_initial_s: float = 0.05
    backoff_max_s: float = 1.0
    batch_s: float = 0.05
    rate_limit_deg_s: float | None = None
    accel_limit_m_s2: float | None = None


class Batcher:
    """Joins a unit's event batches and sends them at most every ``batch_s`` (wall s)."""

    def __init__(self, send: Callable[[EventBatch], None], batch_s: float) -> None:
        self._send = send
        self.batch_s = batch_s
        self._held: list[EventBatch] = []
        self._since = 0.0
        self._lock = threading.Lock()

    def add(self, doc: EventBatch) -> None:
        """Hold ``doc``; send what is held if the oldest is ``batch_s`` old."""
        with self._lock:
            if not self._held:
                self._since = time.monotonic()
            self._held.append(doc)
        self.tick()

    def tick(self, *, force: bool = False) -> None:
        """Send what is held if it is due (or ``force``)."""
        with self._lock:
            if not self._held or not (force or time.monotonic() - self._since >= self.batch_s):
                return
            held, self._held = self._held, []
            self._send(EventBatch.join(held))


class UnitWorker:
    """Reads one unit in a thread and hands its event batches to ``send``.

    Parameters
    ----------
    unit_id : str
        ``unit1``, ``unit2``, ... in the order of the URLs.
    opened : OpenedDevice
        The adapter (opened) and, for a simulation, the simulator behind it.
    settings : ReadSettings
        Duration, timeouts, backoff.
    send : callable
        Where each event batch goes (in the reading thread).
    """

    def __init__(self, unit_id: str, opened: OpenedDevice, settings: ReadSettings,
                 send: Callable[[EventBatch], None]) -> None:
        self.unit_id = unit_id
        self.opened = opened
        self.settings = settings
        self.description: DeviceDescription = opened.source.describe()
        #: The simulated device's controls, None for hardware (and a replay).
        self.simulated: Simulated | None = opened if isinstance(opened, Simulated) else None
        self.clock: Callable[[], float] = opened.unit_clock
        self.time_warp = opened.time_warp
        self.time_base = opened.time_base
        self._out = Batcher(send, settings.batch_s)
        #: The source has nothing more to give (the end of a replayed capture).
        self.source_ended = False
        self.tally = UnitTally()
        self.done = threading.Event()
        self.stop = threading.Event()
        self.error: BaseException | None = None
        self.cpu_s = 0.0
        self.samples_sent: int | None = None
        self.start_utc = ""
        self.last_counter = -1
        self._held_at = 0
        self._last_sample_at = 0.0
        self._t0 = 0.0
        self._seq = 0
        self._thread = threading.Thread(target=self._run, name=f"recorder-{unit_id}",
                                        daemon=True)

    # -- life cycle ----------------------------------------------------------------
    def start(self) -> None:
        """Start reading (a held simulation starts sampling now)."""
        self.start_utc = utc_now()
        self._t0 = self.clock()
        if self.simulated is not None:
            if isinstance(self.opened.source, HeldQuiet):
                self.opened.source.quiet_until_now()  # held since it was opened
            # Samples it made before it was held (none when it was opened held, as the
            # unit's process opens it): the leading gap's count starts there (an 8-bit
            # counter cannot say how many wraps that was).
            self._held_at = self.simulated.samples_sent()
            # it ends at the duration on its own clock, however late this process reads
            # it: a starved reader must not find (and declare lost) the samples of the
            # time it overran. Set with the release itself (a second request to its
            # process would come late on a loaded host); its time line is this reader's
            # from the release on (the gaps' wrap counts are bounded by that timing), and
            # samples it made before a hold come on top (none when it was opened held)
            run_s = self.settings.duration_s - self.elapsed_s()
            self.simulated.resume(run_for_s=max(run_s, 0.0))
        self._thread.start()

    def join(self, timeout_s: float | None = None) -> None:
        """Wait for the thread to end."""
        if self._thread.is_alive():
            self._thread.join(timeout_s)

    def elapsed_s(self) -> float:
        """Time since the unit started, s on its own time base."""
        return self.clock() - self._t0

    # -- reading -------------------------------------------------------------------
    def _emit(self, batch_or_none: object, extra: Sequence[LogEntry] = ()) -> int:
        if isinstance(batch_or_none, SampleBatch):
            doc = EventBatch.from_samples(self.unit_id, self._seq, batch_or_none, self._t0,
                                          [*self._leading_gap(batch_or_none), *extra])
        elif extra:
            doc = _log_only(self.unit_id, self._seq, self.description.n_axes, extra)
        else:
            self._out.tick()
            return 0
        if len(doc) or doc.log:
            self._seq += 1
            self.tally.add(doc)
            if len(doc):
                self.last_counter = int(doc.counter[-1])
                self._last_sample_at = time.monotonic()
            self._out.add(doc)
        return len(doc)

    def _leading_gap(self, batch: SampleBatch) -> list[LogEntry]:
        """A simulated unit starts at counter 0 when the recorder starts listening: samples
        it produced before the first one received (a polled register overwritten, a CAN
        frame before the bus was read, samples a starved simulator lost) are declared as
        a gap.

        The counter gives the count modulo its wrap; the time from the start to the
        first sample's reception bounds the wraps (:func:`leading_gap_bounds`): a host
        that held the first sample back for longer than a counter period makes the count
        an interval, never a certain count that misses whole wraps.
        """
        if self.tally.samples or not len(batch) or self.simulated is None:
            return []
        first = int(batch.counter[0])
        elapsed = float(batch.receive_time_s[0]) - self._t0
        low, best, high = leading_gap_bounds(
            first, self._held_at, elapsed, self.description.sample_rate_hz,
            self.description.counter_modulus)
        if high <= 0:
            return []
        return [LogEntry("gap", elapsed, 1, best, -1,
                         "counter" if low == high else "counter+elapsed",
                         "before the first sample received (the simulated device starts "
                         "at counter 0)", low, high)]

    def _read_once(self, backoff_s: float, timeout_s: float | None = None) -> tuple[int, float]:
        """One adapter read (``timeout_s`` wall s, default the settings'); returns
        (samples, next backoff s)."""
        cfg = self.settings
        try:
            batch = self.opened.source.read(cfg.read_timeout_s if timeout_s is None
                                            else timeout_s)
        except DeviceTimeoutError as exc:
            self._emit(None, [LogEntry("timeout", self.elapsed_s(), detail=str(exc)[:120])])
            return 0, backoff_s
        except EndOfReplayError:
            self.source_ended = True
            return 0, backoff_s
        except NoRateError:
            raise  # a device configured without the rate output: no retry mends it
        except DeviceError as exc:
            # Disconnected, or no acknowledgement on reconnect: the adapter logs the
            # disconnect itself; wait and let the next read reopen the link.
            if not isinstance(exc, ConnectionError) and backoff_s == cfg.backoff_initial_s:
                self._emit(None, [LogEntry("error", self.elapsed_s(), detail=str(exc)[:120])])
            self.stop.wait(backoff_s)
            return 0, min(2.0 * backoff_s, cfg.backoff_max_s)
        n = self._emit(batch)
        return n, cfg.backoff_initial_s if n else backoff_s

    def _record(self) -> None:
        backoff = self.settings.backoff_initial_s
        while (not self.stop.is_set() and not self.source_ended
               and self.elapsed_s() < self.settings.duration_s):
            _, backoff = self._read_once(backoff)

    def _read_until(self, done: Callable[[], bool], quiet_s: float, limit_s: float) -> bool:
        """Read until ``done()``, or no sample for ``quiet_s``, or ``limit_s`` (wall s)."""
        deadline = time.monotonic() + limit_s
        last_progress = time.monotonic()
        backoff = 0.01
        while not done():
            now = time.monotonic()
            if now > deadline or now - last_progress > quiet_s:
                return False
            n, backoff = self._read_once(min(backoff, 0.05), timeout_s=0.01)
            if n:
                last_progress = time.monotonic()
        return True

    def _finish_simulation(self, sim: Simulated) -> None:
        """End a simulated unit exactly: faults off, then on a sample index, read to it."""
        sim.clear_faults()
        settle = time.monotonic() + 0.05
        self._read_until(lambda: time.monotonic() > settle and self.tally.samples > 0,
                         quiet_s=10.0, limit_s=10.0)
        margin = max(1, round(0.05 * self.description.sample_rate_hz))
        modulus = self.description.counter_modulus or 1 << 62
        end = sim.samples_sent() + margin
        # its time line goes on: no silence a counter cannot see; it ends at the run's
        # duration on its own clock if that comes first
        final = sim.finish_after(end)
        end = end if final is None else final
        # (its last sample is recognized by its counter as sent: the unwrapped count may
        # differ from the simulator's by the wraps a gap could not pin down)
        read_through = self._read_until(partial(self._read_through, end, modulus),
                                        quiet_s=2.0, limit_s=20.0)
        # Held first, so that its count is final: a starved simulator thread may still be
        # generating the samples that fell due before its end.
        sim.pause()
        if not read_through:
            # (a unit held meanwhile, by its supply or the operator, generated fewer: those
            # it never generated are no loss)
            self._emit(None, self._trailing_gap(min(end, sim.samples_sent()), modulus))

    def _trailing_gap(self, end: int, modulus: int) -> list[LogEntry]:
        """Its last samples up to index ``end`` never arrived (frames lost on a starved
        host): a gap after the last sample received, counted by the simulator's own count
        (it ended on that index; no later sample will show the gap, and letting it run on
        to show one would record past the run's end): see :func:`trailing_gap_count`."""
        missing = trailing_gap_count(end, self.last_counter, modulus)
        if missing <= 0:
            return []
        return [LogEntry("gap", self.elapsed_s(), 1, missing, self.last_counter, "counter",
                         "after the last sample received (the simulated device ended on "
                         "its own count)", missing, missing)]

    def _read_through(self, end: int, modulus: int) -> bool:
        """Whether the sample before index ``end`` arrived and the line went quiet after."""
        return (self.last_counter % modulus == (end - 1) % modulus
                and time.monotonic() - self._last_sample_at > 0.2)

    def _drain(self) -> None:
        empty = 0
        deadline = time.monotonic() + 5.0
        while empty < 2 and time.monotonic() < deadline:
            n, _ = self._read_once(0.01, timeout_s=0.01)
            empty = 0 if n else empty + 1

    def _run(self) -> None:
        try:
            self._record()
            if self.simulated is not None:
                self._finish_simulation(self.simulated)
            else:
                self._drain()
            self._emit(None, [LogEntry("end", self.elapsed_s(), detail=(
                END_STOPPED if self.stop.is_set() else
                END_OF_REPLAY if self.source_ended else END_DURATION))])
        except Exception as exc:  # noqa: BLE001 - reported, and the run goes on
            self.error = exc
            self._emit(None, [LogEntry("error", self.elapsed_s(),
                                       detail=f"{type(exc).__name__}: {exc}"[:120])])
        finally:
            self._out.tick(force=True)
            self.cpu_s = time.thread_time()
            if self.simulated is not None:
                try:
                    self.samples_sent = self.simulated.samples_sent()
                except DeviceError:
                    self.samples_sent = None  # its process is gone
            self.opened.close()
            self.done.set()


def trailing_gap_count(end: int, last_counter: int, modulus: int) -> int:
    """Samples a simulated unit that ended on sample count ``end`` sent after the last one
    received (unwrapped counter ``last_counter``; -1: none received), samples.

    The count runs from the last sample's unwrapped counter to ``end``, whole counter
    wraps included (a host frozen from before the end loses more than a wrap: a STIM300's
    wraps every 0.128 s), so that the best counts of the unit's gaps add up to what it
    sent; where earlier gaps could not pin their wraps, their bounds hold that
    uncertainty. Only an unwrapped counter already at or past ``end`` (an earlier gap's
    best count too high by wraps) falls back to the counter's residue modulo ``modulus``
    (samples per wrap).
    """
    if last_counter < 0:
        return end
    if end - 1 - last_counter >= 0:
        return end - 1 - last_counter
    return (end - 1 - last_counter) % modulus


def leading_gap_bounds(first: int, held_at: int, elapsed_s: float, sample_rate_hz: float,
                       modulus: int | None) -> tuple[int, int, int]:
    """(fewest, best, most) samples a simulated unit made before the first one received.

    Parameters
    ----------
    first : int
        The first sample's counter as received (its unwrapped count starts there).
    held_at : int
        Samples the simulator had made when the recorder held it (before the start).
    elapsed_s : float
        From the start (the hold released) to the first sample's reception, unit s.
    sample_rate_hz : float
        Nominal rate, Hz.
    modulus : int or None
        The counter's wrap (None: it does not wrap).

    Returns
    -------
    (int, int, int)
        The counts ``first + k * modulus`` for the fewest wraps (none), the best (the
        fewest that reach ``held_at``) and the most the elapsed time can hold at the
        nominal rate (+ RATE_TOLERANCE, and one sample of slack).
    """
    if not modulus:
        return first, first, first
    most = held_at + elapsed_s * sample_rate_hz * (1.0 + RATE_TOLERANCE) + 1.0
    k_high = max(0, math.floor((most - first) / modulus))
    k_best = min(k_high, max(0, math.ceil((held_at - first) / modulus)))
    return first, first + k_best * modulus, first + k_high * modulus


def _log_only(unit_id: str, seq: int, n_axes: int, log: Sequence[LogEntry]) -> EventBatch:
    return EventBatch(unit_id, seq, np.empty((0, n_axes)), np.empty(0, np.int64),
                      np.empty(0), np.empty(0, np.uint32), log=tuple(log))
