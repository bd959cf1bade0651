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
from analysis.gmwm_selection import GmwmSelection, gmwm_analysis
from station.record_files import RateRecord

DEFAULT_METHOD: FitMethod = "logwls"
#: ``--method gmwm``: the GMWM beside the default Allan fit (whose read-offs and terms stay).
GMWM_METHOD = "gmwm"


@dataclass(frozen=True)
class AxisAnalysis:
    """Everything ``station analyze`` reports for one axis."""

    name: str
    sample_rate_hz: float
    n_samples: int
    allan: AllanResult
    fit: NoiseCoefficients
    figures: SpecFigures
    gmwm: GmwmSelection | None = None

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
            **({"gmwm": self.gmwm.as_json()} if self.gmwm is not None else {}),
        }


def analyze_record(
    record: RateRecord,
    *,
    estimator: Estimator = "overlapping",
    taus: str | np.ndarray = "log",
    method: FitMethod | str = DEFAULT_METHOD,
    terms: str = "QNBKR",
    gmwm_model: str = "auto",
    robust: bool = False,
) -> list[AxisAnalysis]:
    """Allan variance, fit and spec figures of every axis of ``record`` (rates in deg/s).

    ``method="gmwm"`` adds the GMWM (``gmwm_model``: a model string or ``"auto"``
    selection; ``robust``: the robust wavelet variance) beside the default Allan fit.
    """
    use_gmwm = method == GMWM_METHOD
    allan_method = DEFAULT_METHOD if use_gmwm else method
    result = allan_variance(record.rate_deg_s, record.sample_rate_hz, estimator=estimator, taus=taus)
    out = []
    for i, name in enumerate(record.axis_names):
        axis = result.axis(i)
        fit = fit_noise_terms(axis, method=allan_method, terms=terms)  # type: ignore[arg-type]
        figures = spec_figures(record.rate_deg_s[:, i], record.sample_rate_hz, axis, fit)
        gm = gmwm_analysis(record.rate_deg_s[:, i], record.sample_rate_hz, model=gmwm_model,
                           robust=robust) if use_gmwm else None
        out.append(AxisAnalysis(name, record.sample_rate_hz, record.n_samples, axis, fit, figures, gm))
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
    if any(a.gmwm is not None for a in axes):
        lines += gmwm_rows(axes, width, col)
    for a in axes:
        lines += [f"note ({a.name}): {n}" for n in a.figures.notes]
    return "\n".join(lines)


def gmwm_rows(axes: list[AxisAnalysis], width: int, col: int) -> list[str]:
    """The GMWM lines of the table: model, each parameter +- its standard error, fit test, runner-up."""
    fits = [a.gmwm for a in axes]
    keys = list(dict.fromkeys(k for g in fits if g is not None for k in g.best.values))
    rows: list[tuple[str, list[str]]] = [("GMWM model", [g.best.model.name if g else "-" for g in fits])]
    for key in keys:
        rows.append((f"GMWM {key}", [_fmt(g.best.values[key], g.best.stderr[key]) if g and key in g.best.values
                                     else "-" for g in fits]))
    rows.append(("GMWM fit J / dof (p)", [f"{g.best.objective:.3g} / {g.best.dof} ({g.best.p_value:.2g})" if g
                                         else "-" for g in fits]))
    rows.append(("GMWM runner-up (+WIC)", [f"{g.runner_up.model} (+{g.runner_up.criterion - g.ranking[0].criterion:.3g})"
                                           if g and g.runner_up else "-" for g in fits]))
    width = max(width, *(len(label) for label, _ in rows))
    return [f"{label:<{width}}  " + "  ".join(f"{v:>{col}}" for v in vals) for label, vals in rows]
