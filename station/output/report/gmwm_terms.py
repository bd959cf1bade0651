"""A graded run's GMWM terms as the views show them, without plotting.

Where the report service (or a fleet's report) added the GMWM to the graded axes
(:mod:`station.evaluation.gmwm_run`): per axis and parameter a :class:`GmwmRow` (value,
unit, standard error, interval, and the Allan figure of the same term), and one line with
the selected model, its J test and the ranking's runner-up. The PDF and HTML sheets
(:mod:`station.output.report.gmwm_sheet`), the CSV report, ``station fleet report`` and the
TUI's spec screen all read them from here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from analysis.figures.accel import STANDARD_GRAVITY_M_S2
from analysis.gmwm.equivalent import WN_EQUIVALENT_KEY
from analysis.gmwm.models import KINDS
from analysis.units.conversions import S_PER_H
from station.evaluation.grading import AxisGrade, UnitGrade
from station.output.report.common import fmt

#: Unit of a GMWM key's suffix (longest first: ``deg_h_rt_h`` before ``deg_h``).
KEY_UNITS = (("deg_h_rt_h", "deg/h/sqrt(h)"), ("deg_rt_h", "deg/sqrt(h)"), ("deg_h2", "deg/h^2"),
             ("sigma_deg_h", "deg/h"), ("deg_h", "deg/h"), ("tau_s", "s"), ("urad", "urad"),
             ("phi", "1"))
#: An accelerometer axis' GMWM (fitted to m/s^2 where a rate axis' is in deg/s): the unit
#: and the factor from the key's value, by the key's suffix (the deg/h family's s and h
#: carried over: N in m/s/sqrt(h), K in m/s/h^1.5, R in m/s/h^2; B and a Gauss-Markov's
#: sigma from "deg/h" (m/s^2 x 3600) to ug; Q from urad to m/s).
ACCEL_KEY_UNITS = (("deg_h_rt_h", "m/s/h^1.5", 1.0), ("deg_rt_h", "m/s/sqrt(h)", 1.0),
                   ("deg_h2", "m/s/h^2", 1.0),
                   ("sigma_deg_h", "ug", 1.0 / (S_PER_H * STANDARD_GRAVITY_M_S2 * 1e-6)),
                   ("deg_h", "ug", 1.0 / (S_PER_H * STANDARD_GRAVITY_M_S2 * 1e-6)),
                   ("tau_s", "s", 1.0), ("urad", "m/s", 1.0 / (math.pi / 180.0 * 1e6)),
                   ("phi", "1", 1.0))
#: What a shape parameter is called, by its key's suffix.
SHAPE_NAMES = {"tau_s": "correlation time", "phi": "coefficient phi"}


@dataclass(frozen=True)
class GmwmRow:
    """One GMWM parameter of one axis, with the Allan figure of the same term.

    Attributes
    ----------
    axis, key : str
        The axis, and the parameter's key (``wn_deg_rt_h``, ``gm_tau_s``).
    term, unit : str
        What it is (``white noise``, ``Gauss-Markov correlation time``) and its unit.
    value, stderr, ci_low, ci_high : float or None
        The estimate, its standard error and its interval, in ``unit`` (None: not finite).
    allan : str
        The Allan figure of the same term in ``unit`` and where it comes from, "" when the
        Allan fit has none.
    """

    axis: str
    key: str
    term: str
    unit: str
    value: float | None
    stderr: float | None
    allan: str
    ci_low: float | None = None
    ci_high: float | None = None

    def text(self) -> str:
        """``"white noise 0.01234 deg/sqrt(h) [0.0119, 0.0128]"`` (value, unit, interval)."""
        interval = ("" if self.ci_low is None or self.ci_high is None
                    else f" [{fmt(self.ci_low)}, {fmt(self.ci_high)}]")
        return f"{self.term} {fmt(self.value)} {self.unit}{interval}".replace("  ", " ")


def _finite(x: float | None) -> float | None:
    return x if x is not None and math.isfinite(x) else None


def _unit_of(key: str) -> str:
    return next((unit for suffix, unit in KEY_UNITS if key.endswith(suffix)), "")


def _accel_unit_of(key: str) -> tuple[str, float]:
    """(unit, factor from the key's value) of an accelerometer axis' GMWM key."""
    return next(((unit, k) for suffix, unit, k in ACCEL_KEY_UNITS if key.endswith(suffix)),
                ("", 1.0))


def _term_of(key: str) -> str:
    if key == WN_EQUIVALENT_KEY:
        return "white-noise equivalent (white noise and fast Gauss-Markov / AR(1) together)"
    label = key.split("_", 1)[0]
    # the longest code the label starts with ("ar1", "ar12": AR(1); "gm2": Gauss-Markov)
    kind = KINDS[max((c for c in KINDS if label.startswith(c)), key=len)]
    number = label[len(kind.code):]
    shape = next((name for suffix, name in SHAPE_NAMES.items() if key.endswith(suffix)), "")
    what = shape or ("sigma" if kind.has_shape else "")
    return " ".join(p for p in (kind.title, number, what) if p)


def _allan_of(axis: AxisGrade, key: str) -> str:
    """The Allan figure of the term ``key`` names, in the key's unit."""
    a = axis.analysis
    figs, fit = a.figures, a.fit
    code = key.split("_", 1)[0]
    if code == "wn" and figs.arw_deg_rt_h is not None:
        return f"{fmt(figs.arw_deg_rt_h)} (ARW read-off)"
    if code == "bi" and figs.bias_instability_deg_h is not None:
        return f"{fmt(figs.bias_instability_deg_h)} (B read-off)"
    term = {"wn": "N", "qn": "Q", "rw": "K", "dr": "R", "bi": "B"}.get(code)
    if term is None or fit.values.get(term) is None:
        return ""
    return f"{fmt(fit.values[term])} (fit {term}, {fit.method})"


def _row_order(values: dict[str, float]) -> list[str]:
    """The keys of ``values``, the white-noise equivalent first: the angle random walk the
    record shows where a fast term took the white term's place."""
    return sorted(values, key=lambda k: k != WN_EQUIVALENT_KEY)


def gmwm_rows(axis: AxisGrade) -> list[GmwmRow]:
    """The GMWM parameters of ``axis`` (none when it has no GMWM); an accelerometer axis'
    in its own units (:data:`ACCEL_KEY_UNITS`), its Allan figures being in its own table.
    Where a Gauss-Markov / AR(1) term is faster than the shortest tau, the white-noise
    equivalent comes first and the white term is marked as the term alone."""
    g = axis.analysis.gmwm
    if g is None:
        return []
    best = g.best
    accel = axis.analysis.quantity == "acceleration"
    rows = []
    fast = best.white_equivalent() is not None
    for key in _row_order(best.values):
        value = best.values[key]
        unit, k = _accel_unit_of(key) if accel else (_unit_of(key), 1.0)

        def scaled(x: float | None, k: float = k) -> float | None:
            x = _finite(x)
            return None if x is None else x * k

        term = _term_of(key) + (" (term alone)" if fast and key == "wn_deg_rt_h" else "")
        rows.append(GmwmRow(axis.axis, key, term, unit, scaled(value),
                            scaled(best.stderr.get(key)), "" if accel else _allan_of(axis, key),
                            scaled(best.ci_low.get(key)), scaled(best.ci_high.get(key))))
    return rows


def gmwm_summary(axis: AxisGrade) -> str:
    """One line: the model, how it was chosen, its J test and the ranking's runner-up."""
    g = axis.analysis.gmwm
    if g is None:
        return f"{axis.axis}: no GMWM"
    best = g.best
    chosen = (f"selected by the WIC among {len(g.ranking)} candidates" if len(g.ranking) > 1
              else "given")
    p = "-" if not math.isfinite(best.p_value) else f"{best.p_value:.2g}"
    text = (f"{axis.axis}: model {best.model.name} ({chosen}); J = {best.objective:.3g} on "
            f"{best.dof} dof, p-value {p}")
    runner = g.runner_up
    if runner is not None:
        text += (f"; runner-up {runner.model} (WIC +"
                 f"{runner.criterion - g.ranking[0].criterion:.3g})")
    if best.model_error > 0:
        text += f"; weights floored at {best.model_error:.0%} model error (J rejects the model)"
    equivalent = best.white_equivalent()
    if equivalent is not None:
        unit = "m/s/sqrt(h)" if axis.analysis.quantity == "acceleration" else "deg/sqrt(h)"
        text += ("; white-noise equivalent readings (the fast terms are white at every tau "
                 "of the record): " + ", ".join(equivalent.readings()).replace(
                     "deg/sqrt(h)", unit))
    return text


def has_gmwm(unit: UnitGrade) -> bool:
    """Whether any axis of ``unit`` carries a GMWM result."""
    return any(a.analysis.gmwm is not None for a in unit.axes)


def fitted_axes(unit: UnitGrade) -> list[AxisGrade]:
    """The axes of ``unit`` that carry a GMWM result."""
    return [a for a in unit.axes if a.analysis.gmwm is not None]


def gmwm_p_value(axis: AxisGrade) -> float | None:
    """The selected model's J-test p-value (None: no GMWM, or not finite)."""
    g = axis.analysis.gmwm
    return None if g is None else _finite(g.best.p_value)


def gmwm_model_name(axis: AxisGrade) -> str:
    """The selected GMWM model (``wn+gm+rw``), "" without a GMWM."""
    g = axis.analysis.gmwm
    return "" if g is None else g.best.model.name
