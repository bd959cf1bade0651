"""Polls a run file in SWMR mode and keeps what the live screen shows (never the devices).

:class:`RunPoller` reads, at each :meth:`~RunPoller.poll`, only what the recorder has
committed since the previous poll (at most :data:`MAX_SAMPLES_PER_POLL` samples a unit, so
that reattaching to a long run catches up over several polls without freezing), and
returns a :class:`LiveSnapshot`: the run state, the progress, one :class:`UnitStatus` per
unit, and per unit a decimated rate series and the Allan deviation of its first axis
computed from 0.1-s averages of the valid samples (``status`` 0: docs/hdf5-layout.md; every
tau from 0.1 s up grows as the run grows).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import h5py
import numpy as np
from numpy.typing import NDArray

from station.recording.progress import DEG_S_TO_DEG_H, BlockAverager
from station.storage.hdf5 import (
    UnitCounts,
    open_run_file,
    run_state,
    text_value,
    unit_counts,
    unit_ids,
    word_in_status,
)
from station.storage.hdf5_open import refresh_alone

#: Length of the averages the live plots are drawn from, s.
BLOCK_S = 0.1
#: Most samples read from one unit at one poll.
MAX_SAMPLES_PER_POLL = 2_000_000
#: Most points of a plotted series (the terminal has fewer columns than this anyway).
MAX_PLOT_POINTS = 400


@dataclass(frozen=True)
class UnitStatus:
    """One unit's live status row (counts from the committed data)."""

    unit_id: str
    model: str
    serial_number: str
    samples: int
    sample_rate_hz: float
    achieved_rate_hz: float | None
    crc_errors: int
    gaps: int
    missing: int
    reconnects: int
    connected: bool
    temperature_c: float | None
    unit_time_s: float
    time_warp: float


@dataclass(frozen=True, eq=False)  # arrays: compared by identity
class Series:
    """x/y points of one line of a plot (units given by the plot's labels).

    ``kind`` is ``"line"``, ``"points"`` or ``"dashed"`` (a limit, a fitted term).
    """

    label: str
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    kind: str = "line"


@dataclass(frozen=True)
class LiveSnapshot:
    """What the live screen shows at one moment.

    ``elapsed_s`` is the slowest unit's time on its own time base (simulated seconds for
    a time-warped simulation): its newest sample's, or while recording the wall time since
    the start times its warp when that is later (a disconnected unit); ``remaining_wall_s``
    is the wall time left at the units' time warp.
    """

    path: Path
    state: str
    stop_reason: str
    start_utc: str
    duration_s: float
    elapsed_s: float
    remaining_wall_s: float
    units: tuple[UnitStatus, ...]
    rate: tuple[Series, ...] = ()
    adev: tuple[Series, ...] = ()
    caught_up: bool = True

    @property
    def fraction(self) -> float:
        """Progress, 0..1."""
        return min(1.0, self.elapsed_s / self.duration_s) if self.duration_s > 0 else 0.0

    @property
    def stopped(self) -> bool:
        """The recorder closed the file."""
        return self.state == "stopped"


@dataclass
class _UnitState:
    next_index: int = 0
    averager: BlockAverager | None = None
    tau0_s: float = BLOCK_S
    last_samples: int = 0
    last_time_s: float = 0.0
    achieved_hz: float | None = None
    temperature_c: float | None = None
    attrs: dict[str, object] = field(default_factory=dict)


