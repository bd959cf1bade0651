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
from analysis.units import S_PER_H  # noqa: E402
from station.analyze import AxisAnalysis  # noqa: E402

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


def plot_wavelet(axes: Sequence[AxisAnalysis], path: str | Path, *, title: str = "") -> Path:
    """Haar wavelet variance ((deg/h)^2) of each axis with its interval, the GMWM model (solid,
    its terms dotted) and the Allan fit's curve as a wavelet variance (dashed, AVAR / 2)."""
    path = Path(path)
    n = len(axes)
    fig, panels = plt.subplots(n, 1, figsize=(8, 4.6 * n), dpi=110, squeeze=False)
    k2 = S_PER_H**2
    for ax, a in zip(panels[:, 0], axes, strict=True):
        g = a.gmwm
        if g is None:
            raise ValueError(f"axis {a.name} has no GMWM result; analyze with method='gmwm'")
        w, fit = g.wavelet, g.best
        tau = w.tau_s
        ax.fill_between(tau, w.ci_low * k2, w.ci_high * k2, color="k", alpha=0.15, lw=0)
        ax.loglog(tau, w.wv * k2, "ko", ms=3.5, label=f"{a.name} empirical WV ({w.ci} interval)")
        dense = np.geomspace(tau[0], tau[-1], 200)
        ax.loglog(dense, fit.model_wv_at(dense) * k2, "-", color="tab:blue", lw=1.8,
                  label=f"GMWM {fit.model.name} (J = {fit.objective:.3g}, {fit.dof} dof)")
        for label, curve in zip(fit.model.term_labels(fit.params), fit.term_wv_at(dense), strict=True):
            if np.any(curve > 0):
                ax.loglog(dense, curve * k2, ":", color="tab:blue", lw=1)
                j = int(np.argmax(curve))
                ax.annotate(label, (dense[j], curve[j] * k2), color="tab:blue", fontsize=8)
        ax.loglog(dense, a.fit.model_avar(dense) / 2.0 * k2, "--", color="tab:red", lw=1.4,
                  label=f"Allan fit ({a.fit.method}) as AVAR/2")
        ax.set_ylim(float(np.min(w.ci_low)) * k2 / 10, float(np.max(w.ci_high)) * k2 * 3)
        ax.set_xlabel("averaging time tau [s]")
        ax.set_ylabel("Haar wavelet variance [(deg/h)^2]")
        ax.grid(True, which="both", alpha=0.3)
        ax.set_title(f"{title} {a.name}".strip(), fontsize=9)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path
