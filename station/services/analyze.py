"""``analyze``: Allan deviation, five-term fit and spec figures of every axis of a record."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

from analysis.allan import Estimator
from analysis.deviations import DeviationKind
from analysis.fit import FitMethod
from station.evaluation.analyze import DEFAULT_METHOD, AxisAnalysis, OutlierPolicy, analyze_record
from station.evaluation.settings import TauGrid
from station.model.records import RateRecord
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
        The deviation shown and listed (:data:`analysis.deviations.DEVIATION_KINDS`;
        None: the estimator's Allan deviation).
    taus : {"log", "octave", "all"}
        Tau grid.
    method : str
        Fit method (:data:`analysis.fit.FIT_METHODS`).
    terms : str
        Noise terms to fit, a subset of ``QNBKR``.
    outliers : {"auto", "keep", "remove"}
        What to do with isolated spikes.
    bench : str, Path or None
        Bench file whose Earth rate the bias is reported without (run files: default the
        run's bench).
    """

    source: RecordSource
    estimator: Estimator | None = None
    deviation: DeviationKind | None = None
    taus: TauGrid = "log"
    method: FitMethod = DEFAULT_METHOD
    terms: str = "QNBKR"
    outliers: OutlierPolicy = "auto"
    bench: str | Path | None = None


@dataclass(frozen=True)
class AnalyzeResult:
    """Every axis' analysis, the record it came from and the part of it analysed."""

    file: str
    record: RateRecord
    selection: RecordSelection
    axes: tuple[AxisAnalysis, ...]
    notes: tuple[str, ...] = ()

    def as_json(self) -> dict[str, object]:
        """The ``station analyze --json`` object: ``{"file", "axes", "selection"}``."""
        return {"file": self.file, "axes": [a.as_json() for a in self.axes],
                "selection": asdict(self.selection)}


def analyze(request: AnalyzeRequest) -> AnalyzeResult:
    """Read the selected record and analyse every axis (:func:`analyze_record`).

    Raises
    ------
    StationError, AnalysisError
        An unreadable record, a bad selection or profile, a record too short.
    """
    loaded = load_record(request.source)
    estimator = request.estimator or ("clusters" if request.deviation == "adev" else "overlapping")
    bench = bench_of(request.bench, request.source.file)
    axes = analyze_record(loaded.record, estimator=estimator, taus=request.taus,
                          method=request.method, terms=request.terms,
                          outliers=request.outliers, bench=bench,
                          deviation_kind=request.deviation)
    return AnalyzeResult(str(request.source.file), loaded.record, loaded.selection, tuple(axes),
                         loaded.notes)
