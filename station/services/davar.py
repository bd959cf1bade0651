"""``davar``: dynamic Allan deviation of a record, its warm-up time and stationarity verdict."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from analysis.allan import blocks
from analysis.allan.estimators import Missing
from analysis.allan.partial_clusters import MAX_MISSING_SHARE
from analysis.davar.estimators import DavarResult, dynamic_allan_variance, plan_davar
from analysis.davar.long import dynamic_allan_variance_long, group_span
from analysis.davar.warmup import WarmupVerdict, detect_warmup
from analysis.units.conversions import DEG_FAMILY, S_PER_H, UnitFamily
from station.errors import UsageError
from station.evaluation.accel_axes import Quantity, accel_record
from station.model.records import RateRecord
from station.services.records import RecordSource, load_record
from station.storage.scratch import scratch_array


@dataclass(frozen=True)
class DavarRequest:
    """The record, and the DAVAR's windows (s).

    The warm-up is discarded as ``station analyze`` discards it: ``source.warmup_s``, else
    the profile's (given, or the one a run file was recorded with); ``warmup_s=0`` keeps
    the whole record, to see the warm-up the DAVAR finds. Window times and the warm-up
    verdict count from the record's start either way.
    """

    source: RecordSource
    window_s: float
    step_s: float | None = None
    png: Path | None = None
    output_units: UnitFamily = DEG_FAMILY  # of the heat map (deg/h or rad/s)


@dataclass(frozen=True)
class DavarAnswer:
    """The DAVAR of every axis, each axis' warm-up verdict, the heat map written (if asked).

    ``quantity`` says what the axes measure: ``"rate"`` (``record`` in deg/s), or
    ``"acceleration"`` (accelerometer axes asked for alone: ``record`` holds their m/s^2
    in the rate's place, and the DAVAR is in m/s^2)."""

    record: RateRecord
    result: DavarResult
    verdicts: tuple[WarmupVerdict, ...]
    png: Path | None = None
    notes: tuple[str, ...] = field(default=())
    quantity: Quantity = "rate"

    def as_json(self) -> dict[str, object]:
        """``{"axes": [{"name", "quantity", "t_s", "tau_s", "adev_deg_h", "adev_deg_s",
        "adev", "warmup_end_s", "stationary"}]}``: window centres (s), taus (s), ADEV per
        window and tau (null in a window that holds a recorded gap; ``adev`` is
        ``adev_deg_s``, the key older readers know), the verdict. An accelerometer axis
        has ``adev_m_s2`` (m/s^2) in place of the three ADEV keys."""
        axes = []
        for i, (name, verdict) in enumerate(zip(self.record.axis_names, self.verdicts,
                                                strict=True)):
            one = self.result.axis(i)
            adev = [[None if math.isnan(v) else v for v in row] for row in one.adev.tolist()]
            curves: dict[str, object] = {"adev_m_s2": adev}
            if self.quantity == "rate":
                curves = {"adev_deg_h": [[None if v is None else v * S_PER_H for v in row]
                                         for row in adev], "adev_deg_s": adev, "adev": adev}
            axes.append({"name": name, "quantity": self.quantity, "t_s": one.t_s.tolist(),
                         "tau_s": one.tau_s.tolist(), **curves,
                         "warmup_end_s": verdict.warmup_end_s,
                         "stationary": bool(verdict.stationary)})
        return {"axes": axes}


def _davar_of(record: RateRecord, request: DavarRequest) -> DavarResult:
    """The DAVAR of every axis of the record; a long one a group of windows of one axis at
    a time, the angle in a scratch memmap (bounded memory, :mod:`analysis.davar.long`)."""
    missing: Missing = "gap" if record.missing_samples else "raise"
    if not blocks.is_long(record.span_samples):
        return dynamic_allan_variance(record.on_time_grid(), record.sample_rate_hz,
                                      window_s=request.window_s, step_s=request.step_s,
                                      missing=missing)
    plan = plan_davar(record.sample_rate_hz, request.window_s, request.step_s, "log")
    samples = record.rate_deg_s
    if record.sample_index is not None:  # the time grid, NaN in the gaps, an axis a row
        grid = scratch_array((len(record.axis_names), record.span_samples))
        for c in range(len(record.axis_names)):
            record.gridded(c, out=grid[c])
        samples = grid.T
    return dynamic_allan_variance_long(samples, record.sample_rate_hz,
                                       window_s=request.window_s, step_s=request.step_s,
                                       missing=missing,
                                       angle_out=scratch_array((group_span(plan) + 1,)))


def davar(request: DavarRequest) -> DavarAnswer:
    """Read the record, compute its DAVAR and each axis' warm-up verdict, draw the heat map.

    Raises
    ------
    UsageError
        A window longer than the record.
    """
    source = request.source
    loaded = load_record(source)
    record = loaded.record
    quantity: Quantity = "rate"
    notes = loaded.notes
    if not record.axis_names:  # accelerometer axes asked for alone (--axis accel_x)
        accel = accel_record(record)
        if accel is None:
            raise UsageError(f"{source.file}: no axis to compute the DAVAR of")
        record, quantity = accel, "acceleration"
        notes += ("accelerometer axes: the DAVAR is in m/s^2",)
    elif record.accel_axis_names:
        notes += (f"accelerometer axes {', '.join(record.accel_axis_names)} are not in this "
                  f"DAVAR (the rate axes'): --axis {record.accel_axis_names[0]} gives theirs, "
                  f"in m/s^2",)
    if request.window_s * record.sample_rate_hz > record.n_samples:
        raise UsageError(f"--window-s {request.window_s:g} is longer than the record "
                         f"({record.duration_s:g} s)")
    offset = loaded.selection.start_s
    if loaded.selection.warmup_s > 0 and offset == loaded.selection.warmup_s:
        notes += (f"the first {offset:g} s are left out (warm-up from "
                  f"{loaded.selection.warmup_from}); --warmup-s 0 shows the whole record",)
    result = _davar_of(record, request)
    if record.missing_samples:
        broken = int(np.isnan(result.avar).any(axis=(1, 2)).sum())
        notes += (f"{record.missing_samples} samples are missing in gaps; a window missing "
                  f"at most {MAX_MISSING_SHARE:.0%} keeps partial clusters (edf reduced), the "
                  f"{broken} of {len(result.t_s)} windows that miss more are left out (blank "
                  f"on the heat map, null in the JSON)",)
    verdicts = tuple(detect_warmup(result, axis=i) for i in range(len(record.axis_names)))
    if offset > 0:  # times since the record's start, not since the cut
        result = replace(result, t_s=result.t_s + offset)
        verdicts = tuple(
            replace(
                v,
                warmup_end_s=None if v.warmup_end_s is None else v.warmup_end_s + offset,
                window_start_s=v.window_start_s + offset,
            )
            for v in verdicts
        )
    if request.png is not None:
        from station.output.plots import plot_davar  # matplotlib: only for a heat map

        plot_davar(request.png, result, verdicts, record, request.output_units,
                   accel=quantity == "acceleration")
    return DavarAnswer(record, result, verdicts, request.png, notes, quantity)
