"""Analysis of a rate record, axis by axis: Allan variance, five-term fit, spec figures.

This composes :mod:`analysis` for the ``station analyze`` command, the demo and reports;
it is what tests call directly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from analysis.allan import AllanResult, Estimator, allan_variance
from analysis.figures import SpecFigures, spec_figures
from analysis.fit import FitMethod, NoiseCoefficients, fit_noise_terms
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
        }


def analyze_record(
    record: RateRecord,
    *,
    estimator: Estimator = "overlapping",
    taus: str | np.ndarray = "log",
    method: FitMethod = DEFAULT_METHOD,
    terms: str = "QNBKR",
    select: bool | None = None,
) -> list[AxisAnalysis]:
    """Allan variance, fit and spec figures of every axis of ``record`` (rates in deg/s).

    ``select`` is :func:`analysis.fit.fit_noise_terms`' (default: on for logwls).
    """
    result = allan_variance(record.rate_deg_s, record.sample_rate_hz, estimator=estimator, taus=taus)
    out = []
    for i, name in enumerate(record.axis_names):
        axis = result.axis(i)
        fit = fit_noise_terms(axis, method=method, terms=terms, select=select)
        figures = spec_figures(record.rate_deg_s[:, i], record.sample_rate_hz, axis, fit)
        out.append(AxisAnalysis(name, record.sample_rate_hz, record.n_samples, axis, fit, figures))
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
        lines += [f"fit note ({a.name}): {n}" for n in a.fit.notes]
    return "\n".join(lines)
