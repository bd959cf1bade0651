"""Reports of ``station reconcile``: the text account of each step and the Allan-deviation figure.

The figure (matplotlib, Agg backend, no display) shows per axis the measured Allan
deviation with its confidence band, the model before and after with their Monte Carlo
bands, and the contribution of each named effect (and of each excess term, before and
after), in deg/h, or in rad/s in the rad unit family (``--output-units rad``,
``docs/units.md``). The text report prints each effect's parameters and the numbers of its
evidence in the family asked for; the TOML of the model after stays in the units a model file
is read in (deg/h, deg/sqrt(h), ...), as ``model_after`` does in ``--json``.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, cast

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import ListedColormap  # noqa: E402

from analysis.allan.confidence import ONE_SIGMA, chi2_interval  # noqa: E402
from analysis.reconcile.discrepancy import Comparison  # noqa: E402
from analysis.reconcile.loop import Effect, ReconcileResult, term_avar  # noqa: E402
from analysis.units.conversions import (  # noqa: E402
    DEG_FAMILY,
    FAMILY_UNITS,
    S_PER_H,
    UnitFamily,
)
from station.output import plots  # noqa: E402
from station.output.json_units import in_family  # noqa: E402

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: Colours of the effects' curves.
DARK2 = cast(ListedColormap, matplotlib.colormaps["Dark2"])


def _fmt(value: float) -> str:
    return f"{value:.4g}"


#: A number followed by a deg-family unit in free text ("+0.5 deg/h"), longest unit first.
_NUMBER_UNIT = re.compile(
    r"(?P<number>[+-]?\d+(?:\.\d*)?(?:[eE][+-]?\d+)?) (?P<unit>"
    + "|".join(re.escape(u.label) for u in sorted(FAMILY_UNITS, key=lambda u: -len(u.label)))
    + r")(?![\w/^])"
)


def _in_family_text(text: str, family: UnitFamily) -> str:
    """``text`` with each "<number> <deg-family unit>" in ``family`` (an effect's evidence:
    "+0.52 deg/h at 300 s" -> "+2.52e-06 rad/s at 300 s")."""
    if family.name == "deg":
        return text

    def convert(m: re.Match[str]) -> str:
        value = float(m["number"]) * family.factor(m["unit"])
        sign = "+" if m["number"].startswith("+") else ""
        return f"{value:{sign}.3g} {family.label(m['unit'])}"

    return _NUMBER_UNIT.sub(convert, text)


def _params(effect: Effect, family: UnitFamily) -> str:
    """``key = value +- stderr, ...``, each key named with its unit (``amplitude_deg_h``, in
    the rad family ``amplitude_rad_s``: the keys of ``--json``)."""
    params = cast(Mapping[str, float], in_family(effect.params, family))
    stderr = cast(Mapping[str, float], in_family(effect.stderr, family))
    parts = []
    for key, value in params.items():
        err = stderr.get(key)
        parts.append(f"{key} = {_fmt(value)}" + (f" +- {_fmt(err)}" if err is not None else ""))
    return ", ".join(parts)


def _ranges(comparison: Comparison) -> str:
    if not comparison.outside:
        return "inside the simulated band at every tau"
    spans = [f"{side} it at {_fmt(lo)}-{_fmt(hi)} s" for lo, hi, side in comparison.outside]
    return "measured curve " + "; ".join(spans)


def _comparison_line(label: str, comparison: Comparison, alpha: float) -> str:
    terms = ", ".join(comparison.model.term_names) or "(no terms)"
    verdict = "disagrees" if comparison.significant(alpha) else "agrees"
    return (
        f"{label}: [{terms}]  gap G = {_fmt(comparison.gap)} (p = {comparison.p_value:.2g}, "
        f"{100 * (1 - alpha):g} % of the model's runs below "
        f"{_fmt(comparison.gap_null.quantile(1 - alpha))}): "
        f"{verdict}; {_ranges(comparison)}"
    )


def format_reconcile(result: ReconcileResult, *, label: str = "",
                     family: UnitFamily = DEG_FAMILY) -> str:
    """The text report of one axis: comparison, each round's candidates, effects (their
    parameters and evidence in ``family``), the model after (its TOML in a model file's
    units)."""
    c, opt = result.curve, result.options
    decimated = f", decimated by {c.decimation}" if c.decimation > 1 else ""
    lines = [
        f"reconcile {label}: {c.n_samples} samples at {c.sample_rate_hz:g} Hz "
        f"({c.duration_s / S_PER_H:.3g} h{decimated}), "
        f"{len(c.tau_s)} taus {_fmt(c.tau_s[0])}-{_fmt(c.tau_s[-1])} s, {opt.runs} Monte Carlo "
        f"runs (seed {opt.seed})",
        _comparison_line("model before", result.before, opt.alpha),
    ]
    for i, rnd in enumerate(result.rounds, start=1):
        if not rnd.attempts:
            continue
        lines.append(f"round {i}: candidates with Delta BIC >= {opt.bic_threshold:g}, best first")
        for a in rnd.attempts:
            lines.append(f"  {a.name:<17} ({a.mode}) Delta BIC {a.delta_bic:8.1f}  {a.outcome}")
    if result.before.significant(opt.alpha) and not result.effects and not result.excess:
        lines.append("no candidate effect shrinks the gap significantly")
    for title, effects in (
        ("missing effects", result.effects),
        ("excess terms (the data show less)", result.excess),
    ):
        lines.append(f"{title}: {'none' if not effects else ''}".rstrip())
        for e in effects:
            lines.append(f"  {e.name} ({e.change}): {_params(e, family)}")
            lines.append(
                f"    explains tau {_fmt(e.tau_range_s[0])}-{_fmt(e.tau_range_s[1])} s; gap "
                f"{_fmt(e.gap_before)} -> {_fmt(e.gap_after)}; Delta BIC {e.delta_bic:.1f}"
                + (f"; {_in_family_text(e.evidence, family)}" if e.evidence else "")
            )
            if e.alternatives:
                what = "GMWM score" if e.criterion == "gmwm" else "Delta BIC"
                others = ", ".join(f"{a.name} ({a.change}, {a.score:.3g})" for a in e.alternatives)
                how = ("about as good" if e.score is None
                       or all(a.score <= e.score + 1e-9 for a in e.alternatives)
                       else "about as good or better")
                lines.append(f"    {how} ({what}; this one {e.score:.3g}): {others}")
    lines.append(_comparison_line("model after", result.after, opt.alpha))
    lines.append("model after (TOML):" if family.name == "deg" else
                 "model after (TOML, in the deg units a model file is read in):")
    lines.extend("  " + line for line in result.model_after.to_toml().splitlines())
    return "\n".join(lines)


def _effect_curves(result: ReconcileResult) -> list[tuple[str, np.ndarray, str]]:
    tau, dur = result.curve.tau_s, result.curve.duration_s
    out = []
    for e in result.effects:
        out.append((f"{e.name} ({e.change})", term_avar(result, e.name), ":"))
    for e in result.excess:
        old = result.model_before.get(e.name)
        if old is not None:
            out.append((f"{e.name} in model before", old.avar(tau, duration_s=dur), "--"))
        out.append((f"{e.name} as the data show", term_avar(result, e.name), ":"))
    return out


def plot_reconcile(results: Sequence[tuple[str, ReconcileResult]], path: str | Path, *,
                   family: UnitFamily = DEG_FAMILY) -> Path:
    """PNG of each axis: measured curve and band, model before and after with bands, effects,
    the Allan deviation in deg/h (rad/s in the rad ``family``)."""
    return plots._save(reconcile_figure(results, family=family), Path(path))


def reconcile_figure(results: Sequence[tuple[str, ReconcileResult]], *,
                     family: UnitFamily = DEG_FAMILY) -> Figure:
    """The figure :func:`plot_reconcile` saves."""
    fig, axes = plt.subplots(
        len(results), 1, figsize=(8.5, 5.2 * len(results)), dpi=110, squeeze=False
    )
    for ax, (label, res) in zip(axes[:, 0], results, strict=True):
        c = res.curve
        tau, k = c.tau_s, S_PER_H * family.factor("deg/h")  # deg/s -> the unit drawn
        low, high = chi2_interval(c.avar, c.precision.edf, ONE_SIGMA)
        ax.fill_between(tau, np.sqrt(low) * k, np.sqrt(high) * k, color="k", alpha=0.15, lw=0)
        ax.loglog(tau, np.sqrt(c.avar) * k, "ko-", ms=2.5, lw=1, label="measured (1-sigma band)")
        for name, comp, color in (
            ("model before", res.before, "tab:red"),
            ("model after", res.after, "tab:blue"),
        ):
            if name == "model after" and comp is res.before:
                continue
            ax.fill_between(
                tau,
                np.sqrt(comp.band.low) * k,
                np.sqrt(comp.band.high) * k,
                color=color,
                alpha=0.15,
                lw=0,
            )
            ax.loglog(tau, np.sqrt(comp.model_avar) * k, "-", color=color, lw=1.6,
                      label=f"{name}, G = {comp.gap:.3g} (95 % simulated band)")
        for i, (name, avar, style) in enumerate(_effect_curves(res)[:DARK2.N]):
            if np.any(avar > 0):
                ax.loglog(tau, np.sqrt(np.maximum(avar, 1e-300)) * k, style, color=DARK2(i), lw=1.4,
                          label=name)
        floor = float(np.min(np.sqrt(low))) * k / 5
        ceiling = float(np.max(np.sqrt(np.maximum(high, res.before.band.high)))) * k * 2
        ax.set_ylim(floor, ceiling)
        ax.set_xlabel("averaging time tau [s]")
        ax.set_ylabel(f"Allan deviation [{family.label('deg/h')}]")
        ax.grid(True, which="both", alpha=0.3)
        ax.set_title(f"reconcile {label}".strip(), fontsize=10)
        ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    return fig
