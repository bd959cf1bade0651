"""The Allan analysis of each temperature plateau of a sequence.

A temperature test steps the chamber (``set_chamber T``, ``wait_stable``, ``record D`` per
set point, IEEE Std 952-1997 and IEEE Std 1431-2004's drift rate temperature sensitivity
test at stabilized temperatures). Beside the bias against temperature, each plateau's
record tells how the noise changes with temperature: its rate axis is analysed as any
record's is (:func:`station.evaluation.analyze.analyze_rates` with the profile's fit method;
the accelerometer axes the record carries are not a plateau's figures), and its
ARW and bias instability are read off with their intervals as grading reads them
(:func:`station.evaluation.figure_intervals.figure_interval`: IEEE Std 952-1997 Annex C read-offs,
chi-square intervals on the edf of the Allan values, or the fitted N and B when the
profile's ``figure_source`` is ``"fit"``).

A record is a plateau when the sequence sets two temperatures or more, a ``set_chamber``
step comes before it, and its temperature after the warm-up (``bias_after_s`` from
switch-on, left out as the temperature points leave it out) moves less than
``plateau_span_c`` (5th to 95th percentile); a ramp is none. A step recorded in several
parts (interrupted and resumed) gives its longest part.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from analysis.allan.estimators import AllanResult
from analysis.errors import AnalysisError
from analysis.sequences.temperature_sensitivity import plateau_point
from station.errors import RecordFormatError
from station.evaluation.analyze import analyze_rates
from station.evaluation.figure_intervals import Interval, figure_interval
from station.evaluation.sequence_cycles import SegmentView
from station.model.profiles import Profile
from station.model.sequences import SequenceSpec, Step

#: Fewest temperature readings a record needs to be judged steady.
MIN_TEMPERATURES = 20


def temperature_span_c(temperature_c: NDArray[np.float64]) -> float | None:
    """How far a record's temperature moves: 95th minus 5th percentile, degC (None:
    fewer than :data:`MIN_TEMPERATURES` finite readings)."""
    finite = temperature_c[np.isfinite(temperature_c)]
    if finite.size < MIN_TEMPERATURES:
        return None
    low, high = np.percentile(finite, [5, 95])
    return float(high - low)


@dataclass(frozen=True)
class Plateau:
    """The Allan analysis of one axis of a unit at one temperature plateau.

    Attributes
    ----------
    axis : str
        The profile's axis.
    set_point_c : float
        The chamber's set point, degC.
    temperature_c : float
        Mean temperature of the samples analysed (the unit's, else the chamber's), degC.
    bias_deg_h : float
        Mean rate, deg/h, signed (the Earth rate not removed: the point of the bias
        against temperature).
    arw : Interval
        Angle random walk with its interval, deg/sqrt(h).
    bias_instability : Interval
        Bias instability with its interval, deg/h.
    duration_s : float
        Time analysed (after the warm-up, gaps included), s.
    segment : str
        The segment file.
    step : int
        The ``record`` step (0-based index of the expanded steps).
    allan : AllanResult or None
        The plateau's Allan variance (None: the analysis failed, see ``note``).
    note : str
        Where each figure was read (tau), or why it is missing or only a bound.
    """

    axis: str
    set_point_c: float
    temperature_c: float
    bias_deg_h: float
    arw: Interval
    bias_instability: Interval
    duration_s: float
    segment: str
    step: int
    allan: AllanResult | None = None
    note: str = ""

    def as_json(self) -> dict[str, object]:
        """One entry of ``station grade --json``'s ``sequence_plateaus``."""

        def ci(i: Interval) -> list[float] | None:
            return None if i.low is None or i.high is None else [i.low, i.high]

        return {"axis": self.axis, "set_point_c": self.set_point_c,
                "temperature_c": self.temperature_c, "bias_deg_h": self.bias_deg_h,
                "arw_deg_rt_h": self.arw.value, "arw_deg_rt_h_ci": ci(self.arw),
                "bias_instability_deg_h": self.bias_instability.value,
                "bias_instability_deg_h_ci": ci(self.bias_instability),
                "duration_s": self.duration_s, "segment": self.segment, "step": self.step + 1,
                "note": self.note}


def set_point_before(steps: Sequence[Step], index: int) -> float | None:
    """The set point of the last ``set_chamber`` step before step ``index`` (None: none)."""
    return next((s.temperature_c for s in reversed(steps[:index])
                 if s.kind == "set_chamber"), None)


def _plateau(view: SegmentView, axis: str, column: int, set_point_c: float,
             spec: SequenceSpec, profile: Profile) -> Plateau | None:
    keep = view.settled(spec.bias_after_s)
    assert view.temperature_c is not None
    temp = view.temperature_c[keep]
    span = temperature_span_c(temp)
    if span is None or span >= spec.plateau_span_c or not keep.any():
        return None
    try:
        point = plateau_point(view.data.record.gridded(column)[keep], temp)
        record = view.data.record.slice_time(int(np.argmax(keep)) / view.sample_rate_hz)
    except (AnalysisError, RecordFormatError):
        return None
    record = record.select(column)
    fs = record.sample_rate_hz
    missing = Interval(None, None, None)
    try:
        # the rate axis only: analysing the accelerometer axes too (analyze_record) cost four
        # times as much and was thrown away
        [analysis] = analyze_rates(record, method=profile.fit_method)
    except (AnalysisError, ValueError) as exc:
        return Plateau(axis, set_point_c, point.temperature_c, point.bias_deg_h, missing,
                       missing, record.span_samples / fs, view.segment.file, view.step.index,
                       note=f"no Allan analysis: {exc}")
    x = analysis.rate_deg_s
    assert x is not None
    arw, bi = (figure_interval(name, x, analysis, profile.confidence,
                               source=profile.figure_source)
               for name in ("arw", "bias_instability"))
    note = "; ".join(f"{label}: {i.note}" for label, i in (("ARW", arw), ("bias instability", bi))
                     if i.note)
    return Plateau(axis, set_point_c, point.temperature_c, point.bias_deg_h, arw, bi,
                   record.span_samples / fs, view.segment.file, view.step.index,
                   analysis.allan, note)


def plateau_analyses(views: Sequence[SegmentView], steps: Sequence[Step],
                     columns: dict[str, int], spec: SequenceSpec, profile: Profile
                     ) -> tuple[Plateau, ...]:
    """The Allan analysis of every temperature plateau of one unit, per axis, in the order
    the sequence recorded them (none when the sequence sets fewer than two temperatures)."""
    if len({s.temperature_c for s in steps if s.kind == "set_chamber"}) < 2:
        return ()
    longest: dict[int, tuple[int, SegmentView, float]] = {}
    for v in views:
        set_point = set_point_before(steps, v.step.index)
        if set_point is None or v.temperature_c is None:
            continue
        n = int(v.settled(spec.bias_after_s).sum())
        if v.step.index not in longest or n > longest[v.step.index][0]:
            longest[v.step.index] = (n, v, set_point)
    out = []
    for _, (_, view, set_point) in sorted(longest.items()):
        for axis, column in columns.items():
            plateau = _plateau(view, axis, column, set_point, spec, profile)
            if plateau is not None:
                out.append(plateau)
    return tuple(out)
