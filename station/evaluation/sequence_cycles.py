"""A sequence's segments placed in time: which switch-on each belongs to, and when it began.

The recorder gives every unit of a segment its own time base (seconds from the moment it
started reading the unit, ``time_warp`` of them per wall second, its start in UTC); the
sequence's journal gives the instant each unit's supply was switched on (the station's
clock, s since the epoch). Put together, every sample gets its time since power-on:

* the *first sample's* time is the lower envelope of ``receive_time - k / fs`` over the
  first samples (a read delivers a sample at the earliest when it was sent; the earliest
  reads give its send time), so a late first read does not make the turn-on look late;
* a segment whose recorder read the unit before its supply came on holds the turn-on:
  its *turn-on time* is that of its first valid sample (status 0) since the switch-on;
* the *switch-on number* counts every switch-on of the unit's supply the journal holds
  up to the segment, those the profile asked for and those a resume made: a unit powered
  again takes a new turn-on bias and warms up again, so a supply a resume found off and
  switched on again starts a switch-on of its own in every figure (its turn-on time not
  heard: no recorder listened), and so does a turn-on record redone after a resume (the
  parts of the switch-on before are superseded); the time since switch-on counts from the
  latest;
* every sample on the grid (gaps included) follows one sample period apart.

Each unit's temperature is the one it reports; a unit without one takes the chamber's air
temperature from the journal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from station.model.sequence_runs import Segment, SequenceRun
from station.model.sequences import Step
from station.storage.sequence_files import SegmentUnit, read_segment_unit

#: Samples whose receive times bound the first sample's send time (the envelope): many,
#: so that a reader held up for a while (a loaded host) still has prompt reads among them.
ENVELOPE_SAMPLES = 2000


@dataclass(frozen=True)
class SegmentView:
    """One unit's data in one segment, placed relative to its switch-on.

    Attributes
    ----------
    segment, step : Segment, Step
        Which segment, of which step.
    data : SegmentUnit
        The unit's samples.
    power_cycle : int or None
        1-based count of the unit's switch-ons (the profile's and a resume's) up to this
        segment's first sample (None: none, a unit that was never switched).
    first_s : float or None
        Time of the first sample since the latest switch-on (the profile's or a resume's),
        s (sequence clock); None without a switch-on.
    switch_on_wall_s : float or None
        That switch-on's instant, s since the epoch (None without one).
    by_resume : bool
        That switch-on is one a resume made (no ``power_on`` step asked for it).
    turn_on_time_s : float or None
        Switch-on to the first valid sample, s, when the recorder read the unit from
        before its switch-on; None otherwise.
    temperature_c : ndarray or None
        Temperature on the sample grid (degC; NaN in gaps), the unit's or the chamber's.
    temperature_source : str
        ``"unit"``, ``"chamber"`` or ``""`` (none).
    """

    segment: Segment
    step: Step
    data: SegmentUnit
    power_cycle: int | None
    first_s: float | None
    switch_on_wall_s: float | None
    by_resume: bool
    turn_on_time_s: float | None
    temperature_c: NDArray[np.float64] | None
    temperature_source: str

    @property
    def sample_rate_hz(self) -> float:
        """Nominal rate, Hz."""
        return self.data.record.sample_rate_hz

    def since_on_s(self) -> NDArray[np.float64] | None:
        """Time since the switch-on of every sample on the grid, s (None without one)."""
        if self.first_s is None:
            return None
        return self.first_s + np.arange(self.data.record.span_samples) / self.sample_rate_hz

    def settled(self, after_s: float) -> NDArray[np.bool_]:
        """Which samples of the grid come ``after_s`` or more after the switch-on (all of
        them without one): the warm-up left out."""
        since = self.since_on_s()
        if since is None:
            return np.ones(self.data.record.span_samples, dtype=bool)
        return since >= after_s


def _grid(record_index: NDArray[np.int64] | None, values: NDArray[np.float64], span: int
          ) -> NDArray[np.float64]:
    if record_index is None:
        return np.asarray(values, dtype=np.float64)
    out = np.full(span, np.nan)
    out[record_index] = values
    return out


def first_sample_unit_s(data: SegmentUnit, *, valid_only: bool = True) -> float | None:
    """Send time of the first (valid) sample on the unit's time base, s: the lower envelope
    of ``receive_time - (grid index) / fs`` over the first :data:`ENVELOPE_SAMPLES`, less
    the samples declared missing before the first one received."""
    rec = data.record
    n = len(data.receive_time_s)
    if n == 0:
        return None
    grid = (np.arange(n) if data.grid_index is None
            else np.asarray(data.grid_index, dtype=np.int64))
    start = 0
    if valid_only:
        valid = np.flatnonzero(data.status == 0)
        if valid.size == 0:
            return None
        start = int(valid[0])
    stop = min(n, start + ENVELOPE_SAMPLES)
    k = grid[start:stop] - grid[start] + (data.leading_missing if start == 0 else 0)
    return float(np.min(data.receive_time_s[start:stop] - k / rec.sample_rate_hz))


def _chamber_readings(run: SequenceRun) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    rows = [(e.wall_s, e.value) for e in run.journal if e.kind == "chamber" and
            math.isfinite(e.value)]
    if not rows:
        return np.zeros(0), np.zeros(0)
    arr = np.array(sorted(rows))
    return arr[:, 0], arr[:, 1]


def segment_view(run: SequenceRun, segment: Segment, unit_id: str) -> SegmentView:
    """One unit of one segment, placed relative to the unit's switch-ons.

    Raises
    ------
    RecordFormatError
        The segment's file cannot be read, or has no such unit.
    """
    data = read_segment_unit(Path(run.path).parent / segment.file, unit_id)
    step = run.steps[segment.step]
    rec = data.record
    warp = data.time_warp if data.time_warp > 0 else 1.0
    first_unit = first_sample_unit_s(data, valid_only=False)
    power_cycle = first_s = turn_on = switch_on = None
    by_resume = False
    if first_unit is not None and math.isfinite(data.start_wall_s):
        first_wall = data.start_wall_s + first_unit / warp
        ons = [e for e in run.switch_ons(unit_id) if e.wall_s <= first_wall]
        if ons:
            power_cycle = len(ons)
            switch_on = ons[-1].wall_s
            by_resume = not run.asked_for(ons[-1])
            on_unit = (switch_on - data.start_wall_s) * warp  # the switch-on, unit time base
            first_s = first_unit - on_unit
            valid_unit = first_sample_unit_s(data)
            if switch_on >= data.start_wall_s and valid_unit is not None:
                turn_on = valid_unit - on_unit
    span = rec.span_samples
    temperature, source = None, ""
    if rec.temperature_c is not None:
        temperature, source = _grid(rec.sample_index, rec.temperature_c, span), "unit"
    else:
        times, values = _chamber_readings(run)
        if times.size and first_unit is not None:
            wall = data.start_wall_s + (first_unit + np.arange(span) / rec.sample_rate_hz) / warp
            temperature, source = np.interp(wall, times, values), "chamber"
    return SegmentView(segment, step, data, power_cycle, first_s, switch_on, by_resume,
                       turn_on, temperature, source)


def unit_segments(run: SequenceRun, unit_id: str) -> list[SegmentView]:
    """Every segment of ``unit_id`` in recording order (segments without it, and those a
    redone step superseded, left out)."""
    from station.errors import RecordFormatError

    views = []
    for seg in run.segments:
        if seg.superseded:
            continue
        try:
            views.append(segment_view(run, seg, unit_id))
        except (RecordFormatError, OSError):
            continue
    return views


def switch_on_cycles(views: list[SegmentView]) -> tuple[int, ...]:
    """The switch-ons (numbers, in order) that recorded data: what a sequence's figures and
    its summary call its cycles."""
    return tuple(sorted({v.power_cycle for v in views if v.power_cycle is not None}))
