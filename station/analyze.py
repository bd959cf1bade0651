"""Analysis of a rate record, axis by axis: Allan variance, five-term fit, spec figures.

This composes :mod:`analysis` for the ``station analyze`` command, the demo and reports;
it is what tests call directly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from analysis.allan import AllanResult, Estimator, allan_variance
from analysis.figures import SpecFigures, spec_figures
from analysis.fit import FitMethod, NoiseCoefficients
from analysis.tones import Tone, find_tones
from analysis.zones import TauZone, fit_outside_zones
from station.record_files import RateRecord

DEFAULT_METHOD: FitMethod = "logwls"


@dataclass(frozen=True)
class AxisAnalysis:
    """Everything ``station analyze`` reports for one axis."""

    name: str
    sample_rate_hz: float
    n_samples: int
    allan: AllanResult
    fit: NoiseCoefficients
    figures: SpecFigures
    tones: tuple[Tone, ...] = ()
    zones: tuple[TauZone, ...] = ()

    def as_json(self) -> dict[str, object]:
        """The JSON object of one axis (the ``station analyze --json`` interface)."""
        return {
            "name": self.name,
            "sample_rate_hz": self.sample_rate_hz,
            "n_samples": self.n_samples,
            "estimator": self.allan.estimator,
            "tau_s": self.allan.tau_s.tolist(),
            "adev": self.allan.adev.tolist(),
            "adev_ci_low": self.allan.adev_ci_low.tolist(),
            "adev_ci_high": self.allan.adev_ci_high.tolist(),
            "n_clusters": self.allan.n_clusters.tolist(),
            "fit": self.fit.as_dict(),
            "figures": self.figures.as_dict(),
            "tones": [t.as_dict() for t in self.tones],
            "excluded_taus": [z.as_dict() for z in self.zones],
        }


def analyze_record(
    record: RateRecord,
    *,
    estimator: Estimator = "overlapping",
    taus: str | np.ndarray = "log",
    method: FitMethod = DEFAULT_METHOD,
    terms: str = "QNBKR",
) -> list[AxisAnalysis]:
    """Allan variance, tones, fit and spec figures of every axis of ``record`` (rates in deg/s).

    The fit and the read-offs leave out the tau zones a tone or an output filter
    distorts (:func:`analysis.zones.fit_outside_zones`).
    """
    result = allan_variance(record.rate_deg_s, record.sample_rate_hz, estimator=estimator, taus=taus)
    out = []
    for i, name in enumerate(record.axis_names):
        axis = result.axis(i)
        rate = record.rate_deg_s[:, i]
        tones = find_tones(rate, record.sample_rate_hz)
        fit, zones = fit_outside_zones(axis, tones, method=method, terms=terms)
        figures = spec_figures(rate, record.sample_rate_hz, axis, fit, zones=zones)
        out.append(AxisAnalysis(name, record.sample_rate_hz, record.n_samples, axis, fit, figures, tones, zones))
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


def _range(taus: tuple[float | None, float | None]) -> str:
    return "-" if taus[0] is None else f"{taus[0]:.3g}-{taus[1]:.3g}"


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
    add("  interval [deg/sqrt(h)]", [_interval(f.arw_ci_deg_rt_h) for f in figs])
    add("  from tau [s]", [_range(f.arw_tau_range_s) for f in figs])
    add("bias instability read-off [deg/h]", [_fmt(f.bias_instability_deg_h) for f in figs])
    add("  interval [deg/h]", [_interval(f.bias_instability_ci_deg_h) for f in figs])
    add("  at tau [s]", [_fmt(f.bias_instability_tau_s) for f in figs])
    labels = {"Q": "Q quantization [urad]", "N": "N ARW [deg/sqrt(h)]", "B": "B bias instability [deg/h]",
              "K": "K rate random walk [deg/h^1.5]", "R": "R rate ramp [deg/h^2]"}
    for term, label in labels.items():
        add(f"fit {label}", [_fmt(f.values[term], f.stderr[term]) if term not in f.negative_terms
                             else "negative" for f in fits])
    add("tones [Hz: deg/s]", [", ".join(f"{t.freq_hz:.3g}: {t.amplitude_deg_s:.2g}" for t in a.tones) or "none"
                              for a in axes])
    width = max(len(label) for label, _ in rows)
    col = max(14, *(len(v) for _, vals in rows for v in vals))
    header = " " * width + "  " + "  ".join(f"{a.name:>{col}}" for a in axes)
    lines = [f"fit method: {fits[0].method}, estimator: {axes[0].allan.estimator}, "
             f"{len(axes[0].allan.tau_s)} taus; read-off intervals at {axes[0].allan.confidence:.1%}", header]
    lines += [f"{label:<{width}}  " + "  ".join(f"{v:>{col}}" for v in vals) for label, vals in rows]
    for a in axes:
        lines += [f"tone ({a.name}): {t.describe()}" for t in a.tones]
        lines += [f"note ({a.name}): {n}" for n in a.figures.notes]
        lines += [f"REVIEW ({a.name}): {n}" for n in a.figures.review]
    return "\n".join(lines)
