"""``reconcile``: model versus measurement, axis by axis: the effects the model lacks."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from analysis.discrepancy import ComparisonCache
from analysis.reconcile import ReconcileOptions, ReconcileResult, reconcile
from devices.model_files import load_noise_model
from station.errors import UsageError
from station.model.records import RateRecord
from station.services.progress import Progress, ProgressSink, ignore_progress
from station.storage.runs import open_run

_DEFAULTS = ReconcileOptions()


@dataclass(frozen=True)
class ReconcileRequest:
    """The measured record, the noise model, and the Monte Carlo's settings.

    Attributes
    ----------
    measured : str or Path
        A run file (``.h5``: every unit) or a rate record (CSV).
    model : str
        Noise model TOML file or preset name.
    rate_hz, units
        Sample rate (Hz) and rate unit of a CSV record.
    axis : str or None
        Only this axis (default every axis of every unit).
    runs, seed, alpha, max_samples
        Monte Carlo runs per comparison (>= 4), their seed, the gap test's level, and the
        longest record before decimation (:class:`analysis.reconcile.ReconcileOptions`).
    png : Path or None
        Where to draw the figure.
    """

    measured: str | Path
    model: str
    rate_hz: float | None = None
    units: str = "deg/s"
    axis: str | None = None
    runs: int = _DEFAULTS.runs
    seed: int = _DEFAULTS.seed
    alpha: float = _DEFAULTS.alpha
    max_samples: int = _DEFAULTS.max_samples
    png: Path | None = None


@dataclass(frozen=True)
class ReconcileAnswer:
    """Each axis' reconciliation (label, result), and the figure drawn (if asked)."""

    measured: str
    model: str
    results: tuple[tuple[str, ReconcileResult], ...]
    png: Path | None = None

    def as_json(self) -> dict[str, object]:
        """The ``station reconcile --json`` object: the first axis' result at the top level,
        every axis under ``"axes"``."""
        axes = [{"axis": label, **res.as_json()} for label, res in self.results]
        return {"file": self.measured, **axes[0], "axes": axes}


def _axes(request: ReconcileRequest) -> list[tuple[str, RateRecord]]:
    run_info = open_run(request.measured, sample_rate_hz=request.rate_hz, units=request.units)
    several_units = len(run_info.units) > 1
    out = []
    for unit in run_info.units:
        record = unit.record
        names = [request.axis] if request.axis is not None else list(record.axis_names)
        if request.axis is not None and request.axis not in record.axis_names:
            if several_units:
                continue
            record.select(request.axis)  # raises with the list of axes
        for name in names:
            out.append((f"{unit.unit_id}/{name}" if several_units else name, record.select(name)))
    if not out:
        raise UsageError(f"no axis {request.axis!r} in {request.measured}")
    return out


def reconcile_run(request: ReconcileRequest,
                  progress: ProgressSink = ignore_progress) -> ReconcileAnswer:
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
    options = ReconcileOptions(runs=request.runs, seed=request.seed, alpha=request.alpha,
                               max_samples=request.max_samples)
    cache = ComparisonCache()
    axes = _axes(request)
    results: list[tuple[str, ReconcileResult]] = []
    for i, (label, record) in enumerate(axes):
        lost = (f"; {record.missing_samples} samples missing in gaps: reconcile joins the "
                f"stretches between them" if record.missing_samples else "")
        progress(Progress("reconcile", f"{label} ({record.n_samples} samples{lost})", i, len(axes)))
        res = reconcile(record.rate_deg_s[:, 0], record.sample_rate_hz, model,
                        temperature_c=record.temperature_c, options=options, cache=cache)
        results.append((label, res))
    if request.png is not None:
        from station.output.reconcile_report import plot_reconcile  # matplotlib

        plot_reconcile(results, request.png)
    return ReconcileAnswer(str(request.measured), request.model, tuple(results), request.png)
