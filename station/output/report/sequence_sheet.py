"""What a spec sheet shows of a test sequence: its figures table, and three plots.

The plots (one PNG, three panels, computed once for the PDF and the HTML sheet):

* bias per switch-on with the mean and the repeatability band (+-1 sigma of the
  per-switch-on biases), per axis;
* the warm-up curves (bias trend against time since switch-on) overlaid, each relative
  to its settled bias, with the band and each curve's warm-up time;
* bias against temperature with the linear (and quadratic) fit, rising and falling
  points marked apart.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from station.evaluation.sequence_grading import UnitSequence  # noqa: E402
from station.output.report.common import FigureRow, fmt, fmt_interval  # noqa: E402
from station.output.report.panels import figure_png, placeholder  # noqa: E402

#: The figures shown whether or not the profile limits them: (JSON key, label, unit).
_INFO = (("turn_on_time_spread_s", "turn-on time spread (1 sigma)", "s"),
         ("warmup_time_spread_s", "warm-up time spread (1 sigma)", "s"),
         ("temperature_coefficient2_deg_h_per_c2", "bias temperature coefficient, quadratic",
          "deg/h/degC^2"),
         ("hysteresis_deg_h", "thermal hysteresis", "deg/h"))


def sequence_rows(seq: UnitSequence) -> list[FigureRow]:
    """The graded figures (limits of the deciding grade), then informational ones (a
    sequence's figures are the unit's: no axis)."""
    rows = []
    grade = seq.deciding_grade
    for g in seq.graded:
        limited = bool(g.spec.limits)
        rows.append(FigureRow("", g.spec.name, g.spec.label, g.spec.unit, g.value, g.ci_low,
                                g.ci_high, g.spec.limits.get(grade) if limited else None,
                                grade if limited else "",
                                g.verdicts.get(grade, "pass") if limited else None, g.note))
    shown = {g.spec.kind.key for g in seq.graded}
    for key, label, unit in _INFO:
        fig = seq.figures.get(key)
        if fig is not None and fig.value is not None and key not in shown:
            rows.append(FigureRow("", key, label, unit, fig.value, fig.low, fig.high, None, "",
                                    None, f"axis {fig.axis}" if fig.axis else ""))
    return rows


def sequence_lines(seq: UnitSequence) -> list[str]:
    """The sequence's figures as plain text lines (``station grade``'s table)."""
    head = (f"sequence {seq.sequence}: {len(seq.cycles)} switch-on(s)"
            + (f", grade {seq.grade}" if seq.grade else ""))
    lines = [head, f"  {'figure':<44} {'value':>10} {'interval':>23} {'limit':>10}  verdict"]
    for r in sequence_rows(seq):
        label = f"{r.label} [{r.unit}]"
        lines.append(f"  {label:<44} {fmt(r.value):>10} {fmt_interval(r.ci_low, r.ci_high):>23} "
                     f"{fmt(r.limit):>10}  {r.verdict or '(info)'}")
    for c in seq.cycles:
        biases = ", ".join(f"{a} {fmt(b.mean_deg_h)}" for a, b in c.biases.items() if b is not None)
        warm = ", ".join(f"{a} {fmt(c.warmup_time_s(a))}" for a in c.warmups)
        lines.append(f"  switch-on {c.power_cycle}: turn-on {fmt(c.turn_on_time_s)} s, bias "
                     f"[deg/h] {biases or '-'}, warm-up [s] {warm or '-'}"
                     + (" (interrupted)" if c.interrupted else ""))
    return lines


def _bias_panel(ax: Axes, seq: UnitSequence, fontsize: float) -> None:
    drawn = False
    for a in seq.axes:
        pts = [(c.power_cycle, b.mean_deg_h, b.stderr_deg_h or 0.0) for c in seq.cycles
               if (b := c.biases.get(a.axis)) is not None]
        if not pts:
            continue
        drawn = True
        n, b, e = np.array(pts).T
        line = ax.errorbar(n, b, yerr=e, fmt="o-", ms=3, lw=0.8, label=f"axis {a.axis}")
        rep = a.repeatability
        if rep.mean_deg_h is not None and rep.value_deg_h is not None:
            color = line[0].get_color()
            ax.axhspan(rep.mean_deg_h - rep.value_deg_h, rep.mean_deg_h + rep.value_deg_h,
                       color=color, alpha=0.12)
            ax.axhline(rep.mean_deg_h, color=color, lw=0.6, ls="--")
    if not drawn:
        placeholder(ax, "no bias per switch-on\n(no record after a switch-on)", fontsize=fontsize)
        return
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("switch-on", fontsize=fontsize)
    ax.set_ylabel("bias after warm-up [deg/h]", fontsize=fontsize)
    ax.set_title("bias per switch-on (band: +-1 sigma repeatability)", fontsize=fontsize)
    ax.legend(fontsize=fontsize * 0.85)


def _warmup_panel(ax: Axes, seq: UnitSequence, fontsize: float) -> None:
    band = None
    drawn = False
    for c in seq.cycles:
        for axis, w in c.warmups.items():
            if w is None:
                continue
            drawn = True
            band = w.band_deg_h
            line, = ax.plot(w.t_s, w.bias_deg_h - w.reference_deg_h, lw=0.7,
                            label=f"#{c.power_cycle} {axis}")
            if w.warmup_time_s is not None:
                ax.axvline(w.warmup_time_s, color=line.get_color(), lw=0.5, ls=":")
    if not drawn:
        placeholder(ax, "no warm-up curve\n(no record from a switch-on)", fontsize=fontsize)
        return
    assert band is not None
    ax.axhspan(-band, band, color="0.85", zorder=0)
    ax.set_xlabel("time since switch-on [s]", fontsize=fontsize)
    ax.set_ylabel("bias - settled bias [deg/h]", fontsize=fontsize)
    ax.set_title("warm-up curves (grey: band; dotted: warm-up time)", fontsize=fontsize)
    ax.legend(fontsize=fontsize * 0.7, ncol=2)


def _temperature_panel(ax: Axes, seq: UnitSequence, fontsize: float) -> None:
    drawn = False
    for a in seq.axes:
        if not a.points:
            continue
        drawn = True
        for direction, marker in (("up", "^"), ("down", "v"), ("plateau", "o")):
            pts = [p for p in a.points if p.direction == direction]
            if pts:
                ax.errorbar([p.temperature_c for p in pts], [p.bias_deg_h for p in pts],
                            yerr=[p.stderr_deg_h for p in pts], fmt=marker, ms=3,
                            label=f"{a.axis} {direction}")
        temps = np.array([p.temperature_c for p in a.points])
        grid = np.linspace(temps.min(), temps.max(), 50)
        for fit, style in ((a.linear, "-"), (a.quadratic, "--")):
            if fit is None:
                continue
            for switch_on in fit.switch_ons:  # a line per switch-on (its own bias)
                on = "" if len(fit.switch_ons) == 1 else f", switch-on {switch_on}"
                ax.plot(grid, fit.bias_deg_h(grid, switch_on), style, lw=0.8,
                        label=f"{a.axis} fit, order {fit.order}{on}")
    if not drawn:
        placeholder(ax, "no bias against temperature\n(no temperature in the records)",
                    fontsize=fontsize)
        return
    ax.set_xlabel("temperature [degC]", fontsize=fontsize)
    ax.set_ylabel("bias [deg/h]", fontsize=fontsize)
    ax.set_title("bias against temperature", fontsize=fontsize)
    ax.legend(fontsize=fontsize * 0.7)


def draw_sequence(axes: list[Axes], seq: UnitSequence, *, fontsize: float = 8) -> None:
    """The three panels into ``axes`` (bias per switch-on, warm-up, temperature)."""
    _bias_panel(axes[0], seq, fontsize)
    _warmup_panel(axes[1], seq, fontsize)
    _temperature_panel(axes[2], seq, fontsize)
    for ax in axes:
        ax.tick_params(labelsize=fontsize * 0.85)
        ax.grid(True, lw=0.3, alpha=0.5)


def sequence_png(seq: UnitSequence) -> bytes:
    """The three panels side by side, as PNG bytes (the HTML sheet)."""
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    draw_sequence(list(axes), seq)
    fig.tight_layout()
    return figure_png(fig)
