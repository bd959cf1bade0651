"""The plots of a spec sheet, drawn into matplotlib axes the format writers place.

* :func:`draw_allan`: Allan deviation (deg/h) per axis with its confidence band, the fitted
  noise terms as their slope lines, and the profile's ARW and bias-instability limits; of
  the accelerometer axes, in their own unit (:func:`accel_plot_unit`: m/s^2, or the mg or
  ug the profile gives its accelerometer figures in);
* :func:`draw_davar`: the dynamic Allan deviation heat map of one axis
  (:func:`station.evaluation.davar_map.davar_grid`, the grid the TUI draws too), warm-up
  discarded marked;
* :func:`unit_png`: both for one unit as PNG bytes (HTML embeds them).
"""

from __future__ import annotations

import io
from collections.abc import Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from analysis.errors import AnalysisError  # noqa: E402
from analysis.fit.least_squares import TERMS  # noqa: E402
from analysis.units.conversions import DEG_FAMILY, S_PER_H, UnitFamily  # noqa: E402
from station.evaluation.accel_axes import Quantity  # noqa: E402
from station.evaluation.davar_map import davar_grid  # noqa: E402
from station.evaluation.grading import AxisGrade, UnitGrade  # noqa: E402
from station.evaluation.limits import limit_lines  # noqa: E402
from station.evaluation.settings import AnalysisSettings  # noqa: E402
from station.model.profiles import Profile  # noqa: E402
from station.output.literal_text import draw_literally  # noqa: E402
from station.output.plots import ACCEL_PLOT_UNITS, heat_map  # noqa: E402

TERM_STYLE = {"Q": ("Q", -1.0), "N": ("N", -0.5), "B": ("B", 0.0), "K": ("K", 0.5), "R": ("R", 1.0)}


def accel_plot_unit(profile: Profile | None) -> str:
    """The unit an accelerometer Allan deviation is drawn in: that of the profile's
    accelerometer Allan-minimum, bias-instability or bias figure where it is mg or ug (or
    m/s^2), else m/s^2."""
    if profile is not None:
        by_name = {f.name: f for f in profile.figures}
        for name in ("accel_adev_min", "accel_bias_instability", "accel_bias"):
            spec = by_name.get(name)
            if spec is not None and spec.unit in ACCEL_PLOT_UNITS:
                return spec.unit
    return "m/s^2"


