"""Matplotlib figures of analysis results, written to PNG files (Agg backend, no display)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from analysis.deviations import DEVIATION_LABELS, from_allan  # noqa: E402
from analysis.fit import TERMS  # noqa: E402
from station.evaluation.analyze import AxisAnalysis  # noqa: E402

TERM_LABELS = {"Q": "quantization", "N": "angle random walk", "B": "bias instability",
               "K": "rate random walk", "R": "rate ramp"}


#: The y-range reaches at most this factor above the highest value plotted: an interval of a
#: tau with two clusters reaches 5x (68 %) or 30x (95 %) above its value and is drawn to the edge.
BAND_HEADROOM = 10.0


def y_range(low: np.ndarray, values: np.ndarray, high: np.ndarray) -> tuple[float, float]:
    """A log y-range that shows every value and interval, capped :data:`BAND_HEADROOM` above."""
    top = float(np.max(values))
    return float(np.min(low)) / 2.0, min(float(np.max(high)) * 1.5, top * BAND_HEADROOM)


def plot_allan(axes: Sequence[AxisAnalysis], path: str | Path, *, title: str = "") -> Path:
    """The deviation of each axis with its confidence band and, on the Allan deviation (deg/h),
    the fitted term lines.

    When another deviation than the fit's Allan deviation was chosen, that deviation is
    drawn with its band, the Allan deviation as a thin line, and the fit lines on it (they
    are the Allan variance's terms); a time deviation (an angle, deg) is drawn alone.
    """
    path = Path(path)
    fig, ax = plt.subplots(figsize=(8, 5.5), dpi=110)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    curve0 = axes[0].shown
    angle = curve0.unit == "angle"
    scale = 1.0 if angle else 3600.0
    own = curve0.kind == from_allan(axes[0].allan).kind
    label = DEVIATION_LABELS[curve0.kind]
    lows, values, highs = [], [], []
    for i, a in enumerate(axes):
        c = colors[i % len(colors)]
        cv = a.shown
        ax.fill_between(cv.tau_s, cv.deviation_ci_low * scale, cv.deviation_ci_high * scale, color=c,
                        alpha=0.2, linewidth=0)
        ax.loglog(cv.tau_s, cv.deviation * scale, "o-", ms=2.5, lw=1, color=c, label=f"{a.name} {cv.kind}")
        lows.append(cv.deviation_ci_low * scale)
        values.append(cv.deviation * scale)
        highs.append(cv.deviation_ci_high * scale)
        if angle:
            continue
        tau = a.allan.tau_s
        if not own:
            ax.loglog(tau, a.allan.adev * 3600, "-", lw=0.8, color=c, alpha=0.6, label=f"{a.name} Allan (fit's)")
        ax.loglog(tau, np.sqrt(a.fit.model_avar(tau)) * 3600, "-", lw=1.5, color=c, alpha=0.8,
                  label=f"{a.name} fit ({a.fit.method})")
        for term in TERMS:
            curve = np.sqrt(a.fit.term_avar(term, tau)) * 3600
            if np.any(curve > 0):
                ax.loglog(tau, curve, ":", lw=1, color=c)
                j = len(tau) // 2 if term == "B" else (0 if term in "QN" else len(tau) - 1)
                ax.annotate(term, (tau[j], curve[j]), color=c, fontsize=8)
    ax.set_ylim(*y_range(np.concatenate(lows), np.concatenate(values), np.concatenate(highs)))
    ax.set_xlabel("averaging time tau [s]")
    ax.set_ylabel(f"{label} [{'deg' if angle else 'deg/h'}]")
    ax.grid(True, which="both", alpha=0.3)
    default = f"{label}, {curve0.confidence:.3g} band" + ("" if angle else ", fitted noise terms (dotted)")
    if not own and not angle:
        default += ": the fit is on the Allan deviation"
    ax.set_title(title or default, fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path
