"""A DAVAR heat map in the terminal: Allan deviation over window time (x) and log tau (y).

Each character cell holds two vertical pixels, drawn as the upper-half block ``▀`` with
the upper pixel's colour as foreground and the lower pixel's as background; the colour is
matplotlib's ``viridis`` over the finite range of log10 ADEV, and cells without a value
are left blank. The pure part (:func:`heat_map_cells`, the ticks, :func:`heat_map_text`)
takes a :class:`~station.tui.spec_data.DavarGrid` and a size; :class:`DavarHeatMap` is a
thin widget over it that redraws on new data and on resize.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from itertools import groupby
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from rich.color import Color
from rich.style import Style
from rich.text import Text
from textual.app import RenderResult
from textual.events import Resize
from textual.reactive import reactive
from textual.widget import Widget

from station.evaluation.davar_map import DavarGrid
from station.tui.widgets import number

if TYPE_CHECKING:
    from matplotlib.colors import Colormap

RGB = tuple[int, int, int]
#: One character cell: (upper pixel, lower pixel) colour, None where blank.
Cell = tuple[RGB | None, RGB | None]

#: Colormap level of every cell when the ADEV is the same everywhere (zero range).
CONSTANT_LEVEL = 0.5
#: Rows of the layout that are not map: title, time axis, time labels, colour bar.
_FRAME_ROWS = 4
_TAU_UNIT, _TIME_UNIT = "tau [s]", "t [min]"
#: Nice steps of the time axis in minutes.
_MINUTE_STEPS = (0.1, 0.2, 0.5, 1, 2, 5, 10, 15, 20, 30, 60, 120, 180, 240, 360, 720, 1440,
                 2880, 7200, 14400)


@lru_cache(maxsize=1)
def viridis() -> Colormap:
    """matplotlib's ``viridis`` colormap (loaded once: call it off the UI thread first,
    matplotlib takes about 0.4 s to import)."""
    from matplotlib import colormaps

    return colormaps["viridis"]


@lru_cache(maxsize=1)
def _palette() -> tuple[RGB, ...]:
    """The colormap's entries as RGB tuples (shared by every cell: no allocation each)."""
    cmap = viridis()
    table = np.asarray(cmap(np.arange(cmap.N), bytes=True))[:, :3].tolist()
    return tuple((r, g, b) for r, g, b in table)


def palette_index(levels: NDArray[np.float64]) -> NDArray[np.intp]:
    """Entry of the colormap for levels in [0, 1] (matplotlib's own rule: ``int(level N)``,
    clipped to the table; NaN gives 0)."""
    n = len(_palette())
    return np.clip((np.nan_to_num(np.asarray(levels, float)) * n).astype(np.intp), 0, n - 1)


def viridis_rgb(levels: NDArray[np.float64]) -> list[RGB]:
    """The viridis colour of each level in [0, 1] (flattened, in order)."""
    table = _palette()
    return [table[i] for i in palette_index(levels).ravel().tolist()]


@dataclass(frozen=True)
class HeatMapCells:
    """A DAVAR grid resampled to ``rows`` x ``columns`` character cells.

    Attributes
    ----------
    cells : tuple of rows (top to bottom) of :data:`Cell` (left to right)
        (upper, lower) pixel colours, None where the grid has no finite ADEV.
    levels : ndarray, shape (2 rows, columns)
        Colormap level in [0, 1] of each pixel (0 the smallest ADEV, 1 the largest), NaN
        where blank; the pixel rows run from the largest tau (top) down.
    t_s : ndarray, shape (columns,)
        Time in s at the centre of each column.
    tau_s : ndarray, shape (2 rows,)
        Tau in s at the centre of each pixel row, top to bottom.
    t_range_s : tuple of float
        Time at the left and right edges of the map, s.
    tau_range_s : tuple of float
        Tau at the bottom and top edges of the map, s.
    adev_min_deg_h, adev_max_deg_h : float
        Smallest and largest finite ADEV in deg/h (the colour bar's ends); NaN when none.
    """

    cells: tuple[tuple[Cell, ...], ...]
    levels: NDArray[np.float64]
    t_s: NDArray[np.float64]
    tau_s: NDArray[np.float64]
    t_range_s: tuple[float, float]
    tau_range_s: tuple[float, float]
    adev_min_deg_h: float
    adev_max_deg_h: float

    @property
    def constant(self) -> bool:
        """True when every finite ADEV is the same (zero colour range: one colour)."""
        return bool(self.adev_min_deg_h == self.adev_max_deg_h)


