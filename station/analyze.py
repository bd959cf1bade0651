"""Analysis of a rate record, axis by axis: Allan variance, five-term fit, spec figures.

This composes :mod:`analysis` for the ``station analyze`` command, the demo and reports;
it is what tests call directly.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from analysis.allan import AllanResult, Estimator, allan_variance, analysis_log_m
from analysis.deviations import (
    DEVIATION_LABELS,
    DeviationKind,
    DeviationResult,
    deviation,
    from_allan,
)
from analysis.figures import SpecFigures, spec_figures
from analysis.fit import FitMethod, NoiseCoefficients, fit_noise_terms
from station.record_files import RateRecord

DEFAULT_METHOD: FitMethod = "logwls"


@dataclass(frozen=True)
class AxisAnalysis:
    """Everything ``station analyze`` reports for one axis.

    ``allan`` is the Allan variance the fit and the spec figures come from; ``curve`` is
    the deviation shown and listed (the same Allan variance unless another was asked for).
    """

    name: str
    sample_rate_hz: float
    n_samples: int
    allan: AllanResult
    fit: NoiseCoefficients
    figures: SpecFigures
    curve: DeviationResult

    @property
    def readoff_allan(self) -> AllanResult:
        """The Allan variance the read-offs see (:func:`readoff_range`)."""
        return readoff_range(self.allan)

    def as_json(self) -> dict[str, object]:
        """The JSON object of one axis (the ``station analyze --json`` interface).

        ``tau_s``, ``adev``, ``adev_ci_low``, ``adev_ci_high`` and ``n_clusters`` are those
        of the chosen ``deviation`` (``adev`` holds its values, in ``deviation_unit``);
        ``fit`` and ``figures`` always come from the Allan variance named by ``estimator``.
        """
        c = self.curve
        return {
            "name": self.name,
            "sample_rate_hz": self.sample_rate_hz,
            "n_samples": self.n_samples,
            "estimator": self.allan.estimator,
            "deviation": c.kind,
            "deviation_label": DEVIATION_LABELS[c.kind],
            "deviation_unit": "deg" if c.unit == "angle" else "deg/s",
            "tau_s": c.tau_s.tolist(),
            "adev": c.deviation.tolist(),
            "adev_ci_low": c.deviation_ci_low.tolist(),
            "adev_ci_high": c.deviation_ci_high.tolist(),
            "n_clusters": c.n_clusters.tolist(),
            "edf": c.edf.tolist(),
            "noise_alpha": c.noise_alpha.tolist(),
            "interval": c.interval,
            "curve_notes": list(c.notes),
            "fit_from": DEVIATION_LABELS[from_allan(self.allan).kind].replace("deviation", "variance"),
            "fit": self.fit.as_dict(),
            "figures": self.figures.as_dict(),
        }


#: The read-offs see the taus with at least this many clusters (Zhang 2015 eq. 20's nine).
#: Past them the curve is the noise of a few clusters: the minimum of the Allan deviation
#: read there is not a bias instability (on the ADIS16405 x axis it reads 8.7 deg/h at
#: 5000 s, two clusters, against 27.2 at 1111 s). Until the read-offs weigh each tau by its
#: interval, they keep eq. 20's range; the fit and the plots use the whole grid.
READOFF_MIN_CLUSTERS = 9


def readoff_range(result: AllanResult) -> AllanResult:
    """``result`` cut to the taus with at least :data:`READOFF_MIN_CLUSTERS` clusters."""
    keep = result.n_clusters >= READOFF_MIN_CLUSTERS
    if keep.all() or not keep.any():
        return result
    arrays = {name: getattr(result, name)[keep] for name in
              ("tau_s", "m", "avar", "n_clusters", "n_terms", "edf", "ci_low", "ci_high", "noise_alpha")}
    return replace(result, **arrays)


def analyze_record(
    record: RateRecord,
    *,
    estimator: Estimator = "overlapping",
    taus: str | np.ndarray = "log",
    method: FitMethod = DEFAULT_METHOD,
    terms: str = "QNBKR",
    deviation_kind: DeviationKind | None = None,
) -> list[AxisAnalysis]:
    """Allan variance, fit and spec figures of every axis of ``record`` (rates in deg/s).

    ``taus="log"`` is :func:`analysis.allan.analysis_log_m`: eq. 20's spacing continued to
    the longest tau with two clusters. ``deviation_kind`` picks the curve shown (default:
    the Allan deviation of ``estimator``); the fit and the figures stay on the Allan variance.
    """
    fs, rate = record.sample_rate_hz, record.rate_deg_s
    grid = analysis_log_m(record.n_samples) / fs if isinstance(taus, str) and taus == "log" else taus
    result = allan_variance(rate, fs, estimator=estimator, taus=grid)
    own = from_allan(result).kind
    other = None
    if deviation_kind is not None and deviation_kind != own:
        other = deviation(rate, fs, kind=deviation_kind, taus=taus)
    out = []
    for i, name in enumerate(record.axis_names):
        axis = result.axis(i)
        fit = fit_noise_terms(axis, method=method, terms=terms)
        figures = spec_figures(rate[:, i], fs, readoff_range(axis), fit)
        curve = other.axis(i) if other is not None else from_allan(axis)
        out.append(AxisAnalysis(name, fs, record.n_samples, axis, fit, figures, curve))
    return out


def _fmt(value: float | None, stderr: float | None = None) -> str:
    if value is None:
        return "-"
    text = f"{value:.4g}"
    if stderr is not None:
        text += f" +- {stderr:.2g}"
    return text


def format_analysis(axes: list[AxisAnalysis]) -> str:
    """A plain-text table of the figures of every axis, units in the first column."""
    rows: list[tuple[str, list[str]]] = []
    fits = [a.fit for a in axes]
    figs = [a.figures for a in axes]

    def add(label: str, values: list[str]) -> None:
        rows.append((label, values))

    add("samples", [str(a.n_samples) for a in axes])
    add("duration [h]", [f"{a.n_samples / a.sample_rate_hz / 3600:.3g}" for a in axes])
    add("bias [deg/h]", [_fmt(f.bias_deg_h) for f in figs])
    add("bias stability 10 s [deg/h]", [_fmt(f.bias_stability_10s_deg_h) for f in figs])
    add("bias stability 100 s [deg/h]", [_fmt(f.bias_stability_100s_deg_h) for f in figs])
    add("ARW read-off [deg/sqrt(h)]", [_fmt(f.arw_deg_rt_h) for f in figs])
    add("bias instability read-off [deg/h]", [_fmt(f.bias_instability_deg_h) for f in figs])
    add("  at tau [s]", [_fmt(f.bias_instability_tau_s) for f in figs])
    labels = {"Q": "Q quantization [urad]", "N": "N ARW [deg/sqrt(h)]", "B": "B bias instability [deg/h]",
              "K": "K rate random walk [deg/h^1.5]", "R": "R rate ramp [deg/h^2]"}
    for term, label in labels.items():
        add(f"fit {label}", [_fmt(f.values[term], f.stderr[term]) if term not in f.negative_terms
                             else "negative" for f in fits])
    width = max(len(label) for label, _ in rows)
    col = max(14, *(len(v) for _, vals in rows for v in vals))
    header = " " * width + "  " + "  ".join(f"{a.name:>{col}}" for a in axes)
    lines = [f"fit method: {fits[0].method}, estimator: {axes[0].allan.estimator}, "
             f"{len(axes[0].allan.tau_s)} taus", header]
    lines += [f"{label:<{width}}  " + "  ".join(f"{v:>{col}}" for v in vals) for label, vals in rows]
    for a in axes:
        lines += [f"note ({a.name}): {n}" for n in a.figures.notes]
    if axes and axes[0].curve.kind != from_allan(axes[0].allan).kind:
        lines += format_curve(axes)
    return "\n".join(lines)


def format_curve(axes: list[AxisAnalysis], *, per_decade: int = 3) -> list[str]:
    """The chosen deviation of every axis at a few taus per decade, with its interval."""
    c0 = axes[0].curve
    unit, scale = ("deg", 1.0) if c0.unit == "angle" else ("deg/h", 3600.0)
    lines = ["", f"{DEVIATION_LABELS[c0.kind]} [{unit}] with its {c0.confidence:.3g} interval "
                 f"({c0.interval}); the fit and figures above are on the Allan variance"]
    logt = np.log10(c0.tau_s)
    picks = np.unique([int(np.argmin(np.abs(logt - v)))
                       for v in np.arange(logt[0], logt[-1] + 1e-9, 1.0 / per_decade)] + [len(logt) - 1])
    lines.append(f"{'tau [s]':>10}  " + "  ".join(f"{a.name:>30}" for a in axes))
    for j in picks:
        cells = [f"{a.curve.deviation[j] * scale:.4g} [{a.curve.deviation_ci_low[j] * scale:.3g}, "
                 f"{a.curve.deviation_ci_high[j] * scale:.3g}]" for a in axes]
        lines.append(f"{c0.tau_s[j]:>10.4g}  " + "  ".join(f"{c:>30}" for c in cells))
    for a in axes:
        lines += [f"note ({a.name}): {n}" for n in a.curve.notes]
    return lines
