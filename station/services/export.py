"""``export``: a characterized unit's noise parameters, written in another tool's file format.

One typed request, one function (:func:`export_noise`): the selected record is read
(:func:`station.services.records.load_record`), its axes are analysed as ``station
analyze`` does (:func:`station.evaluation.analyze.analyze_record`), each axis' figures are
gathered into an :class:`analysis.figures.tool_units.AxisNoise`
(:func:`station.evaluation.noise_parameters.axis_noise`, whose docstring says which figure
feeds which parameter), and the chosen format (:mod:`station.output.export_formats`) is
written through a temporary file and a rename, so that a failure leaves no partial file.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import cast

from analysis.figures.tool_units import AxisNoise
from analysis.figures.tool_units_accel import AccelNoise
from station.errors import UsageError
from station.evaluation.analyze import (
    DEFAULT_METHOD,
    GMWM_METHOD,
    AnalysisMethod,
    analyze_record,
)
from station.evaluation.noise_parameters import EXPORT_METHODS, axis_noise
from station.model.bench import Bench
from station.model.records import RateRecord
from station.model.wording import plural
from station.output.export_formats import (
    FORMATS,
    ExportContext,
    check_export_axes,
    fewer_axes_note,
    render,
)
from station.services.progress import Progress, ProgressSink, ignore_progress
from station.services.records import RecordSource, bench_of, load_record
from station.storage.atomic_files import write_text_atomically

#: The formats whose tool applies one gyroscope value to all three axes, by tool name.
THREE_AXIS_TOOLS = {"kalibr": "Kalibr", "openvins": "OpenVINS",
                    "allan-variance-ros": "allan_variance_ros"}


@dataclass(frozen=True)
class ExportRequest:
    """What to export and where.

    Attributes
    ----------
    source : RecordSource
        The record or run file, the unit, the part of it (``--unit``, ``--start-s``, ...).
    format : str
        One of :data:`station.output.export_formats.FORMATS`.
    out : Path or None
        Where to write; None: the format's default name in the current folder
        (:func:`default_output`); ``Path("-")``: nowhere (the text is in the result).
    method : str
        ``logwls`` (the Allan fit and read-offs) or ``gmwm`` (the GMWM's model beside them).
    gmwm_model : str
        ``method="gmwm"``: the model (``"wn+gm+rw"``...) or ``"auto"`` (ranked by the WIC).
    rostopic : str
        Kalibr, OpenVINS, allan_variance_ros: the IMU topic written.
    bench : str, Path or None
        Bench file whose Earth rate the bias is written without (run files: default the
        run's bench).
    """

    source: RecordSource
    format: str
    out: Path | None = None
    method: str = DEFAULT_METHOD
    gmwm_model: str = "auto"
    rostopic: str = "/imu0"
    bench: str | Path | None = None


@dataclass(frozen=True)
class ExportResult:
    """What was written: the per-axis figures, the text, and where it went."""

    format: str
    out: Path | None
    axes: tuple[AxisNoise, ...]
    text: str
    notes: tuple[str, ...] = ()
    accel: tuple[AccelNoise, ...] = ()

    def as_json(self) -> dict[str, object]:
        """``{"format", "out", "axes": [AxisNoise.as_json()...], "notes"}``
        (``station export --json``)."""
        return {
            "format": self.format,
            "out": None if self.out is None else str(self.out),
            "axes": [a.as_json() for a in self.axes],
            "accel_axes": [a.as_json() for a in self.accel],
            "notes": list(self.notes),
        }


def default_output(file: str, fmt: str, unit: str | None = None) -> Path:
    """``<record stem>[_<unit>]_<format's file name>`` in the current folder."""
    name = Path(file).name
    for suffix in (".gz", ".csv", ".h5", ".hdf5"):
        name = name.removesuffix(suffix)
    spec = FORMATS[fmt]
    name = f"{name}{'_' + unit if unit else ''}_{spec.default_name}"
    if spec.identifier_name:  # a MATLAB script or Python module is called by its name
        stem, dot, ext = name.rpartition(".")
        stem = re.sub(r"\W", "_", stem, flags=re.ASCII)
        name = ("g_" if not stem[:1].isalpha() else "") + stem + dot + ext
    return Path(name)


def export_noise(request: ExportRequest, progress: ProgressSink = ignore_progress) -> ExportResult:
    """Read the selected record, analyse it and write its noise parameters in ``request.format``.

    ``progress`` hears when the analysis starts (the long step).

    Raises
    ------
    UsageError
        An unknown format or method, GMWM options without the GMWM, a record whose axes
        the format cannot hold, an output that cannot be written.
    StationError, AnalysisError
        An unreadable record, a bad selection, a record too short to analyse.
    """
    if request.format not in FORMATS:
        raise UsageError(f"unknown format {request.format!r}: one of {', '.join(FORMATS)}")
    if request.method not in EXPORT_METHODS:
        raise UsageError(f"unknown method {request.method!r}: one of {', '.join(EXPORT_METHODS)}")
    if request.method != GMWM_METHOD and request.gmwm_model != "auto":
        raise UsageError("--model goes with --method gmwm")
    loaded = load_record(request.source)
    record = loaded.record
    check_export_axes(request.format, record.axis_names, bool(record.accel_axis_names))
    progress(
        Progress(
            "export",
            f"{request.method} analysis of {plural(len(record.axis_names), 'axis')} "
            f"of {record.n_samples} samples",
        )
    )
    exported = noise_of(
        record, request.method, request.gmwm_model, bench_of(request.bench, request.source.file)
    )
    axes = [a for a in exported if a.accel is None]
    accel = tuple(a.accel for a in exported if a.accel is not None)
    earth_removed = all(a.earth_rate_removed for a in axes)
    file, unit = str(request.source.file), request.source.unit
    context = ExportContext(
        source=file,
        unit=unit,
        method=request.method,
        rostopic=request.rostopic,
        earth_rate_removed=earth_removed,
        accel=accel,
    )
    out = request.out if request.out is not None else default_output(file, request.format, unit)
    text = render(request.format, [a.noise for a in axes], context, suffix=out.suffix)
    notes = list(loaded.notes)
    if request.format in THREE_AXIS_TOOLS:
        notes += [t for t in (fewer_axes_note(THREE_AXIS_TOOLS[request.format],
                                              [a.noise for a in axes]),) if t]
    notes += [
        f"{a.noise.name}: rate random walk is {a.noise.sources['rrw'].split(': ', 1)[1]}"
        for a in axes
        if a.noise.sources and "upper bound" in a.noise.sources["rrw"]
    ]
    notes += [f"{a.name}: {', '.join(a.upper_bounds)} written as an upper bound the record "
              f"sets, not a measurement (marked UPPER BOUND in the file)"
              for a in accel if a.upper_bounds]
    if request.format == "gnss-ins-sim" and not any(a.noise.gauss_markov for a in axes):
        notes.append(
            "no Gauss-Markov term (--method gmwm finds one where the record shows it): "
            "gnss-ins-sim draws gyro_b_stability as white noise without gyro_b_corr"
        )
    noise = tuple(a.noise for a in axes)
    if str(out) == "-":
        return ExportResult(request.format, None, noise, text, tuple(notes), accel)
    write_text_atomically(out, text)
    return ExportResult(request.format, out, noise, text, tuple(notes), accel)


@dataclass(frozen=True)
class _Exported:
    noise: AxisNoise
    earth_rate_removed: bool
    #: The accelerometer figures of an accelerometer axis (None: a rate axis).
    accel: AccelNoise | None = None


def noise_of(
    record: RateRecord,
    method: str = DEFAULT_METHOD,
    gmwm_model: str = "auto",
    bench: Bench | None = None,
) -> list[_Exported]:
    """Each axis' noise parameters (``method``: ``logwls`` or ``gmwm``) and whether its bias
    has the Earth rate removed."""
    analyses = analyze_record(record, method=cast(AnalysisMethod, method), bench=bench,
                              gmwm_model=gmwm_model)
    return [
        _Exported(axis_noise(a, method), a.figures.earth_rate_removed_deg_h is not None)
        if a.accel is None else
        _Exported(axis_noise(a, method), True,
                  AccelNoise.of_series(axis_noise(a, method), a.accel.accel_bias_mg))
        for a in analyses
    ]
