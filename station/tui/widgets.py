"""Widgets shared by the screens: a plot of :class:`~station.tui.live.Series` (plotext
through textual-plotext), and the small text helpers every screen formats with."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rich.text import Text
from textual.app import RenderResult
from textual.reactive import reactive
from textual_plotext import PlotextPlot

from station.model.kinds import Verdict, verdict_of_grade
from station.tui.live import Series

#: Verdict -> style of its cell (pass green, fail red, indeterminate yellow).
VERDICT_STYLES: dict[Verdict, str] = {
    "pass": "bold green",
    "fail": "bold red",
    "indeterminate": "bold yellow",
}
#: plotext markers of the series kinds.
_MARKERS = {"line": "braille", "points": "dot", "dashed": "·"}
_DRAW_ORDER = {"dashed": 0, "line": 1, "points": 2}


def hms(seconds: float) -> str:
    """``HH:MM:SS`` of a time in seconds (days as ``Nd HH:MM:SS``)."""
    seconds = max(0, int(round(seconds)))
    days, rest = divmod(seconds, 86400)
    text = f"{rest // 3600:02d}:{rest % 3600 // 60:02d}:{rest % 60:02d}"
    return f"{days}d {text}" if days else text


def count(n: int) -> str:
    """A sample count, short: ``950``, ``12.3k``, ``4.56M``."""
    return f"{n / 1e6:.2f}M" if n >= 1e6 else f"{n / 1e3:.1f}k" if n >= 1e4 else str(n)


def number(value: float | None, digits: int = 4) -> str:
    """A number with ``digits`` significant digits, ``-`` when missing."""
    return "-" if value is None or not np.isfinite(value) else f"{value:.{digits}g}"


def interval_text(low: float | None, high: float | None) -> str:
    """``low..high`` with the fewest significant digits (2 to 4) that tell them apart."""
    for digits in (2, 3, 4):
        lo, hi = number(low, digits), number(high, digits)
        if lo != hi:
            break
    return f"{lo}..{hi}"


def model_name(model: str) -> str:
    """A unit's model for a narrow column: a simulation named by its model file shows the
    file's stem (``profiles/models/VG951.toml`` -> ``VG951``)."""
    if model.endswith(".toml") or "/" in model:
        return Path(model).stem
    return model


def verdict_text(verdict: Verdict | None) -> Text:
    """A verdict cell in its colour (``info`` for an ungraded figure)."""
    if verdict is None:
        return Text("info", style="dim")
    return Text(verdict, style=VERDICT_STYLES[verdict])


def grade_text(grade: str, reject: str) -> Text:
    """A grade in the colour of its verdict."""
    return Text(grade, style=VERDICT_STYLES[verdict_of_grade(grade, reject)])


class SeriesPlot(PlotextPlot):
    """A plot of several series; set :attr:`series` and it redraws.

    Parameters
    ----------
    title, x_label, y_label : str
        Text of the plot, units included (``"rate [deg/h]"``).
    log : bool
        Log-log axes (an Allan deviation): points <= 0 are left out.
    empty_text : str
        Shown while there is nothing to plot.
    """

    series: reactive[tuple[Series, ...]] = reactive((), always_update=True)

    def __init__(self, title: str, x_label: str, y_label: str, *, log: bool = False,
                 empty_text: str = "waiting for data", id: str | None = None,
                 classes: str | None = None) -> None:
        super().__init__(id=id, classes=classes)
        self.plot_title = title
        self.x_label = x_label
        self.y_label = y_label
        self.log_scale = log
        self.empty_text = empty_text

    def on_mount(self) -> None:
        """Draw the empty frame."""
        super().on_mount()
        self.replot()

    def watch_series(self) -> None:
        """Redraw when new series arrive."""
        self.replot()

    def drawn(self) -> list[Series]:
        """The series that will be drawn (finite, and positive on log axes)."""
        out = []
        for s in self.series:
            x, y = np.asarray(s.x, float), np.asarray(s.y, float)
            keep = np.isfinite(x) & np.isfinite(y)
            if self.log_scale:
                keep &= (x > 0) & (y > 0)
            if keep.any():
                out.append(Series(s.label, x[keep], y[keep], s.kind))
        return out

    def replot(self) -> None:
        """Draw :attr:`series` now."""
        plt = self.plt
        plt.clear_data()
        plt.clear_figure()
        plt.title(self.plot_title)
        plt.xlabel(self.x_label)
        plt.ylabel(self.y_label)
        drawn = self.drawn()
        if self.log_scale and drawn:  # plotext cannot draw empty log axes
            plt.xscale("log")
            plt.yscale("log")
        for s in sorted(drawn, key=lambda s: _DRAW_ORDER.get(s.kind, 0)):  # data on top
            if s.kind == "points":
                plt.scatter(s.x.tolist(), s.y.tolist(), label=s.label, marker=_MARKERS[s.kind])
            else:
                plt.plot(s.x.tolist(), s.y.tolist(), label=s.label or None,
                         marker=_MARKERS[s.kind])
        if not drawn:
            plt.title(f"{self.plot_title}: {self.empty_text}")
        self.refresh()

    def render(self) -> RenderResult:
        """The plot; a plotting library failure shows as text, never as a traceback."""
        try:
            return super().render()
        except Exception as exc:  # noqa: BLE001 - a plot must not take the app down
            return Text(f"{self.plot_title}: cannot draw ({type(exc).__name__}: {exc})",
                        style="dim")
