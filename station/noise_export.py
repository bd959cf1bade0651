"""``export``: a characterized unit's noise parameters, written in another tool's file format.

One typed request, one function (:func:`export_noise`): the record's axes are analysed
as ``station analyze`` does (:func:`station.analyze.analyze_record`), each axis' figures
are gathered into an :class:`analysis.tool_units.AxisNoise` (:func:`axis_noise`), and the
chosen format (:mod:`station.export_formats`) is written through a temporary file and a
rename, so that a failure leaves no partial file.

Which figure feeds which parameter (the JSON's ``sources`` names it per axis):

* angle random walk N: the five-term fit's N (``logwls``) or the GMWM's white noise
  (``gmwm``), else the IEEE 952 read-off;
* bias instability B: the IEEE 952 read-off ``sigma_min / 0.664`` (the spec figure), or
  the GMWM's flicker term when its model has one; else the fit's B;
* rate random walk K: the fit's K, or the GMWM's random walk; a K the record does not
  resolve (fitted to zero) is written as its 1-sigma upper bound, and the source says so,
  because a filter given no bias random walk at all trusts its bias estimate for ever;
* Gauss-Markov terms: the GMWM's ``gm`` terms (``--method gmwm``), none otherwise.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

from analysis.tool_units import AxisNoise, GaussMarkovBias
from station.analyze import DEFAULT_METHOD, GMWM_METHOD, AxisAnalysis, analyze_record
from station.atomic_files import write_text_atomically
from station.bench import Bench
from station.errors import UsageError
from station.export_formats import FORMATS, ExportContext, render
from station.record_files import RateRecord

#: ``--method`` of ``station export``.
EXPORT_METHODS: tuple[str, ...] = (DEFAULT_METHOD, GMWM_METHOD)


@dataclass(frozen=True)
class ExportRequest:
    """What to export and where.

    Attributes
    ----------
    file : str
        The record or run file (named in the output's header).
    format : str
        One of :data:`station.export_formats.FORMATS`.
    out : Path or None
        Where to write; None: the format's default name in the current folder
        (:func:`default_output`); ``Path("-")``: standard output.
    method : str
        ``logwls`` (the Allan fit and read-offs) or ``gmwm`` (the GMWM's model beside them).
    unit : str or None
        Run files: the unit exported (named in the output).
    rostopic : str
        Kalibr, OpenVINS, allan_variance_ros: the IMU topic written.
    bench : Bench or None
        Latitude and axis directions: the bias is written with the Earth rate removed.
    gmwm_model : str
        ``method="gmwm"``: the model (``"wn+gm+rw"``...) or ``"auto"`` (ranked by the WIC).
    """

    file: str
    format: str
    out: Path | None = None
    method: str = DEFAULT_METHOD
    unit: str | None = None
    rostopic: str = "/imu0"
    bench: Bench | None = None
    gmwm_model: str = "auto"


@dataclass(frozen=True)
class ExportResult:
    """What was written: the per-axis figures, the text, and where it went."""

    format: str
    out: Path | None
    axes: tuple[AxisNoise, ...]
    text: str
    notes: tuple[str, ...] = ()

    def as_json(self) -> dict[str, object]:
        """``{"format", "out", "axes": [AxisNoise.as_json()...], "notes"}`` (``station export --json``)."""
        return {"format": self.format, "out": None if self.out is None else str(self.out),
                "axes": [a.as_json() for a in self.axes], "notes": list(self.notes)}


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


def _positive(value: float | None) -> bool:
    return value is not None and math.isfinite(value) and value > 0


def _rrw(value: float | None, stderr: float | None, what: str) -> tuple[float, str]:
    """(K, its source) from a fitted value and its standard error."""
    if _positive(value):
        return float(value), what  # type: ignore[arg-type]
    if _positive(stderr):
        return float(stderr), f"{what}: upper bound (1 sigma), the record does not resolve K"  # type: ignore[arg-type]
    return 0.0, f"{what}: none found and no bound"


def axis_noise(axis: AxisAnalysis, method: str = DEFAULT_METHOD) -> AxisNoise:
    """The noise parameters of one analysed axis (the module docstring says which figure
    feeds which).

    Raises
    ------
    UsageError
        ``method="gmwm"`` on an analysis without a GMWM, or no angle random walk at all.
    """
    fit, fig = axis.fit, axis.figures
    n_fit = fit.values.get("N")
    arw, arw_from = (n_fit, f"fit ({fit.method})") if _positive(n_fit) else (fig.arw_deg_rt_h, "read-off")
    b, b_from = fig.bias_instability_deg_h, "read-off (sigma_min / 0.664)"
    if not _positive(b):
        b, b_from = (fit.values.get("B"), f"fit ({fit.method})") if _positive(fit.values.get("B")) else (None, "none")
    k, k_from = _rrw(fit.values.get("K"), fit.stderr.get("K"), f"fit ({fit.method})")
    gauss_markov: list[GaussMarkovBias] = []
    if method == GMWM_METHOD:
        if axis.gmwm is None:
            raise UsageError(f"axis {axis.name}: no GMWM in this analysis (analyze with method gmwm)")
        best = axis.gmwm.best
        values, errors = best.values, best.stderr
        model = f"GMWM ({best.model.name})"
        if _positive(values.get("wn_deg_rt_h")):
            arw, arw_from = values["wn_deg_rt_h"], model
        if _positive(values.get("bi_deg_h")):
            b, b_from = values["bi_deg_h"], model
        if "rw_deg_h_rt_h" in values:
            k, k_from = _rrw(values.get("rw_deg_h_rt_h"), errors.get("rw_deg_h_rt_h"), model)
        for key, sigma in values.items():
            if key.startswith("gm") and key.endswith("_sigma_deg_h") and _positive(sigma):
                tau = values[key.removesuffix("_sigma_deg_h") + "_tau_s"]
                gauss_markov.append(GaussMarkovBias(float(sigma), float(tau)))
    if not _positive(arw):
        raise UsageError(f"axis {axis.name}: no angle random walk found (neither fit nor read-off): "
                         f"record longer or at a higher rate")
    gauss_markov.sort(key=lambda g: g.tau_s)
    return AxisNoise(name=axis.name, sample_rate_hz=axis.sample_rate_hz, arw_deg_rt_h=float(arw),  # type: ignore[arg-type]
                     bias_instability_deg_h=None if b is None else float(b), rrw_deg_h_1_5=k,
                     bias_deg_h=fig.bias_deg_h, gauss_markov=tuple(gauss_markov),
                     sources={"arw": arw_from, "bias_instability": b_from, "rrw": k_from})


def export_noise(record: RateRecord, request: ExportRequest) -> ExportResult:
    """Analyse ``record`` and write its noise parameters in ``request.format``.

    Raises
    ------
    UsageError
        An unknown format or method, a record whose axes the format cannot hold, an
        output that cannot be written.
    AnalysisError
        A record too short to analyse.
    """
    if request.format not in FORMATS:
        raise UsageError(f"unknown format {request.format!r}: one of {', '.join(FORMATS)}")
    if request.method not in EXPORT_METHODS:
        raise UsageError(f"unknown method {request.method!r}: one of {', '.join(EXPORT_METHODS)}")
    FORMATS[request.format].check_axes(len(record.axis_names), record.axis_names)
    if request.method != GMWM_METHOD and request.gmwm_model != "auto":
        raise UsageError("--model goes with --method gmwm")
    analyses = analyze_record(record, method=request.method, bench=request.bench,
                              gmwm_model=request.gmwm_model)
    axes = tuple(axis_noise(a, request.method) for a in analyses)
    earth = [a.figures.earth_rate_removed_deg_h is not None for a in analyses]
    context = ExportContext(source=request.file, unit=request.unit, method=request.method,
                            rostopic=request.rostopic, earth_rate_removed=all(earth))
    out = request.out if request.out is not None else default_output(request.file, request.format, request.unit)
    text = render(request.format, axes, context, suffix=out.suffix)
    notes = [f"{a.name}: rate random walk is {a.sources['rrw'].split(': ', 1)[1]}"
             for a in axes if a.sources and "upper bound" in a.sources["rrw"]]
    if request.format == "gnss-ins-sim" and not any(a.gauss_markov for a in axes):
        notes.append("no Gauss-Markov term (--method gmwm finds one where the record shows it): "
                     "gnss-ins-sim draws gyro_b_stability as white noise without gyro_b_corr")
    if str(out) == "-":
        return ExportResult(request.format, None, axes, text, tuple(notes))
    write_text_atomically(out, text)
    return ExportResult(request.format, out, axes, text, tuple(notes))
