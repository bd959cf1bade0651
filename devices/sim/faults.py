"""Fault injection and the sample schedule shared by every simulated device.

:class:`SimCore` turns a signal source and a (time-warped, optionally drifting) clock
into readings due now, decides per frame whether it is dropped, corrupted or preceded
by garbage, and keeps the ledger a test compares the adapter against: how many samples
the device generated, how many never reached the wire intact, and (opt-in, bounded) which
ones and what they were. Memory stays bounded however long the run: an overnight run at
2 kHz generates 86 million samples, which the simulator counts but does not keep.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from devices.codecs.base import Reading
from devices.sim.clock import WarpClock
from devices.sim.signal import SignalChunk, SignalSource


@dataclass(frozen=True)
class FaultConfig:
    """Fault-injection knobs of a simulated device (times in simulated seconds).

    Attributes
    ----------
    drop : float
        Probability that a frame is not sent.
    corrupt : float
        Probability that one bit of a frame is flipped on the wire.
    garbage : float
        Probability of 1..``garbage_max_bytes`` junk bytes before a frame.
    stall_every_s, stall_for_s : float
        Every ``stall_every_s`` the output goes silent for ``stall_for_s``; the samples
        produced meanwhile are lost (a hung transmitter), the port stays open.
    disconnect_every_s, disconnect_for_s : float
        Every ``disconnect_every_s`` of link time the device goes away (port closed, node
        silent, server down) for ``disconnect_for_s``; it keeps sampling meanwhile.
    drift_ppm : float
        Device clock error, parts per million (its sample rate is off by as much).
    seed : int or None
        Seed of the fault decisions.
    """

    drop: float = 0.0
    corrupt: float = 0.0
    garbage: float = 0.0
    garbage_max_bytes: int = 16
    stall_every_s: float = math.inf
    stall_for_s: float = 0.0
    disconnect_every_s: float = math.inf
    disconnect_for_s: float = 0.0
    drift_ppm: float = 0.0
    seed: int | None = None

    def __post_init__(self) -> None:
        for name in ("drop", "corrupt", "garbage"):
            p = getattr(self, name)
            if not 0.0 <= p <= 1.0:
                raise ValueError(f"{name} must be a probability in [0, 1], got {p}")


def _in_window(t_s: float, every_s: float, for_s: float) -> bool:
    """True during the ``for_s`` following each multiple of ``every_s`` (not at t = 0)."""
    if not math.isfinite(every_s) or for_s <= 0:
        return False
    period = every_s + for_s
    return t_s >= every_s and (t_s % period) >= every_s


@dataclass
class Ledger:
    """What a simulated device did: the truth an adapter's report is checked against.

    The counts cover the whole run: ``generated`` and ``lost_in_outage`` count samples;
    ``delivered``, ``dropped`` and ``corrupted`` count frames (one per sample on a serial
    link; a CAN layout with a frame per axis or a CANopen node with two TPDOs sends
    several per sample). ``lost_indices`` holds the sample indices of the latest
    ``window`` lost samples only (0: none), so that a long run stays in bounded memory;
    tests that compare indices open the simulation with ``history=N``.
    """

    generated: int = 0
    delivered: int = 0
    dropped: int = 0
    corrupted: int = 0
    lost_in_outage: int = 0
    disconnects: int = 0
    window: int = 0
    lost_indices: deque[int] = field(default_factory=deque)

    def __post_init__(self) -> None:
        if self.window < 0:
            raise ValueError(f"window must be >= 0, got {self.window}")
        self.lost_indices = deque(self.lost_indices, maxlen=self.window)

    @property
    def missing(self) -> int:
        """Samples generated that never reached the wire intact."""
        return self.dropped + self.corrupted + self.lost_in_outage


class RateHistory:
    """The rates of the latest ``window`` generated samples, in a fixed ring buffer.

    Parameters
    ----------
    window : int
        Samples kept (0 keeps none).
    n_axes : int
        Columns.
    """

    def __init__(self, window: int, n_axes: int) -> None:
        if window < 0:
            raise ValueError(f"window must be >= 0, got {window}")
        self.window = window
        self._ring = np.empty((window, n_axes))
        self._end = 0  # index of the next sample

    @property
    def start(self) -> int:
        """Index of the oldest sample kept."""
        return max(0, self._end - self.window)

    def extend(self, first_index: int, rate_deg_s: np.ndarray) -> None:
        """Append the rates (deg/s, shape (n, n_axes)) of samples ``first_index``..."""
        n = len(rate_deg_s)
        self._end = first_index + n
        if not self.window:
            return
        keep = rate_deg_s[-self.window:]
        positions = np.arange(self._end - len(keep), self._end) % self.window
        self._ring[positions] = keep

    def rates(self, indices: np.ndarray | int | None = None) -> np.ndarray:
        """Rates (deg/s) of the given sample indices; all kept ones in order if None.

        Raises
        ------
        IndexError
            An index outside the kept window.
        """
        if indices is None:
            indices = np.arange(self.start, self._end)
        idx = np.asarray(indices, dtype=np.int64)
        if idx.size and (idx.min() < self.start or idx.max() >= self._end):
            raise IndexError(f"samples {idx.min()}..{idx.max()} are not all in the kept "
                             f"window {self.start}..{self._end - 1} (URL key history=)")
        return self._ring[idx % max(self.window, 1)]


class SimCore:
    """Readings due from a simulated gyro, with its faults and its ledger.

    Parameters
    ----------
    signal : SignalSource
        Where the rates and temperatures come from.
    sample_rate_hz : float
        Nominal rate, Hz (the device runs off it by ``faults.drift_ppm``).
    clock : WarpClock
        Simulated time.
    faults : FaultConfig
        Fault knobs.
    history : int
        Keep the rates and the lost indices of the latest ``history`` samples (for
        round-trip tests; 0, the default, keeps counts only: bounded memory).

    Notes
    -----
    Sampling stops while any *hold* is on: :meth:`pause` / :meth:`resume` are the
    operator's (the recorder holds a unit until it listens), :meth:`enter_configuration`
    / :meth:`enter_measurement` the device's own (an Xbus GoToConfig), :meth:`power_off`
    / :meth:`power_on` its supply's (a unit wired to a simulated fixture). Each releases
    only its own hold.
    """

    def __init__(self, signal: SignalSource, sample_rate_hz: float, clock: WarpClock,
                 faults: FaultConfig | None = None, *, history: int = 0) -> None:
        self.signal = signal
        self.sample_rate_hz = sample_rate_hz
        self.clock = clock
        self.faults = faults or FaultConfig()
        self.ledger = Ledger(window=history)
        self._history = RateHistory(history, signal.n_axes)
        n_accel = 0 if signal.accel is None else signal.accel.n_axes
        self._accel_history = RateHistory(history, n_accel) if n_accel else None
        self._rng = np.random.default_rng(self.faults.seed)
        self._origin_s = clock()
        self._holds: set[str] = set()
        self._hold_lock = threading.Lock()  # the operator, the device and its supply hold
        self._closers: list[Callable[[], None]] = []
        self._paused_at: float | None = None
        self._last_index: int | None = None
        self._end_index: int | None = None

    def device_time(self) -> float:
        """Device clock, s since start (drifting by ``drift_ppm``)."""
        return (self.clock() - self._origin_s) * (1.0 + self.faults.drift_ppm * 1e-6)

    def due_time(self, index: int) -> float:
        """Clock time (s) at which sample ``index`` fell due."""
        return self._origin_s + index / self.sample_rate_hz / (1.0 + self.faults.drift_ppm * 1e-6)

    def retime(self, sample_rate_hz: float) -> None:
        """Change the sample rate (a device reconfigured); the counter continues."""
        if not sample_rate_hz > 0:
            raise ValueError(f"sample_rate_hz must be > 0, got {sample_rate_hz}")
        scale = 1.0 + self.faults.drift_ppm * 1e-6
        self._origin_s = self.clock() - self.ledger.generated / sample_rate_hz / scale
        self.sample_rate_hz = sample_rate_hz

    def _hold(self, reason: str) -> None:
        with self._hold_lock:
            if not self._holds:
                self._paused_at = self.clock()
            self._holds.add(reason)

    def _release(self, reason: str, at_s: float | None = None) -> None:
        with self._hold_lock:
            self._release_locked(reason, at_s)

    def _release_locked(self, reason: str, at_s: float | None = None) -> None:
        self._holds.discard(reason)
        if not self._holds and self._paused_at is not None:
            released = self.clock() if at_s is None else min(at_s, self.clock())
            self._origin_s += max(0.0, released - self._paused_at)
            self._paused_at = None

    @property
    def held(self) -> bool:
        """Whether sampling is stopped now (by either hold)."""
        return bool(self._holds)

    def pause(self) -> None:
        """Hold sampling (the operator's switch: a unit not yet recorded)."""
        self._hold("operator")

    def resume(self, run_for_s: float | None = None) -> None:
        """Release the operator's hold; sampling resumes where it stopped (the counter
        continues without a gap) unless the device is in configuration mode.

        With ``run_for_s`` (s of its clock), it generates ``run_for_s`` worth of sample
        periods more and no more: a run's end on the device's own time line, however late
        the host reads it or runs this simulator's thread (a starved reader finds the
        samples of the run, never the ones of the time it overran), set with the release
        so that the latency of a second request (another process asking, a loaded host)
        cannot lengthen the run. :meth:`stop_after` does not lift it.
        """
        with self._hold_lock:
            self._release_locked("operator")
            if run_for_s is not None:  # on its own time line: a count of sample periods
                self._end_index = self.ledger.generated + int(round(run_for_s
                                                                    * self.sample_rate_hz))

    def enter_configuration(self) -> None:
        """The device's own hold (Xbus GoToConfig): no samples until measurement."""
        self._hold("configuration")

    def enter_measurement(self) -> None:
        """Leave configuration mode (Xbus GoToMeasurement); the operator's hold stays."""
        self._release("configuration")

    def on_close(self, closer: Callable[[], None]) -> None:
        """Have :meth:`stop_attached` call ``closer`` (a thread that follows the unit's
        supply)."""
        self._closers.append(closer)

    def stop_attached(self) -> None:
        """Stop what the simulation runs beside its device (once the device stopped)."""
        closers, self._closers = self._closers, []
        for closer in closers:
            closer()

    def power_off(self) -> None:
        """The supply's hold: the unit is unpowered, or still booting after power came on
        (:mod:`devices.sim.powered`); no samples until :meth:`power_on`."""
        self._hold("power")

    def power_on(self, at_s: float | None = None) -> None:
        """Release the supply's hold: the unit booted at clock time ``at_s`` (default now;
        a thread that tells it late does not delay its samples, which fall due from
        ``at_s`` on) and samples from then on."""
        self._release("power", at_s)

    def clear_faults(self) -> None:
        """Turn the faults off (drops, corruption, junk, disconnects, stalls; the clock
        drift stays): a simulated run ends cleanly, its last samples all delivered."""
        self.faults = replace(self.faults, drop=0.0, corrupt=0.0, garbage=0.0,
                              disconnect_every_s=math.inf, stall_every_s=math.inf)

    def stop_after(self, n_samples: int | None) -> int | None:
        """Generate no sample beyond the first ``n_samples`` (None: no end); returns the
        sample count it ends on (``n_samples``, or fewer where :meth:`resume`'s ``run_for_s`` end
        comes first; None: no end).

        A run ends on a sample index, not on a hold: the device keeps its time line (a
        hold would put a silence in it that no counter shows), it just produces nothing
        more. Lifted again, it finds its samples due since then: those overdue by more
        than the lateness allowance are lost, as a running gyro's would be.

        Under the lock :meth:`due` generates under: a device thread that took its samples
        due just before (a starved thread catching up) has generated them all, and the
        count it ends on is then that many (what it generated stays generated).
        """
        with self._hold_lock:
            if n_samples is not None:
                n_samples = max(n_samples, self.ledger.generated)
            self._last_index = n_samples
            return self._final_index()

    def _final_index(self) -> int | None:
        """The sample count generation stops at (None: none set)."""
        ends = [] if self._last_index is None else [self._last_index]
        if self._end_index is not None:
            ends.append(self._end_index)
        return min(ends) if ends else None

    def link_down(self) -> bool:
        """Whether the device is disconnected now."""
        return _in_window(self.device_time(), self.faults.disconnect_every_s,
                          self.faults.disconnect_for_s)

    def stalled(self) -> bool:
        """Whether the output is stalled now."""
        return _in_window(self.device_time(), self.faults.stall_every_s,
                          self.faults.stall_for_s)

    def due(self, limit: int = 10_000, *, max_lag_s: float | None = None) -> list[Reading]:
        """Readings generated since the last call (at most ``limit``).

        Parameters
        ----------
        limit : int
            Most readings returned in one call.
        max_lag_s : float or None
            A real gyro is never late. When this simulator's thread was starved, the
            samples overdue by more than ``max_lag_s`` (clock s) are generated and booked
            lost (as a device stall would lose them) rather than sent in one late burst.
        """
        # under the hold lock: a hold asked for meanwhile waits for this batch, and no
        # sample is generated once it returns
        with self._hold_lock:
            if self._holds:
                return []
            target = int(self.device_time() * self.sample_rate_hz)
            final = self._final_index()
            if final is not None:
                target = min(target, final)
            if max_lag_s is not None:
                keep = max(1, int(max_lag_s * self.sample_rate_hz))
                self._skip(target - self.ledger.generated - keep)
            return self._generate(min(target - self.ledger.generated, limit))

    def _skip(self, n: int) -> None:
        """Generate ``n`` samples and book them lost at once (no readings built)."""
        if n <= 0:
            return
        start = self.ledger.generated
        self._keep(start, self.signal.read(n))
        self.ledger.generated += n
        self.ledger.lost_in_outage += n
        if self.ledger.window:
            self.ledger.lost_indices.extend(range(max(start, start + n - self.ledger.window),
                                                  start + n))

    def next_readings(self, n: int) -> list[Reading]:
        """``n`` more samples now, off the time schedule (SYNC-triggered measurements);
        none past :meth:`stop_after`'s end."""
        final = self._final_index()
        if final is not None:
            n = min(n, final - self.ledger.generated)
        return self._generate(n)

    def _generate(self, n: int) -> list[Reading]:
        if n <= 0:
            return []
        chunk = self.signal.read(n)
        start = self.ledger.generated
        self._keep(start, chunk)
        self.ledger.generated += n
        dt = 1.0 / self.sample_rate_hz
        accel = chunk.accel_m_s2
        return [Reading(tuple(chunk.rate_deg_s[i].tolist()), start + i, 0, (start + i) * dt,
                        float(chunk.temperature_c[i]),
                        None if accel is None else tuple(accel[i].tolist()))
                for i in range(n)]

    def _keep(self, start: int, chunk: SignalChunk) -> None:
        """Book the rates (and an IMU's accelerations) of samples ``start``... in the
        history windows."""
        self._history.extend(start, chunk.rate_deg_s)
        if self._accel_history is not None and chunk.accel_m_s2 is not None:
            self._accel_history.extend(start, chunk.accel_m_s2)

    def accel_history(self, indices: np.ndarray | int | None = None) -> np.ndarray:
        """Accelerations generated (m/s^2) of the given sample indices, or every kept one,
        of a simulated IMU (the window of :meth:`history`).

        Raises
        ------
        IndexError
            An index outside the kept window.
        ValueError
            A gyro's core: it draws no accelerations.
        """
        if self._accel_history is None:
            raise ValueError("this simulated unit draws no accelerations (a gyro, or accel=0)")
        return self._accel_history.rates(indices)

    @property
    def history_start(self) -> int:
        """Index of the oldest sample whose rate is kept."""
        return self._history.start

    def history(self, indices: np.ndarray | int | None = None) -> np.ndarray:
        """Rates generated (deg/s) of the given sample indices, or every kept one.

        Only the latest ``history`` samples are kept (constructor, URL key ``history=``).

        Raises
        ------
        IndexError
            An index outside the kept window.
        """
        return self._history.rates(indices)

    def overrun(self, indices: list[int]) -> None:
        """Samples booked delivered whose frames the transport could not take (a full
        port): lost after all."""
        self.ledger.delivered -= len(indices)
        self.ledger.lost_in_outage += len(indices)
        if self.ledger.window:
            self.ledger.lost_indices.extend(indices)

    def lose(self, readings: list[Reading]) -> None:
        """Count samples lost to an outage or a stall."""
        self.ledger.lost_in_outage += len(readings)
        if self.ledger.window:
            self.ledger.lost_indices.extend(r.counter for r in readings)

    def wire(self, frame: bytes, index: int, *, header: bytes = b"") -> bytes:
        """A frame as it goes on the wire: maybe dropped, corrupted, or after garbage.

        Parameters
        ----------
        frame : bytes
            The encoded frame.
        index : int
            Sample index of the frame (recorded in the ledger if it is lost).
        header : bytes
            Sync pattern of the protocol: junk bytes never contain its first byte, so a
            junk burst cannot fake a frame start (8-bit checksums could accept one).
        """
        f = self.faults
        if f.drop and self._rng.random() < f.drop:
            self.ledger.dropped += 1
            self.ledger.lost_indices.append(index)
            return b""
        out = b""
        if f.garbage and self._rng.random() < f.garbage:
            junk = self._rng.integers(0, 256, int(self._rng.integers(1, f.garbage_max_bytes + 1)),
                                      dtype=np.uint8)
            if header:
                junk = junk[junk != header[0]]
            out = junk.tobytes()
        if f.corrupt and self._rng.random() < f.corrupt:
            self.ledger.corrupted += 1
            self.ledger.lost_indices.append(index)
            bit = int(self._rng.integers(0, 8 * len(frame)))
            buf = bytearray(frame)
            buf[bit // 8] ^= 1 << (bit % 8)
            frame = bytes(buf)
        else:
            self.ledger.delivered += 1
        return out + frame

    def chance(self, p: float) -> bool:
        """True with probability ``p`` (from the fault generator, nothing booked)."""
        return bool(p and self._rng.random() < p)

    def fault_for(self, index: int) -> str | None:
        """Fault decision for a frame that is not a byte string (a CAN frame, a register).

        Returns ``"drop"``, ``"corrupt"`` or None, and books it in the ledger.
        """
        f = self.faults
        if f.drop and self._rng.random() < f.drop:
            self.ledger.dropped += 1
            fault = "drop"
        elif f.corrupt and self._rng.random() < f.corrupt:
            self.ledger.corrupted += 1
            fault = "corrupt"
        else:
            self.ledger.delivered += 1
            return None
        self.ledger.lost_indices.append(index)
        return fault