def _extent(centres: NDArray[np.float64], half_single: float) -> tuple[float, float]:
    """Edges around increasing centres: half a spacing beyond the first and last."""
    if len(centres) == 1:
        return float(centres[0] - half_single), float(centres[0] + half_single)
    return (float(centres[0] - (centres[1] - centres[0]) / 2),
            float(centres[-1] + (centres[-1] - centres[-2]) / 2))


def _nearest(centres: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.intp]:
    """Index of the nearest of increasing ``centres`` for each ``x``."""
    return np.searchsorted((centres[1:] + centres[:-1]) / 2, x)


def adev_levels(adev_deg_h: NDArray[np.float64]) -> tuple[NDArray[np.float64], float, float]:
    """Colormap level in [0, 1] of each ADEV (log10, over the finite range; a zero ADEV is
    the bottom, NaN/inf are NaN; :data:`CONSTANT_LEVEL` everywhere when the range is
    zero), and the smallest and largest finite ADEV (deg/h; NaN when there is none)."""
    adev = np.asarray(adev_deg_h, dtype=float)
    finite = np.isfinite(adev) & (adev >= 0)
    levels = np.full(adev.shape, np.nan)
    if not finite.any():
        return levels, math.nan, math.nan
    low, high = float(adev[finite].min()), float(adev[finite].max())
    if low == high:
        levels[finite] = CONSTANT_LEVEL
        return levels, low, high
    positive = finite & (adev > 0)
    logs = np.log10(adev[positive])
    span = float(logs.max() - logs.min())
    levels[positive] = (logs - logs.min()) / span if span > 0 else 1.0
    levels[finite & (adev == 0)] = 0.0
    return levels, low, high


def heat_map_cells(grid: DavarGrid, columns: int, rows: int) -> HeatMapCells:
    """Resample ``grid`` to ``columns`` x ``2 rows`` pixels and colour them.

    Each column takes the window whose centre is nearest its centre time, each pixel row
    the tau nearest its centre on the log-tau axis (largest tau at the top); the colour is
    viridis of :func:`adev_levels`.

    Parameters
    ----------
    grid : DavarGrid
        Window centre times (s), taus (s) and ADEV (deg/h).
    columns, rows : int
        Size of the map in character cells (each cell holds two pixels, one above the
        other).

    Returns
    -------
    HeatMapCells

    Raises
    ------
    ValueError
        If ``columns`` or ``rows`` is less than 1.
    """
    if columns < 1 or rows < 1:
        raise ValueError(f"the map needs at least 1 x 1 cells, got {columns} x {rows}")
    t = np.asarray(grid.t_s, dtype=float)
    log_tau = np.log10(np.asarray(grid.tau_s, dtype=float))
    t0, t1 = _extent(t, grid.window_s / 2)
    l0, l1 = _extent(log_tau, 0.5)
    col_t = t0 + (np.arange(columns) + 0.5) * (t1 - t0) / columns
    pix_log_tau = l1 - (np.arange(2 * rows) + 0.5) * (l1 - l0) / (2 * rows)
    levels, low, high = adev_levels(grid.adev_deg_h)
    pixels = levels[_nearest(t, col_t)[None, :], _nearest(log_tau, pix_log_tau)[:, None]]
    table = _palette()
    blank = np.isnan(pixels).tolist()
    rgb = [[None if b else table[i] for i, b in zip(line, blank_line, strict=True)]
           for line, blank_line in zip(palette_index(pixels).tolist(), blank, strict=True)]
    cells = tuple(tuple(zip(rgb[2 * r], rgb[2 * r + 1], strict=True)) for r in range(rows))
    return HeatMapCells(cells, pixels, col_t, 10**pix_log_tau, (t0, t1),
                        (float(10**l0), float(10**l1)), low, high)


# -- axes -------------------------------------------------------------------------------------

def _tau_label(tau_s: float) -> str:
    return f"{tau_s:.0f}" if tau_s >= 100 else f"{tau_s:.2g}"