def draw_allan(ax: Axes, axes: Sequence[AxisGrade], *, fontsize: float = 8,
               family: UnitFamily = DEG_FAMILY, quantity: Quantity = "rate",
               accel_unit: str = "m/s^2") -> None:
    """Allan deviation of each rate axis (deg/h, or rad/s in the rad ``family``) with band,
    fit, term lines and limit lines; with ``quantity="acceleration"``, of each accelerometer
    axis instead, in ``accel_unit`` (m/s^2, mg or ug; its limits are in the table)."""
    accel = quantity == "acceleration"
    axes = [a for a in axes if (a.analysis.accel is not None) == accel]
    # the series (deg/s, or m/s^2) -> the unit drawn
    scale = ACCEL_PLOT_UNITS[accel_unit] if accel else S_PER_H * family.factor("deg/h")
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    lows, highs = [], []
    for i, a in enumerate(axes):
        c = colors[i % len(colors)]
        al, fit = a.analysis.allan, a.analysis.fit
        tau = al.tau_s
        ax.fill_between(
            tau, al.adev_ci_low * scale, al.adev_ci_high * scale, color=c, alpha=0.18, lw=0
        )
        ax.loglog(tau, al.adev * scale, "o", ms=2.2, color=c, label=f"{a.axis} measured"
                  + (f" ({'spikes removed' if a.analysis.outliers.removed else 'spikes kept'})"
                     if a.analysis.allan_alternative is not None else ""))
        other = a.analysis.allan_alternative
        if other is not None:  # the curve the other way round, so the spikes' effect shows
            ax.loglog(other.tau_s, other.adev * scale, "x", ms=2.6, mew=0.6, color=c, alpha=0.7,
                      label=f"{a.axis} {a.analysis.alternative_label}")
        ax.loglog(tau, np.sqrt(fit.model_avar(tau)) * scale, "-", lw=1.3, color=c, alpha=0.85,
                  label=f"{a.axis} fit ({fit.method})")
        for term in TERMS:
            curve = np.sqrt(fit.term_avar(term, tau)) * scale
            if np.any(curve > 0):
                ax.loglog(tau, curve, ":", lw=1, color=c)
                j = {"Q": 0, "N": len(tau) // 5, "B": len(tau) // 2}.get(term, len(tau) - 1)
                ax.annotate(TERM_STYLE[term][0], (tau[j], curve[j]), color=c, fontsize=fontsize,
                            xytext=(2, 2), textcoords="offset points")
        lows.append(float(np.min(al.adev_ci_low)) * scale)
        # the band of a two-cluster tau reaches far up (30x at 95 %): drawn to the edge,
        # it must not squeeze the rest of the curve
        highs.append(
            min(float(np.max(al.adev_ci_high)) * 2.5, float(np.max(al.adev)) * 10) * scale
        )
    if axes and not accel:
        _draw_limits(ax, axes[0], fontsize, family)
    if axes:
        ax.set_ylim(min(lows) / 4, max(highs))
    ax.set_xlabel("averaging time tau [s]", fontsize=fontsize + 1)
    unit = accel_unit if accel else family.label("deg/h")
    ax.set_ylabel(f"Allan deviation [{unit}]", fontsize=fontsize + 1)
    ax.tick_params(labelsize=fontsize)
    ax.grid(True, which="both", alpha=0.3)
    # lower left: the curves fall from the upper left, and the long-tau end on the right is
    # where the bias instability and random walk are read
    ax.legend(
        fontsize=fontsize - 1, loc="lower left", ncol=2 if len(axes) > 1 else 1, framealpha=0.85
    )


def _draw_limits(ax: Axes, axis: AxisGrade, fontsize: float, family: UnitFamily) -> None:
    """The deciding grade's ARW limit as a -1/2 line and the bias-instability/Allan-minimum
    limit."""
    for line in limit_lines(axis):
        label = f"{line.label} limit ({line.grade})"
        if line.shape == "level" and line.figure != "adev_min":
            label = f"0.664 x {line.label} limit ({line.grade})"
        if line.shape == "slope":
            ax.loglog(line.tau_s, family.array(line.adev_deg_h, "deg/h"), "--", color="0.3",
                      lw=0.9, label=label)
        else:
            ax.axhline(float(line.adev_deg_h[0]) * family.factor("deg/h"), ls="-.", color="0.3",
                       lw=0.9, label=label)


def draw_davar(
    ax: Axes,
    unit: UnitGrade,
    axis_index: int,
    *,
    fontsize: float = 8,
    settings: AnalysisSettings | None = None,
    family: UnitFamily = DEG_FAMILY,
    accel_unit: str = "m/s^2",
) -> bool:
    """Heat map of log10 dynamic Allan deviation (deg/h, or rad/s in the rad ``family``; an
    accelerometer axis in ``accel_unit``: m/s^2, mg or ug) of one axis over time and tau.

    The whole record is used (the warm-up is what it shows); the discarded warm-up is
    marked. Returns False (and writes why into the panel) when the record is too short.
    """
    axis = unit.axes[axis_index]
    try:
        grid = davar_grid(unit, axis_index, settings=settings)
    except AnalysisError as exc:
        placeholder(ax, f"DAVAR not available: {exc}", fontsize=fontsize)
        return False
    if grid is None:
        placeholder(ax, "DAVAR not available: the record is too short", fontsize=fontsize)
        return False
    hours = unit.unit.record.duration_s > 3 * 3600
    scale, unit_name = (3600.0, "h") if hours else (60.0, "min")
    if axis.analysis.accel is not None:  # the grid holds its m/s^2 in the rate's place
        adev = grid.adev_deg_h / S_PER_H * ACCEL_PLOT_UNITS[accel_unit]
        drawn_unit = accel_unit
    else:
        adev, drawn_unit = family.array(grid.adev_deg_h, "deg/h"), family.label("deg/h")
    log_adev = np.log10(np.maximum(adev, np.finfo(float).tiny))
    mesh = heat_map(ax, grid.t_s / scale, grid.tau_s, log_adev)
    if grid.warmup_s:
        ax.axvline(grid.warmup_s / scale, color="w", ls="--", lw=1)
    ax.set_title(
        f"DAVAR {axis.axis}: log10 ADEV [{drawn_unit}], window {grid.window_s:.0f} s",
        fontsize=fontsize,
    )
    ax.set_xlabel(f"window centre [{unit_name}]", fontsize=fontsize)
    ax.set_ylabel("tau [s]", fontsize=fontsize)
    ax.tick_params(labelsize=fontsize - 1)
    bar = ax.figure.colorbar(mesh, ax=ax, pad=0.02)
    bar.ax.tick_params(labelsize=fontsize - 1)
    return True


def placeholder(ax: Axes, text: str, *, fontsize: float = 8) -> None:
    """A clearly labelled empty panel."""
    ax.set_xticks([])
    ax.set_yticks([])
    ax.text(
        0.5,
        0.5,
        text,
        ha="center",
        va="center",
        wrap=True,
        fontsize=fontsize,
        transform=ax.transAxes,
    )


def figure_png(fig: Figure, *, dpi: int = 110) -> bytes:
    """A figure as PNG bytes (the figure is closed)."""
    buffer = io.BytesIO()
    draw_literally(fig).savefig(buffer, format="png", dpi=dpi)
    plt.close(fig)
    return buffer.getvalue()


def allan_png(unit: UnitGrade, family: UnitFamily = DEG_FAMILY, *,
              quantity: Quantity = "rate", accel_unit: str = "m/s^2") -> bytes:
    """The Allan panel of a unit's rate axes (in ``family``), or of its accelerometer axes
    (in ``accel_unit``), as a PNG."""
    fig, ax = plt.subplots(figsize=(8, 5), layout="constrained")
    draw_allan(ax, unit.axes, fontsize=9, family=family, quantity=quantity,
               accel_unit=accel_unit)
    ax.set_title(ALLAN_TITLES[quantity], fontsize=10)
    return figure_png(fig)


#: Titles of the Allan panels of the rate axes and of the accelerometer axes.
ALLAN_TITLES: dict[str, str] = {
    "rate": "Allan deviation, confidence band, fitted terms (dotted), limits (dashed)",
    "acceleration": "Accelerometers: Allan deviation, confidence band, fitted terms (dotted); "
                    "limits in the table",
}


def has_accel(unit: UnitGrade) -> bool:
    """Whether a unit has accelerometer axes (its sheet draws their Allan deviation too)."""
    return bool(quantity_axes(unit, "acceleration"))


def davar_png(unit: UnitGrade, family: UnitFamily = DEG_FAMILY, *,
              quantity: Quantity = "rate", accel_unit: str = "m/s^2") -> bytes:
    """The DAVAR heat maps of a unit (one per rate axis, in ``family``; or one per
    accelerometer axis, in ``accel_unit``) as a PNG."""
    shown = quantity_axes(unit, quantity)
    n = len(shown)
    fig, axs = plt.subplots(1, n, figsize=(4.2 * n, 3.2), squeeze=False, layout="constrained")
    for k, i in enumerate(shown):
        draw_davar(axs[0, k], unit, i, family=family, accel_unit=accel_unit)
    return figure_png(fig)


def quantity_axes(unit: UnitGrade, quantity: Quantity) -> list[int]:
    """Indices of a unit's rate axes, or of its accelerometer axes."""
    return [i for i, a in enumerate(unit.axes)
            if (a.analysis.accel is not None) == (quantity == "acceleration")]
