"""``reconcile``: model versus measurement, axis by axis: the effects the model lacks."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from analysis.reconcile.discrepancy import ComparisonCache
from analysis.reconcile.loop import ReconcileOptions, ReconcileResult, reconcile
from analysis.units.conversions import DEG_FAMILY, UnitFamily
from devices.model_files import load_noise_model
from station.errors import UsageError
from station.model.records import RateRecord
from station.services.progress import Progress, ProgressSink, ignore_progress
from station.services.records import RecordSource, cut_record
from station.storage.runs import open_run

_DEFAULTS = ReconcileOptions()


@dataclass(frozen=True)
class ReconcileRequest:
    """The measured record, the noise model, and the Monte Carlo's settings.

    Attributes
    ----------
    source : RecordSource
        The measured record: a run file (``.h5``: every unit, or only ``source.unit``) or a
        rate record (CSV); every axis, or only ``source.axis``; the time slice and the
        warm-up discarded as ``station analyze`` takes them (run files default to the
        warm-up of the profile they were recorded with).
    model : str
        Noise model TOML file or preset name.
    runs, seed, alpha, max_samples
        Monte Carlo runs per comparison (>= 4), their seed, the gap test's level, and the
        longest record before decimation (:class:`analysis.reconcile.ReconcileOptions`).
    png : Path or None
        Where to draw the figure.
    output_units : UnitFamily
        The unit family of the figure (Allan deviation in deg/h or rad/s).
    """

    source: RecordSource
    model: str
    runs: int = _DEFAULTS.runs
    seed: int = _DEFAULTS.seed
    alpha: float = _DEFAULTS.alpha
    max_samples: int = _DEFAULTS.max_samples
    png: Path | None = None
    output_units: UnitFamily = DEG_FAMILY


@dataclass(frozen=True)
class ReconcileAnswer:
    """Each axis' reconciliation (label, result), and the figure drawn (if asked)."""

    measured: str
    model: str
    results: tuple[tuple[str, ReconcileResult], ...]
    png: Path | None = None
    notes: tuple[str, ...] = ()

    def as_json(self) -> dict[str, object]:
        """The ``station reconcile --json`` object: the first axis' result at the top level,
        every axis under ``"axes"``."""
        axes = [{"axis": label, **res.as_json()} for label, res in self.results]
        return {"file": self.measured, **axes[0], "axes": axes}


def _axes(request: ReconcileRequest) -> tuple[list[tuple[str, RateRecord]], tuple[str, ...]]:
    """(label and one-axis record of each axis reconciled, notes for the operator)."""
    source = request.source
    run_info = open_run(source.file, sample_rate_hz=source.rate_hz, units=source.units,
                        accel_units=source.accel_units)
    units = run_info.units
    if source.unit is not None:
        units = tuple(u for u in units if source.unit in (u.unit_id, u.serial_number))
        if not units:
            raise UsageError(f"{source.file}: no unit {source.unit!r}; units: "
                             f"{', '.join(u.unit_id for u in run_info.units)}")
    several_units = len(units) > 1
    out, notes = [], []
    for unit in units:
        record = unit.record
        names = [source.axis] if source.axis is not None else list(record.axis_names)
        if source.axis is not None and source.axis not in record.axis_names:
            if source.axis in record.accel_axis_names:
                raise UsageError(
                    f"accelerometer axis {source.axis!r}: reconcile compares a rate axis with "
                    f"a gyro noise model; give a rate axis ({', '.join(record.axis_names)}), "
                    f"or station analyze --axis {source.axis} for its Allan curve in m/s^2")
            if several_units:
                continue
            record.select(source.axis)  # raises with the list of axes
        loaded = cut_record(record, source)
        notes += [n for n in loaded.notes if n not in notes]
        if loaded.selection.start_s > 0 or loaded.selection.stop_s is not None:
            note = (
                f"reconciled {loaded.selection.start_s:g} s .. "
                f"{'end' if loaded.selection.stop_s is None else f'{loaded.selection.stop_s:g} s'}"
                f" (warm-up {loaded.selection.warmup_s:g} s from {loaded.selection.warmup_from})"
            )
            if note not in notes:
                notes.append(note)
        for name in names:
            label = f"{unit.unit_id}/{name}" if several_units else name
            out.append((label, loaded.record.select(name)))
    if not out:
        raise UsageError(f"no axis {source.axis!r} in {source.file}")
    return out, tuple(notes)


def reconcile_run(
    request: ReconcileRequest, progress: ProgressSink = ignore_progress
) -> ReconcileAnswer:
    """Reconcile each axis with the model (:func:`analysis.reconcile.reconcile`); draw the figure.

    ``progress`` hears of each axis as it starts.

    Raises
    ------
    UsageError
        Fewer than 4 runs, or no such axis.
    """
    if request.runs < 4:
        raise UsageError(f"--runs must be at least 4, got {request.runs}")
    model = load_noise_model(request.model)
    options = ReconcileOptions(
        runs=request.runs, seed=request.seed, alpha=request.alpha, max_samples=request.max_samples
    )
    cache = ComparisonCache()
    axes, notes = _axes(request)
    results: list[tuple[str, ReconcileResult]] = []
    for i, (label, record) in enumerate(axes):
        lost = (
            f"; {record.missing_samples} samples missing in gaps: reconcile joins the "
            f"stretches between them"
            if record.missing_samples
            else ""
        )
        progress(Progress("reconcile", f"{label} ({record.n_samples} samples{lost})", i, len(axes)))
        res = reconcile(
            record.rate_deg_s[:, 0],
            record.sample_rate_hz,
            model,
            temperature_c=record.temperature_c,
            options=options,
            cache=cache,
        )
        results.append((label, res))
    if request.png is not None:
        from station.output.reconcile_report import plot_reconcile  # matplotlib

        plot_reconcile(results, request.png, family=request.output_units)
    return ReconcileAnswer(str(request.source.file), request.model, tuple(results), request.png,
                           notes)
