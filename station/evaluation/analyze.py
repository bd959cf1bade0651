"""Analysis of a rate record, axis by axis: Allan variance, five-term fit, spec figures.

This composes :mod:`analysis` for the ``station analyze`` command, the demo and reports;
it is what tests call directly.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from analysis.allan import blocks
from analysis.allan.deviations import (
    DEVIATION_LABELS,
    DeviationKind,
    deviation,
)
from analysis.allan.estimators import (
    AllanResult,
    Estimator,
    analysis_log_m,
    cluster_allan_variance,
    overlapping_allan_variance,
)
from analysis.allan.gaps import gap_allan_variance, gap_summary_of_index
from analysis.allan.outliers import (
    SpikeDetection,
    detect_spikes,
    min_samples,
    replace_flagged,
    replace_spikes,
)
from analysis.allan.partial_clusters import MAX_MISSING_SHARE, partial_allan_variance
from analysis.allan.variance import allan_variance
from analysis.figures.ambiguity import resolve_for_rate
from analysis.figures.spec import spec_figures
from analysis.figures.tones import find_tones
from analysis.figures.zones import fit_outside_zones
from analysis.fit.least_squares import FitMethod
from analysis.gmwm.selection import gmwm_analysis
from analysis.units.conversions import DEG_FAMILY, S_PER_H, UnitFamily, family_unit_of_key
from station.errors import UsageError
from station.evaluation.accel_axes import analyze_accel, format_accel_table
from station.evaluation.analysis_options import (
    DEFAULT_METHOD as DEFAULT_METHOD,
    GMWM_METHOD as GMWM_METHOD,
    OUTLIER_POLICIES as OUTLIER_POLICIES,
    AnalysisMethod as AnalysisMethod,
    OutlierPolicy as OutlierPolicy,
)
from station.evaluation.axis_analysis import (
    SPIKES_LISTED as SPIKES_LISTED,
    AxisAnalysis as AxisAnalysis,
    GapReport as GapReport,
    OutlierReport as OutlierReport,
    Quantity as Quantity,
)
from station.evaluation.long_records import angle_buffer, return_freed_heap
from station.model.bench import Bench, earth_rate_note
from station.model.records import RateRecord
from station.storage.scratch import scratch_array


def _spikes(x: NDArray[np.float64], positions: NDArray[np.int64] | None, fs: float,
            policy: OutlierPolicy, quantity: Quantity = "rate"
            ) -> tuple[NDArray[np.float64], OutlierReport]:
    """(the present samples to analyse, the report) of one axis under ``policy``."""
    if policy not in OUTLIER_POLICIES:
        raise ValueError(
            f"outlier policy must be one of {', '.join(OUTLIER_POLICIES)}, got {policy!r}"
        )
    if len(x) < min_samples():
        return x, OutlierReport(
            rule=f"not looked for: {len(x)} samples, fewer than {min_samples()}",
            quantity=quantity,
        )
    detection = detect_spikes(x)
    times = tuple(
        float(sp.index if positions is None else positions[sp.index]) / fs
        for sp in detection.spikes
    )
    remove = detection.count > 0 and (
        policy == "remove" or (policy == "auto" and detection.removable)
    )
    rule = detection.rule_text()
    if detection.count and policy != "auto":
        rule += f" (--outliers {policy})"
    report = OutlierReport(detection, remove, rule, times, quantity)
    return (_replaced(x, detection, positions) if remove else x), report


def _replaced(x: NDArray[np.float64], detection: SpikeDetection,
              positions: NDArray[np.int64] | None) -> NDArray[np.float64]:
    """``x`` with the detected spikes replaced (into a scratch memmap when ``x`` is long)."""
    if blocks.is_long(len(x)):
        return replace_flagged(x, detection.flagged, positions, out=scratch_array((len(x),)))
    return replace_spikes(x, detection.flags, np.arange(len(x)) if positions is None else positions)


def _allan(grid_rate: NDArray[np.float64], fs: float, gapped: bool, estimator: Estimator,
           taus: str | np.ndarray, present: int) -> AllanResult:
    """The Allan variance of one axis on its time grid (``present`` samples not NaN)."""
    if blocks.is_long(len(grid_rate)) and not (gapped and estimator == "clusters"):
        # a long record: its angle in a scratch memmap, read a block at a time (the cluster
        # estimator of a record with gaps needs every sample's grid position: in memory)
        angle = scratch_array((present + 1, 1))
        if gapped:
            return gap_allan_variance(grid_rate, fs, taus=taus, angle_out=angle)
        if estimator == "clusters":
            return cluster_allan_variance(grid_rate, fs, taus=taus, angle_out=angle)
        return overlapping_allan_variance(grid_rate, fs, taus=taus, angle_out=angle)
    if gapped:  # short gaps: partial clusters kept (analysis.allan.partial_clusters)
        return partial_allan_variance(grid_rate, fs, estimator=estimator, taus=taus)
    return allan_variance(grid_rate, fs, estimator=estimator, taus=taus)


def _minus(x: NDArray[np.float64], offset: float) -> NDArray[np.float64]:
    """``x - offset`` (into a scratch memmap when ``x`` is long)."""
    if not blocks.is_long(len(x)):
        return x - offset
    out = scratch_array((len(x),))
    for a, b in blocks.spans(0, len(x)):
        np.subtract(x[a:b], offset, out=out[a:b])
        blocks.release(x)
        blocks.release(out)
    return out


def _on_grid(record: RateRecord, x: NDArray[np.float64]) -> NDArray[np.float64]:
    """``x`` (one axis' present samples) on the record's time grid, NaN in the gaps (in a
    scratch memmap, a block at a time, when the record is long)."""
    if record.sample_index is None:
        return x
    if not blocks.is_long(record.span_samples):
        out = np.full(record.span_samples, np.nan)
        out[record.sample_index] = x
        return out
    column = RateRecord(x[:, None], record.sample_rate_hz, ("x",), sample_index=record.sample_index)
    return column.gridded(0, out=scratch_array((record.span_samples,)))


def analyze_record(record: RateRecord, *, bench: Bench | None = None,
                   **options: Any) -> list[AxisAnalysis]:
    """Every rate axis of ``record`` (:func:`analyze_rates`), then its accelerometer axes
    through the same analysis in m/s^2 (:func:`station.evaluation.accel_axes.analyze_accel`:
    no Earth rate; gravity off the bias). ``options`` are :func:`analyze_rates`'."""
    rates = analyze_rates(record, bench=bench, **options) if record.axis_names else []
    return rates + analyze_accel(record, bench,
                                 lambda accel: analyze_rates(accel, bench=None,
                                                             quantity="acceleration", **options))


def analyze_rates(
    record: RateRecord,
    *,
    estimator: Estimator = "overlapping",
    taus: str | np.ndarray = "log",
    method: AnalysisMethod = DEFAULT_METHOD,
    terms: str = "QNBKR",
    outliers: OutlierPolicy = "auto",
    bench: Bench | None = None,
    deviation_kind: DeviationKind | None = None,
    select: bool | None = None,
    gmwm_model: str = "auto",
    robust: bool = False,
    quantity: Quantity = "rate",
) -> list[AxisAnalysis]:
    """Allan variance, tones, fit and spec figures of every axis of ``record`` (rates in deg/s;
    with ``quantity="acceleration"``, accelerations in m/s^2: the spikes are said in m/s^2).

    ``method="gmwm"`` adds the GMWM (``gmwm_model``: a model string or ``"auto"``
    selection; ``robust``: the robust wavelet variance) beside the default Allan fit, on
    the same samples (spikes removed as the rule says, no Haar window across a gap).

    Samples missing in gaps (``record.sample_index``) stay missing: an Allan cluster or a
    bias-stability average is kept when at most a tenth of it is missing, as the mean of
    its present samples with its edf reduced (:mod:`analysis.allan.partial_clusters`; a long
    record, over :data:`analysis.allan.blocks.LONG_SAMPLES`, keeps only averages that straddle no
    gap, :mod:`analysis.allan.gaps`). Isolated spikes
    are looked for on every axis and removed under ``outliers`` (:mod:`analysis.allan.outliers`).
    The bias is reported with the Earth-rate projection of ``bench`` removed when it
    gives the axis' latitude and direction. Tones are looked for in every axis
    (:mod:`analysis.figures.tones`); the fit and the read-offs leave out the tau zones a tone or an
    output filter distorts (:func:`analysis.figures.zones.fit_outside_zones`).

    ``taus="log"`` is :func:`analysis.allan.analysis_log_m` (eq. 20's spacing continued to
    the longest tau with two clusters; a record with gaps keeps the gap-aware estimator's
    own grid). ``deviation_kind`` picks the curve shown (default: the Allan deviation of
    ``estimator``); the fit and the figures stay on the Allan variance. ``select`` is
    :func:`analysis.fit.fit_noise_terms`' (default: on for logwls).

    Raises
    ------
    UsageError
        A deviation other than the Allan ones on a record with gaps (only the Allan
        estimators skip gaps).
    """
    fs = record.sample_rate_hz
    use_gmwm = method == GMWM_METHOD
    allan_method: FitMethod = DEFAULT_METHOD if method == GMWM_METHOD else method
    gapped = record.sample_index is not None
    asked = taus
    if isinstance(taus, str) and taus == "log" and not gapped:
        taus = analysis_log_m(record.n_samples) / fs
    own = "oadev" if estimator == "overlapping" else "adev"
    if deviation_kind not in (None, own, "oadev", "adev") and gapped:
        raise UsageError(
            f"the {DEVIATION_LABELS[deviation_kind]} of a record with gaps is not computed "
            f"(only the Allan deviations skip gaps); analyze a gap-free stretch with "
            f"--start-s/--stop-s"
        )
    gaps = GapReport()  # a record without gaps (no mask as long as the record)
    if record.sample_index is not None:
        summary = gap_summary_of_index(record.sample_index)
        gaps = GapReport(summary.count, summary.missing_samples / fs, summary.share)
    long = blocks.is_long(record.n_samples)
    earth = (bench or Bench()).earth_rate_deg_h(record.axis_names)
    cleaned, reports = [], []
    for i in range(len(record.axis_names)):
        x, report = _spikes(record.rate_deg_s[:, i], record.sample_index, fs, outliers,
                            quantity)
        cleaned.append(x)
        reports.append(report)
    joint = None
    if not gapped and not long and not any(r.removed for r in reports):
        joint = allan_variance(record.rate_deg_s, fs, estimator=estimator, taus=taus)
    out = []
    for i, name in enumerate(record.axis_names):
        grid_rate = _on_grid(record, cleaned[i])
        axis = (joint.axis(i) if joint is not None
                else _allan(grid_rate, fs, gapped, estimator, taus, record.n_samples))
        if long:  # the compiled kernels are loaded: the compiler's pages can go
            return_freed_heap()
        alternative, label = None, ""
        if reports[i].count:
            detection = reports[i].detection
            assert detection is not None
            other = (record.rate_deg_s[:, i] if reports[i].removed
                     else _replaced(record.rate_deg_s[:, i], detection, record.sample_index))
            alternative = _allan(_on_grid(record, other), fs, gapped, estimator, taus,
                                 record.n_samples)
            label = "spikes kept" if reports[i].removed else "spikes removed"
        tones = find_tones(grid_rate, fs)
        fit, zones = fit_outside_zones(axis, tones, method=allan_method, terms=terms,
                                       select=select)
        fit = resolve_for_rate(axis, fit, grid_rate, fs, gaps=gapped,
                               exclude_tau_s=tuple((z.tau_low_s, z.tau_high_s) for z in zones),
                               angle_out=angle_buffer(grid_rate))
        earth_deg_h = earth[i]
        analysed = grid_rate if earth_deg_h is None else _minus(grid_rate, earth_deg_h / S_PER_H)
        figures = spec_figures(analysed, fs, axis, fit, zones=zones)
        notes = [earth_rate_note(bench, name, earth[i])]
        if gaps.count:
            rule = ("no Allan difference or average straddles a gap"
                    if blocks.is_long(record.span_samples) else
                    f"an Allan cluster or average is kept when at most {MAX_MISSING_SHARE:.0%} "
                    f"of it is missing (mean of its present samples, edf reduced)")
            notes.append(f"gaps: {gaps.text()} missing; {rule}, tau is true time")
        if reports[i].count:
            notes.append(f"spikes: {reports[i].note()}")
        figures = replace(figures, earth_rate_removed_deg_h=earth[i],
                          notes=figures.notes + tuple(notes))
        curve = None
        if deviation_kind is not None and deviation_kind != own:
            curve = deviation(cleaned[i], fs, kind=deviation_kind, taus=asked,
                              angle_out=angle_buffer(cleaned[i]))
        if long and use_gmwm:  # the GMWM starts from what is in use
            return_freed_heap()
        gm = (gmwm_analysis(grid_rate, fs, model=gmwm_model, robust=robust, gaps=gapped,
                            angle_out=angle_buffer(grid_rate)) if use_gmwm else None)
        out.append(AxisAnalysis(name, fs, record.n_samples, axis, fit, figures, gaps, reports[i],
                                analysed, alternative, label, tones, zones, curve, gm))
        if long:
            return_freed_heap()
    return out


def _fmt(value: float | None, stderr: float | None = None) -> str:
    if value is None:
        return "-"
    text = f"{value:.4g}"
    if stderr is not None:
        text += f" +- {stderr:.2g}"
    return text


def _interval(ci: tuple[float | None, float | None] | None) -> str:
    if ci is None or ci[0] is None or ci[1] is None:
        return "-"
    return f"[{ci[0]:.4g}, {ci[1]:.4g}]"


def _in(family: UnitFamily, ci: tuple[float | None, float | None] | None,
        unit: str) -> tuple[float | None, float | None] | None:
    """An interval in ``unit`` (deg family) in ``family``."""
    return None if ci is None else (family.value(ci[0], unit), family.value(ci[1], unit))


def _range(taus: tuple[float | None, float | None]) -> str:
    return "-" if taus[0] is None else f"{taus[0]:.3g}-{taus[1]:.3g}"


def format_analysis(axes: list[AxisAnalysis], family: UnitFamily = DEG_FAMILY) -> str:
    """A plain-text table of the figures of every axis, units (of ``family``) in the first
    column; accelerometer axes in a table of their own (SI, ``format_accel_table``)."""
    accel = [a for a in axes if a.accel is not None]
    axes = [a for a in axes if a.accel is None]
    if not axes:
        return format_accel_table(accel)
    if accel:
        return format_analysis(axes, family) + "\n\n" + format_accel_table(accel)
    rows: list[tuple[str, list[str]]] = []
    u, v = family.label, family.value
    fits = [a.fit for a in axes]
    figs = [a.figures for a in axes]

    def add(label: str, values: list[str]) -> None:
        rows.append((label, values))

    add("samples", [str(a.n_samples) for a in axes])
    add("duration [h]", [f"{a.n_samples / a.sample_rate_hz / 3600:.3g}" for a in axes])
    if any(a.gaps.count for a in axes):
        add("gaps (time missing)", [a.gaps.text() for a in axes])
    add("spikes", [a.outliers.text() for a in axes])
    add(f"bias [{u('deg/h')}]", [_fmt(v(f.bias_deg_h, "deg/h")) for f in figs])
    add(
        f"  Earth rate removed [{u('deg/h')}]",
        [
            _fmt(v(f.earth_rate_removed_deg_h, "deg/h"))
            if f.earth_rate_removed_deg_h is not None
            else "not removed"
            for f in figs
        ],
    )
    rate, arw = u("deg/h"), u("deg/sqrt(h)")
    add(f"bias stability 10 s [{rate}]",
        [_fmt(v(f.bias_stability_10s_deg_h, "deg/h")) for f in figs])
    add(f"bias stability 100 s [{rate}]",
        [_fmt(v(f.bias_stability_100s_deg_h, "deg/h")) for f in figs])
    add(f"ARW read-off [{arw}]", [_fmt(v(f.arw_deg_rt_h, "deg/sqrt(h)")) for f in figs])
    add(f"  interval [{arw}]", [_interval(_in(family, f.arw_ci_deg_rt_h, "deg/sqrt(h)"))
                                for f in figs])
    add("  from tau [s]", [_range(f.arw_tau_range_s) for f in figs])
    add(f"bias instability read-off [{rate}]",
        [_fmt(v(f.bias_instability_deg_h, "deg/h")) for f in figs])
    add(f"  interval [{rate}]", [_interval(_in(family, f.bias_instability_ci_deg_h, "deg/h"))
                                 for f in figs])
    add("  at tau [s]", [_fmt(f.bias_instability_tau_s) for f in figs])
    labels = {
        "Q": ("Q quantization", "urad"),
        "N": ("N ARW", "deg/sqrt(h)"),
        "B": ("B bias instability", "deg/h"),
        "K": ("K rate random walk", "deg/h^1.5"),
        "R": ("R rate ramp", "deg/h^2"),
    }
    for term, (label, unit) in labels.items():
        add(f"fit {label} [{u(unit)}]",
            [_fmt(v(f.values[term], unit), v(f.stderr[term], unit))
             if term not in f.negative_terms else "negative" for f in fits])
    add(
        f"tones [Hz: {u('deg/s')}]",
        [
            ", ".join(f"{t.freq_hz:.3g}: {v(t.amplitude_deg_s, 'deg/s'):.2g}" for t in a.tones)
            or "none"
            for a in axes
        ],
    )
    width = max(len(label) for label, _ in rows)
    col = max(14, *(len(v) for _, vals in rows for v in vals))
    header = " " * width + "  " + "  ".join(f"{a.name:>{col}}" for a in axes)
    lines = [
        f"fit method: {fits[0].method}, estimator: {axes[0].allan.estimator}, "
        f"{len(axes[0].allan.tau_s)} taus; read-off intervals at {axes[0].allan.confidence:.1%}",
        header,
    ]
    lines += [
        f"{label:<{width}}  " + "  ".join(f"{v:>{col}}" for v in vals) for label, vals in rows
    ]
    if any(a.gmwm is not None for a in axes):
        lines += gmwm_rows(axes, width, col, family)
    for a in axes:
        lines += [f"tone ({a.name}): {t.describe()}" for t in a.tones]
        lines += [f"note ({a.name}): {n}" for n in a.figures.notes]
        lines += [f"fit note ({a.name}): {n}" for n in a.fit.notes]
        lines += [f"AMBIGUOUS ({a.name}): the record also allows {alt.describe()}"
                  for alt in a.fit.alternatives]
        lines += [f"REVIEW ({a.name}): {n}" for n in a.figures.review]
    if axes and axes[0].curve is not None:
        from station.evaluation.curve_text import format_curve

        lines += format_curve(axes, family=family)
    return "\n".join(lines)


def gmwm_rows(axes: list[AxisAnalysis], width: int, col: int,
              family: UnitFamily = DEG_FAMILY) -> list[str]:
    """The GMWM lines of the table: model, each parameter +- its standard error (named with
    its unit in ``family``), fit test, runner-up."""
    fits = [a.gmwm for a in axes]
    keys = list(dict.fromkeys(k for g in fits if g is not None for k in g.best.values))
    rows: list[tuple[str, list[str]]] = [
        ("GMWM model", [g.best.model.name if g else "-" for g in fits])]
    for key in keys:
        split = family_unit_of_key(key)
        unit = "" if split is None else split[1].label
        name = key if split is None or family.name == "deg" else f"{split[0]}_{split[1].rad_key}"
        rows.append((f"GMWM {name}", [_fmt(family.value(g.best.values[key], unit),
                                           family.value(g.best.stderr[key], unit))
                                      if g and key in g.best.values else "-" for g in fits]))
    rows.append(("GMWM fit J / dof (p)",
                 [f"{g.best.objective:.3g} / {g.best.dof} ({g.best.p_value:.2g})" if g else "-"
                  for g in fits]))
    rows.append(("GMWM runner-up (+WIC)",
                 [f"{g.runner_up.model} (+{g.runner_up.criterion - g.ranking[0].criterion:.3g})"
                  if g and g.runner_up else "-" for g in fits]))
    width = max(width, *(len(label) for label, _ in rows))
    return [f"{label:<{width}}  " + "  ".join(f"{v:>{col}}" for v in vals) for label, vals in rows]
