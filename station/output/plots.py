"""Matplotlib figures of analysis results, written to PNG files (Agg backend, no display)."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from analysis.allan.deviations import DEVIATION_LABELS, from_allan  # noqa: E402
from analysis.davar.estimators import DavarResult  # noqa: E402
from analysis.davar.warmup import WarmupVerdict  # noqa: E402
from analysis.fit.least_squares import TERMS  # noqa: E402
from analysis.units.conversions import DEG_FAMILY, S_PER_H, STANDARD_GRAVITY_M_S2, UnitFamily  # noqa: E402
from station.evaluation.analyze import AxisAnalysis  # noqa: E402
from station.model.records import RateRecord  # noqa: E402
from station.output.colors import VERDICT_COLORS  # noqa: E402
from station.output.literal_text import draw_literally  # noqa: E402
from station.output.results import TrendPoint  # noqa: E402
from station.storage.atomic_files import replacing  # noqa: E402

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.collections import QuadMesh
    from matplotlib.figure import Figure

TERM_LABELS = {"Q": "quantization", "N": "angle random walk", "B": "bias instability",
               "K": "rate random walk", "R": "rate ramp"}


#: The y-range reaches at most this factor above the highest value plotted: an interval of a
#: tau with two clusters reaches 5x (68 %) or 30x (95 %) above its value and is drawn to the edge.
BAND_HEADROOM = 10.0


#: Units an accelerometer axis' deviation may be drawn in: factor from m/s^2 (a time
#: deviation, m/s, is drawn in m/s whatever the unit).
ACCEL_PLOT_UNITS = {"m/s^2": 1.0, "mg": 1e3 / STANDARD_GRAVITY_M_S2,
                    "ug": 1e6 / STANDARD_GRAVITY_M_S2}


def drawn_unit(axis: AxisAnalysis, family: UnitFamily, accel_unit: str = "m/s^2"
               ) -> tuple[str, float, float]:
    """(unit label, factor of the shown deviation, factor of the Allan deviation and its fit
    lines) of ``axis``: deg/h (or rad/s in the rad ``family``) for a rate axis, deg (rad) for
    its time deviation; ``accel_unit`` of :data:`ACCEL_PLOT_UNITS` for an accelerometer axis,
    m/s for its time deviation.

    Raises
    ------
    ValueError
        ``accel_unit`` not one of :data:`ACCEL_PLOT_UNITS`.
    """
    if accel_unit not in ACCEL_PLOT_UNITS:
        raise ValueError(f"accelerometer plot unit must be one of "
                         f"{', '.join(ACCEL_PLOT_UNITS)}, got {accel_unit!r}")
    angle = axis.shown.unit == "angle"
    if axis.accel is not None:
        factor = ACCEL_PLOT_UNITS[accel_unit]
        return ("m/s", 1.0, factor) if angle else (accel_unit, factor, factor)
    rate = S_PER_H * family.factor("deg/h")  # deg/s -> the rate unit drawn
    if angle:
        return family.label("deg"), family.factor("deg"), rate
    return family.label("deg/h"), rate, rate


def y_range(low: np.ndarray, values: np.ndarray, high: np.ndarray) -> tuple[float, float]:
    """A log y-range that shows every value and interval, capped :data:`BAND_HEADROOM` above."""
    top = float(np.max(values))
    return float(np.min(low)) / 2.0, min(float(np.max(high)) * 1.5, top * BAND_HEADROOM)


def plot_allan(axes: Sequence[AxisAnalysis], path: str | Path, *, title: str = "",
               family: UnitFamily = DEG_FAMILY, accel_unit: str = "m/s^2") -> Path:
    """:func:`allan_figure` into a PNG at ``path``."""
    return _save(allan_figure(axes, title=title, family=family, accel_unit=accel_unit),
                 Path(path))


def _save(fig: Figure, path: Path, dpi: float | None = None) -> Path:
    """Write ``fig`` to ``path`` (at ``dpi``, default the figure's; whole or not at all,
    :func:`replacing`) and close it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        with replacing(path) as tmp:
            draw_literally(fig).savefig(tmp, dpi="figure" if dpi is None else dpi)
    finally:
        plt.close(fig)
    return path