def decimate(x: NDArray[np.float64], y: NDArray[np.float64], max_points: int = MAX_PLOT_POINTS
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """At most ``max_points`` points of (x, y): means of equal consecutive groups."""
    n = len(y)
    if n <= max_points:
        return x, y
    k = -(-n // max_points)
    m = n // k * k
    return x[:m].reshape(-1, k).mean(axis=1), y[:m].reshape(-1, k).mean(axis=1)


def live_adev(means: NDArray[np.float64], tau0_s: float) -> tuple[NDArray[np.float64],
                                                                  NDArray[np.float64]]:
    """Overlapping Allan deviation (deg/h) at octave taus of block means (deg/s) of
    ``tau0_s`` each; empty until there are at least 3 blocks."""
    if len(means) < 3:
        return np.empty(0), np.empty(0)
    from analysis.allan.variance import allan_variance  # scipy: loaded once a plot is due

    result = allan_variance(means, 1.0 / tau0_s, taus="octave")
    keep = np.isfinite(result.adev) & (result.adev > 0)
    return result.tau_s[keep], result.adev[keep] * DEG_S_TO_DEG_H


class RunPoller:
    """Follows one run file; call :meth:`poll` from a worker thread (it does file I/O).

    Parameters
    ----------
    path : Path
        The run file (being written, or closed).
    max_samples_per_poll : int
        Most samples read per unit per poll.
    """

    def __init__(self, path: Path, *, max_samples_per_poll: int = MAX_SAMPLES_PER_POLL) -> None:
        self.path = Path(path)
        self.max_samples_per_poll = max_samples_per_poll
        self._units: dict[str, _UnitState] = {}

    def _unit_state(self, g: h5py.Group, uid: str) -> _UnitState:
        st = self._units.get(uid)
        if st is None:
            attrs = {k: (text_value(v) if isinstance(v, bytes | str | np.bytes_) else v)
                     for k, v in g.attrs.items()}
            rate = float(attrs["sample_rate_hz"])
            block = max(1, round(rate * BLOCK_S))
            st = _UnitState(averager=BlockAverager(block), tau0_s=block / rate, attrs=attrs)
            self._units[uid] = st
        return st

    def _read_new(self, g: h5py.Group, st: _UnitState, committed: int) -> bool:
        """Read samples ``next_index:`` (bounded) of the first axis, the valid ones
        (``status`` 0) into the averages; True when caught up."""
        stop = min(committed, st.next_index + self.max_samples_per_poll)
        if stop > st.next_index and st.averager is not None:
            refresh_alone(g["rate"])
            refresh_alone(g["status"])
            rates = np.asarray(g["rate"][st.next_index:stop, 0], dtype=np.float64)
            valid = (np.asarray(g["status"][st.next_index:stop]) == 0  # the device's "good"
                     ) | word_in_status(g)
            st.averager.add(rates[valid])
            if "temperature" in g:
                refresh_alone(g["temperature"])
                st.temperature_c = float(g["temperature"][stop - 1])
            st.next_index = stop
        return stop == committed

    def poll(self) -> LiveSnapshot:
        """Read what was committed since the last poll and return the new snapshot.

        Raises
        ------
        RecordFormatError
            Not a run file.
        FileNotFoundError
            The file is gone.
        """
        with open_run_file(self.path) as f:
            state = run_state(f)
            duration_s = float(f.attrs.get("duration_requested_s", 0.0))
            start_utc = text_value(f.attrs.get("start_utc", ""))
            rows, rates, adevs, caught_up = [], [], [], True
            for uid in unit_ids(f):
                g = f["units"][uid]
                st = self._unit_state(g, uid)
                c = unit_counts(f, uid)
                caught_up &= self._read_new(g, st, c.samples_recorded)
                if c.last_time_s > st.last_time_s and st.last_samples:
                    st.achieved_hz = ((c.samples_recorded - st.last_samples)
                                      / (c.last_time_s - st.last_time_s))
                st.last_samples, st.last_time_s = c.samples_recorded, c.last_time_s
                rows.append(self._status(uid, st, c))
                means = np.asarray(st.averager.means if st.averager else [], dtype=np.float64)
                t = np.asarray((np.arange(len(means)) + 0.5) * st.tau0_s, dtype=np.float64)
                rates.append(Series(uid, *decimate(t, means * DEG_S_TO_DEG_H)))
                adevs.append(Series(uid, *live_adev(means, st.tau0_s)))
        if state["state"] == "stopped":
            times = [r.unit_time_s for r in rows]
        else:  # a unit that sends nothing (disconnected) still ages on the clock
            wall_s = wall_elapsed_s(start_utc)
            times = [max(r.unit_time_s, wall_s * r.time_warp) for r in rows]
        elapsed = min(min(times, default=0.0), duration_s)
        remaining = max(((duration_s - t) / max(r.time_warp, 1e-9) for t, r in zip(times, rows,
                                                                                 strict=True)),
                        default=0.0)
        if state["state"] == "stopped":
            remaining = 0.0
        return LiveSnapshot(self.path, state["state"], state["stop_reason"], start_utc,
                            duration_s, elapsed, max(0.0, remaining), tuple(rows), tuple(rates),
                            tuple(adevs), caught_up)

    @staticmethod
    def _status(uid: str, st: _UnitState, c: UnitCounts) -> UnitStatus:
        a = st.attrs
        return UnitStatus(uid, str(a.get("model", "")), str(a.get("serial_number", "")),
                          c.samples_recorded,
                          float(a.get("sample_rate_hz", 0.0)),  # type: ignore[arg-type]
                          st.achieved_hz, c.crc_errors, c.gaps, c.samples_missing_declared,
                          c.reconnects, c.disconnects <= c.reconnects, st.temperature_c,
                          st.last_time_s, float(a.get("time_warp", 1.0)))  # type: ignore[arg-type]



def wall_elapsed_s(start_utc: str) -> float:
    """Wall seconds since ``start_utc`` (ISO 8601, UTC), 0 when it cannot be read."""
    try:
        start = datetime.fromisoformat(start_utc.replace("Z", "+00:00"))
    except ValueError:
        return 0.0
    if start.tzinfo is None:
        start = start.replace(tzinfo=UTC)
    return max(0.0, (datetime.now(UTC) - start).total_seconds())
