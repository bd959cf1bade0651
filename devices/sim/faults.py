"""Fault injection and the sample schedule shared by every simulated device.

:class:`SimCore` turns a signal source and a (time-warped, optionally drifting) clock
into readings due now, decides per frame whether it is dropped, corrupted or preceded
by garbage, and keeps the ledger a test compares the adapter against: every sample the
device generated, and which ones never reached the wire intact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from devices.codecs.base import Reading
from devices.sim.clock import WarpClock
from devices.sim.signal import SignalSource


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
    """What a simulated device did: the truth an adapter's report is checked against."""

    generated: int = 0
    delivered: int = 0
    dropped: int = 0
    corrupted: int = 0
    lost_in_outage: int = 0
    disconnects: int = 0
    lost_indices: list[int] = field(default_factory=list)

    @property
    def missing(self) -> int:
        """Samples generated that never reached the wire intact."""
        return self.dropped + self.corrupted + self.lost_in_outage


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
    keep_history : bool
        Keep every generated rate (for round-trip tests).
    """

    def __init__(self, signal: SignalSource, sample_rate_hz: float, clock: WarpClock,
                 faults: FaultConfig | None = None, *, keep_history: bool = True) -> None:
        self.signal = signal
        self.sample_rate_hz = sample_rate_hz
        self.clock = clock
        self.faults = faults or FaultConfig()
        self.ledger = Ledger()
        self.keep_history = keep_history
        self._history: list[np.ndarray] = []
        self._rng = np.random.default_rng(self.faults.seed)
        self._origin_s = clock()
        self._paused_at: float | None = None

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

    def pause(self) -> None:
        """Stop sampling (a device put in configuration mode)."""
        if self._paused_at is None:
            self._paused_at = self.clock()

    def resume(self) -> None:
        """Resume sampling where it stopped (the counter continues without a gap)."""
        if self._paused_at is not None:
            self._origin_s += self.clock() - self._paused_at
            self._paused_at = None

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
        if self._paused_at is not None:
            return []
        target = int(self.device_time() * self.sample_rate_hz)
        n = min(target - self.ledger.generated, limit)
        if max_lag_s is not None:
            keep = max(1, int(max_lag_s * self.sample_rate_hz))
            if n > keep:
                self.lose(self._generate(n - keep))
                n = keep
        return self._generate(n)

    def next_reading(self) -> Reading:
        """One more sample now, off the time schedule (a SYNC-triggered measurement)."""
        return self._generate(1)[0]

    def _generate(self, n: int) -> list[Reading]:
        if n <= 0:
            return []
        chunk = self.signal.read(n)
        if self.keep_history:
            self._history.append(chunk.rate_deg_s)
        start = self.ledger.generated
        self.ledger.generated += n
        dt = 1.0 / self.sample_rate_hz
        return [Reading(tuple(chunk.rate_deg_s[i].tolist()), start + i, 0, (start + i) * dt,
                        float(chunk.temperature_c[i])) for i in range(n)]

    def history(self) -> np.ndarray:
        """Every rate generated so far, deg/s, shape (generated, n_axes)."""
        if not self._history:
            return np.empty((0, self.signal.n_axes))
        return np.concatenate(self._history)

    def lose(self, readings: list[Reading]) -> None:
        """Count samples lost to an outage or a stall."""
        self.ledger.lost_in_outage += len(readings)
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
