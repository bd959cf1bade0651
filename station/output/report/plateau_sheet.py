"""What a spec sheet shows of a temperature test's plateaus: a table, and their Allan
deviations overlaid on one plot.

Each plateau (:class:`station.evaluation.sequence_plateaus.Plateau`) is a row: axis, set
point, measured temperature, bias, ARW and bias instability with their intervals, the
time analysed. The plot draws every plateau's Allan deviation (deg/h) with its
confidence band, coloured by temperature (blue cold, red hot), so a noise that grows
with temperature shows as curves stacked in colour order.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402

from analysis.units.conversions import S_PER_H  # noqa: E402
from station.evaluation.sequence_plateaus import Plateau  # noqa: E402
from station.output.report.common import fmt, fmt_interval  # noqa: E402
from station.output.report.panels import figure_png, placeholder  # noqa: E402

#: The table's columns: (heading, unit).
PLATEAU_COLUMNS = (("axis", ""), ("set point", "degC"), ("temperature", "degC"),
                   ("bias", "deg/h"), ("ARW", "deg/sqrt(h)"), ("ARW interval", "deg/sqrt(h)"),
                   ("bias instability", "deg/h"), ("BI interval", "deg/h"),
                   ("analysed", "s"))


def plateau_cells(p: Plateau) -> list[str]:
    """One row of the table, as text (the columns of :data:`PLATEAU_COLUMNS`)."""
    return [p.axis, fmt(p.set_point_c), fmt(p.temperature_c), fmt(p.bias_deg_h),
            fmt(p.arw.value), fmt_interval(p.arw.low, p.arw.high),
            fmt(p.bias_instability.value),
            fmt_interval(p.bias_instability.low, p.bias_instability.high),
            fmt(p.duration_s)]


def plateau_headings(*, sep: str = " ") -> list[str]:
    """The column headings with their units (``sep`` between name and unit)."""
    return [f"{name}{sep}[{unit}]" if unit else name for name, unit in PLATEAU_COLUMNS]


def plateau_lines(plateaus: tuple[Plateau, ...]) -> list[str]:
    """The plateaus as plain text lines (``station grade``'s table); none without plateaus."""
    if not plateaus:
        return []
    rows = [plateau_headings()] + [plateau_cells(p) for p in plateaus]
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["temperature plateaus (Allan analysis of each):"]
    lines += ["  " + "  ".join(f"{c:>{w}}" for c, w in zip(r, widths, strict=True))
              for r in rows]
    return lines


def draw_plateaus(ax: Axes, plateaus: tuple[Plateau, ...], *, fontsize: float = 8) -> None:
    """Every plateau's Allan deviation (deg/h) with its band, coloured by temperature."""
    drawn = [p for p in plateaus if p.allan is not None]
    if not drawn:
        placeholder(ax, "no Allan deviation of a temperature plateau", fontsize=fontsize)
        return
    temps = np.array([p.temperature_c for p in drawn])
    low, high = float(temps.min()), float(temps.max())
    cmap = plt.get_cmap("coolwarm")
    axes_named = len({p.axis for p in drawn}) > 1
    for p in drawn:
        allan = p.allan
        assert allan is not None
        color = cmap(0.5 if high == low else (p.temperature_c - low) / (high - low))
        ax.fill_between(allan.tau_s, allan.adev_ci_low * S_PER_H, allan.adev_ci_high * S_PER_H,
                        color=color, alpha=0.12, lw=0)
        label = (f"{p.axis} " if axes_named else "") + (
            f"{p.set_point_c:g} degC set, {p.temperature_c:.1f} degC measured")
        ax.loglog(allan.tau_s, allan.adev * S_PER_H, "o-", ms=2, lw=0.8, color=color,
                  label=label)
    ax.set_xlabel("averaging time tau [s]", fontsize=fontsize)
    ax.set_ylabel("Allan deviation [deg/h]", fontsize=fontsize)
    ax.set_title("Allan deviation of each temperature plateau (band: confidence interval)",
                 fontsize=fontsize)
    ax.grid(True, which="both", lw=0.3, alpha=0.5)
    ax.tick_params(labelsize=fontsize * 0.85)
    ax.legend(fontsize=fontsize * 0.75, loc="lower left", ncol=2 if len(drawn) > 6 else 1)


def plateau_png(plateaus: tuple[Plateau, ...]) -> bytes:
    """The overlay as PNG bytes (the HTML sheet)."""
    fig, ax = plt.subplots(figsize=(8, 4.5))
    draw_plateaus(ax, plateaus)
    fig.tight_layout()
    return figure_png(fig)
