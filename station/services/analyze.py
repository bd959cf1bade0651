"""``analyze``: Allan deviation, five-term fit and spec figures of every axis of a record."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

from analysis.allan.deviations import DeviationKind
from analysis.allan.estimators import Estimator
from analysis.fit.least_squares import check_terms
from analysis.gmwm.models import GmwmModel
from analysis.units.conversions import DEG_FAMILY, UnitFamily
from station.errors import UsageError
from station.evaluation.analyze import (
    DEFAULT_METHOD,
    GMWM_METHOD,
    AnalysisMethod,
    AxisAnalysis,
    OutlierPolicy,
    analyze_record,
)
from station.evaluation.resolution import check_not_constant
from station.evaluation.settings import TauGrid
from station.model.records import RateRecord
from station.model.wording import plural
from station.services.progress import Progress, ProgressSink, ignore_progress
from station.services.records import RecordSelection, RecordSource, bench_of, load_record


@dataclass(frozen=True)
class AnalyzeRequest:
    """What to analyse and how.

    Attributes
    ----------
    source : RecordSource
        The record and the part of it.
    estimator : {"overlapping", "clusters"} or None
        Allan variance of the fit and figures (None: overlapping, or clusters when the
        deviation shown is ``adev``).
    deviation : str or None
        The deviation shown and listed (:data:`analysis.allan.deviations.DEVIATION_KINDS`;
        None: the estimator's Allan deviation).
    taus : {"log", "octave", "all"}
        Tau grid.
    method : str
        Fit method (:data:`analysis.fit.FIT_METHODS`), or ``"gmwm"``: the GMWM beside the
        default Allan fit.
    terms : str
        Noise terms to fit, a subset of ``QNBKR``.
    select : bool or None
        logwls: keep only the terms the data resolve (None: the fit's default, on).
    gmwm_model : str
        ``method="gmwm"``: the model (terms joined by ``+``) or ``"auto"`` (WIC ranking).
    robust : bool
        ``method="gmwm"``: the robust wavelet variance.
    outliers : {"auto", "keep", "remove"}
        What to do with isolated spikes.
    bench : str, Path or None
        Bench file whose Earth rate the bias is reported without (run files: default the
        run's bench).
    png : Path or None
        Where to draw the Allan deviation (with ``method="gmwm"``: the wavelet variance).
    csv : Path or None
        Where to write the curve (:mod:`station.output.curve_csv`).
    output_units : UnitFamily
        The unit family of the figure and the curve (deg/h or rad/s).
    """

    source: RecordSource
    estimator: Estimator | None = None
    deviation: DeviationKind | None = None
    taus: TauGrid = "log"
    method: AnalysisMethod = DEFAULT_METHOD
    terms: str = "QNBKR"
    select: bool | None = None
    gmwm_model: str = "auto"
    robust: bool = False
    outliers: OutlierPolicy = "auto"
    bench: str | Path | None = None
    png: Path | None = None
    csv: Path | None = None
    output_units: UnitFamily = DEG_FAMILY


@dataclass(frozen=True)
class AnalyzeResult:
    """Every axis' analysis, the record it came from and the part of it analysed."""

    file: str
    record: RateRecord
    selection: RecordSelection
    axes: tuple[AxisAnalysis, ...]
    notes: tuple[str, ...] = ()
    png: Path | None = None

    def as_json(self) -> dict[str, object]:
        """The ``station analyze --json`` object: ``{"file", "axes", "selection"}``."""
        return {"file": self.file, "axes": [a.as_json() for a in self.axes],
                "selection": asdict(self.selection)}


def accel_png_path(png: Path) -> Path:
    """Where the accelerometers' Allan plot goes beside the rate axes' ``png``:
    ``<stem>_accel.png``."""
    return png.with_name(f"{png.stem}_accel{png.suffix}")


def analyze(request: AnalyzeRequest,
            progress: ProgressSink = ignore_progress) -> AnalyzeResult:
    """Read the selected record and analyse every axis (:func:`analyze_record`); draw the
    figure when ``request.png`` names one. ``progress`` hears of the GMWM's start (the
    long step).

    Raises
    ------
    UsageError
        GMWM options without ``method="gmwm"``, or a GMWM model that does not parse.
    StationError, AnalysisError
        An unreadable record, a bad selection or profile, a record too short, an axis
        that holds one value throughout.
    """
    gmwm = request.method == GMWM_METHOD
    if not gmwm and (request.gmwm_model != "auto" or request.robust):
        raise UsageError("--model and --robust go with --method gmwm")
    if gmwm and request.gmwm_model.strip().lower() != "auto":
        GmwmModel.parse(request.gmwm_model)  # a bad model string fails before the record is read
    check_terms(request.terms)  # a bad --terms fails before the record is read
    loaded = load_record(request.source)
    record = loaded.record
    for i, name in enumerate(record.axis_names):  # one line, before any numpy warning
        check_not_constant(record.rate_deg_s[:, i], f"{record.source or 'record'} axis {name}")
    if gmwm and request.gmwm_model.strip().lower() != "auto":
        from analysis.gmwm.estimator import (  # scipy: only when asked
            check_model_scales,
            gmwm_levels,
        )

        n = record.n_samples  # a model the record's scales cannot identify fails before the fit
        check_model_scales(GmwmModel.parse(request.gmwm_model), gmwm_levels(n), n)
    if gmwm:
        counted = plural(len(record.axis_names), "axis")
        progress(Progress("analyze", f"GMWM ({request.gmwm_model}) of {counted} of "
                                     f"{record.n_samples} samples"))
    estimator = request.estimator or ("clusters" if request.deviation == "adev" else "overlapping")
    bench = bench_of(request.bench, request.source.file)
    axes = analyze_record(
        record,
        estimator=estimator,
        taus=request.taus,
        method=request.method,
        terms=request.terms,
        outliers=request.outliers,
        bench=bench,
        deviation_kind=request.deviation,
        select=request.select,
        gmwm_model=request.gmwm_model,
        robust=request.robust,
    )
    notes = loaded.notes
    if request.png is not None:
        from station.output.plots import (  # matplotlib: only when a plot is asked for
            plot_allan,
            plot_wavelet,
        )

        plot = plot_wavelet if gmwm else plot_allan
        drawn = [a for a in axes if a.accel is None]  # a plot is in one kind's units
        accel = [a for a in axes if a.accel is not None]
        if drawn:
            plot(drawn, request.png, title=str(request.source.file),
                 family=request.output_units)
        if accel:
            png = accel_png_path(request.png) if drawn else request.png
            accel_unit = "m/s^2"
            if request.source.profile is not None:  # in the unit it grades them in
                from station.model.profiles import load_profile
                from station.output.report.panels import accel_plot_unit

                accel_unit = accel_plot_unit(load_profile(request.source.profile))
            plot(accel, png, title=f"{request.source.file}: accelerometers",
                 accel_unit=accel_unit)
            if drawn:
                notes += (f"accelerometer axes are drawn in {accel_unit} in {png}",)
    if request.csv is not None:
        from station.output.curve_csv import write_curve_csv

        write_curve_csv(axes, request.csv, request.output_units)
    return AnalyzeResult(
        str(request.source.file), record, loaded.selection, tuple(axes), notes, request.png
    )
