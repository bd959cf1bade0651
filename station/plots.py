"""Matplotlib figures of analysis results, written to PNG files (Agg backend, no display)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from analysis.fit import TERMS  # noqa: E402
from station.analyze import AxisAnalysis  # noqa: E402

TERM_LABELS = {"Q": "quantization", "N": "angle random walk", "B": "bias instability",
               "K": "rate random walk", "R": "rate ramp"}


def plot_allan(axes: Sequence[AxisAnalysis], path: str | Path, *, title: str = "") -> Path:
    """Allan deviation (deg/h) of each axis with its confidence band and fitted term lines."""
    path = Path(path)
    fig, ax = plt.subplots(figsize=(8, 5.5), dpi=110)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, a in enumerate(axes):
        c = colors[i % len(colors)]
        tau = a.allan.tau_s
        ax.fill_between(tau, a.allan.adev_ci_low * 3600, a.allan.adev_ci_high * 3600, color=c, alpha=0.2,
                        linewidth=0)
        ax.loglog(tau, a.allan.adev * 3600, "o-", ms=2.5, lw=1, color=c, label=f"{a.name} measured")
        ax.loglog(tau, np.sqrt(a.fit.model_avar(tau)) * 3600, "-", lw=1.5, color=c, alpha=0.8,
                  label=f"{a.name} fit ({a.fit.method})")
        for term in TERMS:
            curve = np.sqrt(a.fit.term_avar(term, tau)) * 3600
            if np.any(curve > 0):
                ax.loglog(tau, curve, ":", lw=1, color=c)
                j = len(tau) // 2 if term == "B" else (0 if term in "QN" else len(tau) - 1)
                ax.annotate(term, (tau[j], curve[j]), color=c, fontsize=8)
    floor = min(float(np.min(a.allan.adev_ci_low)) for a in axes) * 3600 / 5
    ceiling = max(float(np.max(a.allan.adev_ci_high)) for a in axes) * 3600 * 2
    ax.set_ylim(floor, ceiling)  # term lines far below the data say nothing
    ax.set_xlabel("averaging time tau [s]")
    ax.set_ylabel("Allan deviation [deg/h]")
    ax.grid(True, which="both", alpha=0.3)
    ax.set_title(title or "Allan deviation, 1-sigma band, fitted noise terms (dotted)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path