def tau_ticks(tau_range_s: tuple[float, float], rows: int) -> list[tuple[int, str]]:
    """Labelled rows of the tau axis, ``(row from the top, label in s)``: decades, else
    1-3 or 1-2-5 steps, at least two rows apart; the top and bottom rows' own taus when
    fewer than two nice values fall inside."""
    lo, hi = (math.log10(v) for v in tau_range_s)

    def row_of(tau: float) -> int:  # the bottom edge belongs to the last row
        return min(rows - 1, int((hi - math.log10(tau)) / (hi - lo) * rows))

    ticks: list[tuple[int, str]] = []
    for mantissas in ((1,), (1, 3), (1, 2, 5)):
        ticks = []
        for k in range(math.floor(lo) - 1, math.ceil(hi) + 1):
            for m in mantissas:
                value = m * 10.0**k
                row = row_of(value)
                if lo <= math.log10(value) <= hi and 0 <= row < rows and all(
                        abs(row - r) >= 2 for r, _ in ticks):
                    ticks.append((row, _tau_label(value)))
        if len(ticks) >= min(3, max(2, rows // 3)):
            break
    if len(ticks) < 2:
        step = (hi - lo) / rows
        ticks = [(0, _tau_label(10 ** (hi - step / 2)))]
        if rows > 1:
            ticks.append((rows - 1, _tau_label(10 ** (lo + step / 2))))
    return sorted(ticks)


def time_ticks(t_range_s: tuple[float, float], columns: int,
               spacing: int = 8) -> list[tuple[int, str]]:
    """Labelled columns of the time axis, ``(column, label in min)``: the smallest nice
    step that leaves about ``spacing`` columns per label."""
    t0, t1 = (v / 60.0 for v in t_range_s)
    span = max(t1 - t0, 1e-9)
    per_column = span / columns
    step = next((s for s in _MINUTE_STEPS if s / per_column >= spacing), _MINUTE_STEPS[-1])
    ticks = []
    for i in range(math.ceil(t0 / step - 1e-9), math.floor(t1 / step + 1e-9) + 1):
        col = int((i * step - t0) / per_column)
        if 0 <= col < columns:
            ticks.append((col, f"{i * step:g}"))
    return ticks


def _column_of(t_s: float, t_range_s: tuple[float, float], columns: int) -> int | None:
    """The column of time ``t_s`` (s) on a time axis of ``columns`` over ``t_range_s``,
    None when it is not after the start or falls outside."""
    t0, t1 = t_range_s
    if not t_s > t0 or t1 <= t0:
        return None
    col = int((t_s - t0) / (t1 - t0) * columns)
    return col if col < columns else None


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.3g} s"
    return f"{seconds / 60:.0f} min" if seconds < 7200 else f"{seconds / 3600:.1f} h"


def _colour_bar(cells: HeatMapCells, width: int) -> Text:
    low, high = cells.adev_min_deg_h, cells.adev_max_deg_h
    if math.isnan(low):
        return Text("ADEV: no finite value in the grid", style="dim")
    if cells.constant:
        swatch = viridis_rgb(np.array([CONSTANT_LEVEL]))[0]
        return Text.assemble(("  ", Style(bgcolor=Color.from_rgb(*swatch))),
                             f" ADEV {number(low, 3)} deg/h everywhere: constant, one colour")
    head, tail = f"ADEV {number(low, 3)} ", f" {number(high, 3)} deg/h (log colour)"
    n = width - len(head) - len(tail)
    if n < 3:
        return Text(f"ADEV {number(low, 3)}..{number(high, 3)} deg/h")
    bar = Text()
    for rgb in viridis_rgb(np.linspace(0.0, 1.0, n)):
        bar.append(" ", Style(bgcolor=Color.from_rgb(*rgb)))
    return Text.assemble(head, bar, tail)


@lru_cache(maxsize=256)
def _cell_style(upper: RGB | None, lower: RGB | None) -> tuple[str, Style | None]:
    if upper is None:
        return ("▄", Style(color=Color.from_rgb(*lower))) if lower is not None else (" ", None)
    return "▀", Style(color=Color.from_rgb(*upper),
                      bgcolor=None if lower is None else Color.from_rgb(*lower))


def heat_map_text(grid: DavarGrid | None, width: int, height: int, *,
                  empty_text: str = "record too short") -> tuple[Text, HeatMapCells | None]:
    """The whole heat map as ``height`` lines of at most ``width`` characters: title, map
    with the tau axis on the left, time axis and its labels, colour bar; and the cells
    drawn (None when there is no grid or no room).

    Parameters
    ----------
    grid : DavarGrid or None
        What to draw; None shows ``empty_text``.
    width, height : int
        Size in character cells.
    empty_text : str
        Why there is no grid.
    """
    if grid is None:
        return Text(f"DAVAR: {empty_text}", style="dim", no_wrap=True, overflow="crop"), None
    rows = height - _FRAME_ROWS
    if rows < 1 or width < 20:
        return Text(f"DAVAR {grid.axis}: too small to draw, enlarge the terminal",
                    no_wrap=True, overflow="crop"), None
    windows = "1 window" if len(grid.t_s) == 1 else f"{len(grid.t_s)} windows"
    warmup = (f", ▲ {_duration(grid.warmup_s)} warm-up" if grid.warmup_s > 0
              else "")
    title = Text(f"DAVAR {grid.axis}: ADEV over run time and tau, {windows} of "
                 f"{_duration(grid.window_s)}{warmup}", style="bold", no_wrap=True,
                 overflow="ellipsis")
    ticks = dict(tau_ticks(_extent_of(grid), rows))
    margin = max(len(_TAU_UNIT), *(len(v) for v in ticks.values()))
    columns = width - margin - 1
    cells = heat_map_cells(grid, columns, rows)
    out = Text(no_wrap=True, overflow="crop", end="")
    title.truncate(width, overflow="ellipsis")
    out.append_text(title)
    for r, line in enumerate(cells.cells):
        out.append(f"\n{ticks.get(r, ''):>{margin}}{'┤' if r in ticks else '│'}", style="dim")
        for cell, run in groupby(line):  # a run of equal cells is one span
            char, style = _cell_style(*cell)
            out.append(char * len(list(run)), style)
    t_ticks = time_ticks(cells.t_range_s, columns)
    axis = ["─"] * columns
    labels = [" "] * columns
    free = 0  # first column a label may start at
    for col, label in t_ticks:
        axis[col] = "┬"
        start = min(max(0, col - len(label) // 2), columns - len(label))
        if start >= free:
            labels[start:start + len(label)] = label
            free = start + len(label) + 1
    warmup_col = _column_of(grid.warmup_s, cells.t_range_s, columns)
    if warmup_col is not None:
        axis[warmup_col] = "▲"
    out.append(f"\n{_TAU_UNIT:>{margin}}└", style="dim")
    for char, same in groupby(axis):
        out.append(char * len(list(same)), "bold" if char == "▲" else "dim")
    out.append(f"\n{_TIME_UNIT:>{margin}} {''.join(labels)}", style="dim")
    out.append("\n")
    bar = _colour_bar(cells, width)
    bar.truncate(width)
    out.append_text(bar)
    return out, cells


def _extent_of(grid: DavarGrid) -> tuple[float, float]:
    """Tau at the bottom and top edges of the map of ``grid``, s."""
    lo, hi = _extent(np.log10(np.asarray(grid.tau_s, dtype=float)), 0.5)
    return 10**lo, 10**hi


class DavarHeatMap(Widget):
    """The DAVAR heat map of :attr:`grid` (None: :attr:`empty_text`); redrawn when either
    changes and on resize. :attr:`cells` holds what was last drawn (None if nothing)."""

    DEFAULT_CSS = """
    DavarHeatMap { width: 1fr; height: 1fr; }
    """

    # always_update: a DavarGrid holds arrays, which == cannot compare
    grid: reactive[DavarGrid | None] = reactive(None, always_update=True)
    empty_text: reactive[str] = reactive("waiting for data")

    def __init__(self, *, empty_text: str = "waiting for data", id: str | None = None,
                 classes: str | None = None) -> None:
        super().__init__(id=id, classes=classes)
        self.set_reactive(DavarHeatMap.empty_text, empty_text)
        self.cells: HeatMapCells | None = None
        self._drawn_grid: DavarGrid | None = None
        self._drawn_key: tuple[int, int, str] | None = None
        self._text = Text()

    def show(self, grid: DavarGrid | None, empty_text: str = "record too short") -> None:
        """Draw ``grid``, or ``empty_text`` when it is None."""
        self.empty_text = empty_text
        self.grid = grid

    def on_resize(self, event: Resize) -> None:
        """Resample the grid to the new size."""
        self.refresh()

    def render(self) -> RenderResult:
        """The heat map at the widget's size (recomputed only when the grid, the text or
        the size changed); a failure shows as text, never as a traceback."""
        size = self.content_size
        key = (size.width, size.height, self.empty_text)
        if self.grid is not self._drawn_grid or key != self._drawn_key:
            try:
                self._text, self.cells = heat_map_text(self.grid, size.width, size.height,
                                                       empty_text=self.empty_text)
            except Exception as exc:  # noqa: BLE001 - a plot must not take the app down
                self._text, self.cells = Text(f"DAVAR: cannot draw ({type(exc).__name__}: "
                                              f"{exc})", style="dim"), None
            self._drawn_grid, self._drawn_key = self.grid, key
        return self._text