def allan_figure(axes: Sequence[AxisAnalysis], *, title: str = "",
                 family: UnitFamily = DEG_FAMILY, accel_unit: str = "m/s^2") -> Figure:
    """The deviation of each axis with its confidence band and, on the Allan deviation (deg/h,
    or rad/s in the rad ``family``; accelerometer axes in ``accel_unit``: m/s^2, mg or ug),
    the fitted term lines.

    When another deviation than the fit's Allan deviation was chosen, that deviation is
    drawn with its band, the Allan deviation as a thin line, and the fit lines on it (they
    are the Allan variance's terms); a time deviation (an angle, deg or rad; m/s for an
    accelerometer) is drawn alone.

    Raises
    ------
    ValueError
        Rate and accelerometer axes mixed in one figure (their units differ), or an
        unknown ``accel_unit``.
    """
    if len({a.accel is None for a in axes}) > 1:
        raise ValueError("rate and accelerometer axes go in separate Allan plots "
                         "(deg/h and m/s^2): pass one kind at a time")
    fig, ax = plt.subplots(figsize=(8, 5.5), dpi=110)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    curve0 = axes[0].shown
    angle = curve0.unit == "angle"
    unit, scale, rate = drawn_unit(axes[0], family, accel_unit)
    own = curve0.kind == from_allan(axes[0].allan).kind
    label = DEVIATION_LABELS[curve0.kind]
    lows, values, highs = [], [], []
    for i, a in enumerate(axes):
        c = colors[i % len(colors)]
        cv = a.shown
        ax.fill_between(
            cv.tau_s,
            cv.deviation_ci_low * scale,
            cv.deviation_ci_high * scale,
            color=c,
            alpha=0.2,
            linewidth=0,
        )
        ax.loglog(
            cv.tau_s, cv.deviation * scale, "o-", ms=2.5, lw=1, color=c, label=f"{a.name} {cv.kind}"
        )
        lows.append(cv.deviation_ci_low * scale)
        values.append(cv.deviation * scale)
        highs.append(cv.deviation_ci_high * scale)
        if angle:
            continue
        tau = a.allan.tau_s
        if not own:
            ax.loglog(
                tau,
                a.allan.adev * rate,
                "-",
                lw=0.8,
                color=c,
                alpha=0.6,
                label=f"{a.name} Allan (fit's)",
            )
        ax.loglog(tau, np.sqrt(a.fit.model_avar(tau)) * rate, "-", lw=1.5, color=c, alpha=0.8,
                  label=f"{a.name} fit ({a.fit.method})")
        for term in TERMS:
            curve = np.sqrt(a.fit.term_avar(term, tau)) * rate
            if np.any(curve > 0):
                ax.loglog(tau, curve, ":", lw=1, color=c)
                j = len(tau) // 2 if term == "B" else (0 if term in "QN" else len(tau) - 1)
                ax.annotate(term, (tau[j], curve[j]), color=c, fontsize=8)
    ax.set_ylim(*y_range(np.concatenate(lows), np.concatenate(values), np.concatenate(highs)))
    ax.set_xlabel("averaging time tau [s]")
    ax.set_ylabel(f"{label} [{unit}]")
    ax.grid(True, which="both", alpha=0.3)
    default = f"{label}, {curve0.confidence:.3g} band" + (
        "" if angle else ", fitted noise terms (dotted)"
    )
    if not own and not angle:
        default += ": the fit is on the Allan deviation"
    ax.set_title(title or default, fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _edges(centres: np.ndarray, *, log: bool) -> np.ndarray:
    """Cell edges around sorted centres (geometric midpoints when ``log``)."""
    c = np.log(centres) if log else np.asarray(centres, dtype=float)
    if len(c) == 1:
        edges = np.array([c[0] - 0.5, c[0] + 0.5])
    else:
        mid = (c[1:] + c[:-1]) / 2
        edges = np.concatenate([[2 * c[0] - mid[0]], mid, [2 * c[-1] - mid[-1]]])
    return np.exp(edges) if log else edges


def heat_map(ax: Axes, t: np.ndarray, tau_s: np.ndarray, values: np.ndarray) -> QuadMesh:
    """A DAVAR heat map: ``values`` (shape (len(t), len(tau_s))) over time ``t`` (x, in the
    caller's unit) and tau (y, s, log scale), viridis; an image in a PDF, not thousands of
    paths."""
    mesh = ax.pcolormesh(_edges(t, log=False), _edges(tau_s, log=True), values.T,
                         shading="flat", cmap="viridis", rasterized=True)
    ax.set_yscale("log")
    return mesh


def plot_davar(path: Path, result: DavarResult, verdicts: Sequence[WarmupVerdict],
               record: RateRecord, family: UnitFamily = DEG_FAMILY, *,
               accel: bool = False) -> Path:
    """:func:`davar_figure` into a PNG at ``path``."""
    return _save(davar_figure(result, verdicts, record, family, accel=accel), Path(path),
                 dpi=110)


def davar_figure(result: DavarResult, verdicts: Sequence[WarmupVerdict], record: RateRecord,
                 family: UnitFamily = DEG_FAMILY, *, accel: bool = False) -> Figure:
    """Heat map per axis: time on x, log tau on y, log10 ADEV (deg/h, or rad/s in the rad
    ``family``; m/s^2 for accelerometer axes, ``accel``: ``record`` holds their m/s^2 in
    the rate's place) as colour."""
    scale = 1.0 if accel else S_PER_H * family.factor("deg/h")  # the series -> the unit drawn
    unit = "m/s^2" if accel else family.label("deg/h")
    n_axes = len(record.axis_names)
    fig, axs = plt.subplots(n_axes, 1, figsize=(9, 2.8 * n_axes + 0.6), squeeze=False,
                            sharex=True, constrained_layout=True)
    for i, (name, verdict) in enumerate(zip(record.axis_names, verdicts, strict=True)):
        ax = axs[i, 0]
        log_adev = np.log10(np.maximum(result.axis(i).adev * scale, np.finfo(float).tiny))
        mesh = heat_map(ax, result.t_s, result.tau_s, log_adev)
        ax.set_ylabel("tau (s)")
        ax.set_title(
            f"{Path(record.source).name or 'record'}: {name}, window {result.window_s:g} s"
        )
        if verdict.warmup_end_s:
            ax.axvline(verdict.warmup_end_s, color="w", ls="--", lw=1.2,
                       label=f"warm-up end {verdict.warmup_end_s:g} s")
            ax.legend(loc="upper right", fontsize=8)
        fig.colorbar(mesh, ax=ax, label=f"log10 ADEV ({unit})")
    axs[-1, 0].set_xlabel("window centre time since start (s)")
    return fig


def _date(text: str) -> datetime | None:
    try:
        return datetime.fromisoformat(text.replace("Z", "+00:00"))
    except ValueError:
        return None


def plot_trend(figure: str, points: list[TrendPoint], path: Path) -> Path:
    """PNG of a figure over test dates: value with its interval, limit, verdict as colour."""
    dates = [_date(p.test_date) for p in points]
    xs: list = dates if all(dates) else list(range(len(points)))
    fig, ax = plt.subplots(figsize=(9, 4.5), layout="constrained")
    for x, p in zip(xs, points, strict=True):
        if p.value is None:
            continue
        low = p.value - (p.ci_low if p.ci_low is not None else p.value)
        high = (p.ci_high if p.ci_high is not None else p.value) - p.value
        edge = {"pass": "#2e7d32", "fail": "#c62828", "indeterminate": "#b8860b"}.get(
            p.verdict or "", "0.3"
        )
        ax.errorbar([x], [p.value], yerr=[[low], [high]], fmt="o", ms=5, color=edge,
                    mfc=VERDICT_COLORS.get(p.verdict, "white"), capsize=2)
    limits = [(x, p.limit) for x, p in zip(xs, points, strict=True) if p.limit is not None]
    if limits:
        ax.step(
            [x for x, _ in limits],
            [v for _, v in limits],
            "--",
            color="0.3",
            where="post",
            label="limit",
        )
        ax.legend()
    unit = points[0].unit if points else ""
    ax.set_ylabel(f"{figure} [{unit}]")
    ax.set_xlabel("test date (UTC)" if xs is dates else "grading")
    ax.set_title(
        f"{figure}: value and confidence interval per unit and axis ({len(points)} points)"
    )
    ax.grid(True, alpha=0.3)
    fig.autofmt_xdate()
    return _save(fig, path, dpi=110)


def draw_wavelet(ax: Axes, a: AxisAnalysis, *, fontsize: float = 8, title: str = "",
                 family: UnitFamily = DEG_FAMILY, accel_unit: str = "m/s^2") -> None:
    """One axis' Haar wavelet variance ((deg/h)^2, or (rad/s)^2 in the rad ``family``; an
    accelerometer axis in ``accel_unit`` squared) with its interval, the GMWM model (solid,
    its terms dotted) and the Allan fit's curve as a wavelet variance (dashed, AVAR / 2).

    Raises
    ------
    ValueError
        The axis has no GMWM result.
    """
    g = a.gmwm
    if g is None:
        raise ValueError(f"axis {a.name} has no GMWM result; analyze with method='gmwm'")
    if a.accel is not None:  # its series is in m/s^2
        k, unit = ACCEL_PLOT_UNITS[accel_unit], accel_unit
    else:
        k, unit = S_PER_H * family.factor("deg/h"), family.label("deg/h")
    k2 = k**2  # the series' unit squared -> the unit drawn
    w, fit = g.wavelet, g.best
    tau = w.tau_s
    ax.fill_between(tau, w.ci_low * k2, w.ci_high * k2, color="k", alpha=0.15, lw=0)
    ax.loglog(tau, w.wv * k2, "ko", ms=3.5, label=f"{a.name} empirical WV ({w.ci} interval)")
    dense = np.geomspace(tau[0], tau[-1], 200)
    ax.loglog(dense, fit.model_wv_at(dense) * k2, "-", color="tab:blue", lw=1.8,
              label=f"GMWM {fit.model.name} (J = {fit.objective:.3g}, {fit.dof} dof)")
    terms = zip(fit.model.term_labels(fit.params), fit.term_wv_at(dense), strict=True)
    for label, curve in terms:
        if np.any(curve > 0):
            ax.loglog(dense, curve * k2, ":", color="tab:blue", lw=1)
            j = int(np.argmax(curve))
            ax.annotate(label, (dense[j], curve[j] * k2), color="tab:blue", fontsize=fontsize)
    ax.loglog(dense, a.fit.model_avar(dense) / 2.0 * k2, "--", color="tab:red", lw=1.4,
              label=f"Allan fit ({a.fit.method}) as AVAR/2")
    ax.set_ylim(float(np.min(w.ci_low)) * k2 / 10, float(np.max(w.ci_high)) * k2 * 3)
    ax.set_xlabel("averaging time tau [s]", fontsize=fontsize + 1)
    ax.set_ylabel(f"Haar wavelet variance [({unit})^2]", fontsize=fontsize + 1)
    ax.tick_params(labelsize=fontsize)
    ax.grid(True, which="both", alpha=0.3)
    ax.set_title(f"{title} {a.name}".strip(), fontsize=fontsize + 1)
    ax.legend(fontsize=fontsize)


def plot_wavelet(axes: Sequence[AxisAnalysis], path: str | Path, *, title: str = "",
                 family: UnitFamily = DEG_FAMILY, accel_unit: str = "m/s^2") -> Path:
    """:func:`wavelet_figure` into a PNG at ``path``."""
    return _save(wavelet_figure(axes, title=title, family=family, accel_unit=accel_unit),
                 Path(path))


def wavelet_figure(axes: Sequence[AxisAnalysis], *, title: str = "",
                   family: UnitFamily = DEG_FAMILY, accel_unit: str = "m/s^2") -> Figure:
    """:func:`draw_wavelet` of each axis, one panel each (each in its own unit)."""
    n = len(axes)
    fig, panels = plt.subplots(n, 1, figsize=(8, 4.6 * n), dpi=110, squeeze=False)
    for ax, a in zip(panels[:, 0], axes, strict=True):
        draw_wavelet(ax, a, title=title, family=family, accel_unit=accel_unit)
    fig.tight_layout()
    return fig
