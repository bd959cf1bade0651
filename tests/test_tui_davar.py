"""The spec sheet's DAVAR heat map: the grid of a record, its resampling to character
cells coloured by viridis, its text (axes, colour bar), and the DAVAR tab at 80x24."""

from __future__ import annotations

import asyncio
from pathlib import Path

import numpy as np
import pytest
from matplotlib import colormaps

from station.evaluation.davar_map import DavarGrid, davar_grid_of, davar_plan
from station.evaluation.settings import DAVAR_WINDOWS
from station.tui.app import StationApp
from station.tui.heatmap import (
    CONSTANT_LEVEL,
    DavarHeatMap,
    heat_map_cells,
    heat_map_text,
    tau_ticks,
    time_ticks,
)
from station.tui.spec_screen import SpecSheetScreen
from tests.test_tui import SIZE, screen_text, settings, until, write_run

#: Viridis as matplotlib draws it (256 RGB entries), to read a colour back as a level.
VIRIDIS = colormaps["viridis"](np.linspace(0.0, 1.0, 256), bytes=True)[:, :3].astype(int)


def colour_level(rgb: tuple[int, int, int]) -> float:
    """The viridis level in [0, 1] whose colour is nearest ``rgb``."""
    return float(np.argmin(((VIRIDIS - np.asarray(rgb)) ** 2).sum(axis=1)) / 255)


def doubling_grid(n_windows: int = 20, n_tau: int = 30) -> DavarGrid:
    """One hour in ``n_windows`` windows of 180 s; ADEV = a white-noise and a random-walk
    term (deg/h), doubled in every window centred in the second half hour."""
    t = np.linspace(90.0, 3510.0, n_windows)
    tau = np.logspace(-1, np.log10(40.0), n_tau)
    base = 0.5 / np.sqrt(tau) + 0.02 * np.sqrt(tau)
    adev = np.where((t > 1800.0)[:, None], 2.0, 1.0) * base[None, :]
    return DavarGrid("x", t, tau, adev, 180.0)


# -- the grid of a record ---------------------------------------------------------------------

def test_window_plan_covers_the_record_with_half_window_steps() -> None:
    for n in (20, 1799, 1800, 18_000, 4_320_000):
        window, step = davar_plan(n)
        windows = (n - window) // step + 1
        assert window == 2 * step and 1 <= windows <= DAVAR_WINDOWS
        assert n - (windows - 1) * step - window < 2 * step  # the record's end is covered
    assert davar_plan(1) == (0, 0)
    assert davar_plan(4_320_000)[1] == 4_320_000 // (DAVAR_WINDOWS + 1)  # 12 h at 100 Hz


def test_grid_of_a_record_windows_taus_and_units() -> None:
    rng = np.random.default_rng(5)
    rate = rng.standard_normal(36_000) * 0.01  # 1 h at 10 Hz, white rate noise 0.01 deg/s
    grid = davar_grid_of(rate, 10.0, "z")
    assert grid is not None and grid.axis == "z"
    assert len(grid.t_s) == DAVAR_WINDOWS and np.all(np.diff(grid.t_s) > 0)
    assert grid.window_s == pytest.approx(2 * (36_000 // 41) / 10.0)
    assert grid.tau_s[0] == pytest.approx(0.1) and grid.tau_s[-1] <= grid.window_s / 9
    # white rate noise: ADEV(tau0) = sigma = 0.01 deg/s = 36 deg/h in every window
    assert np.allclose(grid.adev_deg_h[:, 0], 36.0, rtol=0.1)


def test_too_short_single_window_and_constant_records() -> None:
    assert davar_grid_of(np.ones(5), 10.0) is None  # not 9 samples in a window
    one = davar_grid_of(np.random.default_rng(1).standard_normal(600), 10.0, "x")
    assert one is not None and len(one.t_s) == 1 and one.t_s[0] == pytest.approx(30.0)
    constant = davar_grid_of(np.full(20_000, 100.3), 10.0, "x")  # rounding left ~1e-23
    assert constant is not None and np.all(constant.adev_deg_h == 0.0)
    with pytest.raises(ValueError, match="n_windows, n_tau"):
        DavarGrid("x", np.arange(3.0), np.arange(1.0, 5.0), np.ones((4, 3)), 1.0)


# -- cells and colours ------------------------------------------------------------------------

def test_doubled_adev_makes_the_right_half_brighter() -> None:
    cells = heat_map_cells(doubling_grid(), 40, 10)
    assert len(cells.cells) == 10 and all(len(row) == 40 for row in cells.cells)
    levels = cells.levels
    assert levels.shape == (20, 40) and not np.isnan(levels).any()
    left, right = levels[:, :20], levels[:, 20:]  # 2 columns a window, split at 30 min
    assert np.all(right.min(axis=1) > left.max(axis=1))  # every tau, all the way across
    assert np.all(cells.t_s[:20] < 1800) and np.all(cells.t_s[20:] > 1800)
    # the colours are viridis of the levels: read back, the right half has larger values
    for r, row in enumerate(cells.cells):
        for j, (upper, lower) in enumerate(row):
            assert upper is not None and lower is not None
            assert colour_level(upper) == pytest.approx(levels[2 * r, j], abs=1 / 255)
            assert colour_level(lower) == pytest.approx(levels[2 * r + 1, j], abs=1 / 255)
        assert colour_level(row[-1][0]) > colour_level(row[0][0])
    # the scale spans the finite ADEV, log10: the extremes are level 0 and 1
    assert cells.adev_min_deg_h == pytest.approx(doubling_grid().adev_deg_h.min())
    assert cells.adev_max_deg_h == pytest.approx(doubling_grid().adev_deg_h.max())
    assert levels.min() == 0.0 and levels.max() == 1.0
    # largest tau at the top; the ADEV minimum (tau = 25 s) is in the rows above the middle
    assert cells.tau_s[0] > cells.tau_s[-1]
    assert np.argmin(levels[:, 0]) < 10


def test_nan_cells_are_blank() -> None:
    grid = doubling_grid(n_tau=20)
    adev = grid.adev_deg_h.copy()
    adev[:10, 15:] = np.nan  # the first half hour has no value at the 5 longest taus
    cells = heat_map_cells(DavarGrid("x", grid.t_s, grid.tau_s, adev, grid.window_s), 40, 10)
    blank = np.isnan(cells.levels)
    assert blank[:, :20].any() and not blank[:, 20:].any() and not blank[10:, :].any()
    for r, row in enumerate(cells.cells):
        for j, (upper, lower) in enumerate(row):
            assert (upper is None) == blank[2 * r, j] and (lower is None) == blank[2 * r + 1, j]
    text, _ = heat_map_text(DavarGrid("x", grid.t_s, grid.tau_s, adev, grid.window_s), 80, 14)
    assert " " in text.plain.splitlines()[1][8:]  # blank cells are spaces, without colour
    nothing = np.full_like(adev, np.nan)
    drawn, cells = heat_map_text(DavarGrid("x", grid.t_s, grid.tau_s, nothing, 1.0), 80, 14)
    assert cells is not None and all(c == (None, None) for row in cells.cells for c in row)
    assert "no finite value" in drawn.plain


def test_constant_grid_is_one_colour_and_says_so() -> None:
    grid = doubling_grid()
    flat = DavarGrid("x", grid.t_s, grid.tau_s, np.full_like(grid.adev_deg_h, 0.25), 180.0)
    cells = heat_map_cells(flat, 30, 6)
    assert cells.constant and np.all(cells.levels == CONSTANT_LEVEL)
    assert len({c for row in cells.cells for c in row}) == 1
    text, _ = heat_map_text(flat, 80, 14)
    assert "ADEV 0.25 deg/h everywhere: constant, one colour" in text.plain
    zero = davar_grid_of(np.full(20_000, 100.3), 10.0, "x")
    assert zero is not None
    text, cells = heat_map_text(zero, 80, 14)
    assert cells is not None and cells.constant and "ADEV 0 deg/h everywhere" in text.plain


def test_single_window_fills_the_width() -> None:
    grid = doubling_grid()
    one = DavarGrid("y", grid.t_s[:1], grid.tau_s, grid.adev_deg_h[:1], 180.0)
    text, cells = heat_map_text(one, 80, 14)
    assert cells is not None and cells.t_range_s == pytest.approx((0.0, 180.0))
    assert np.all(cells.levels == cells.levels[:, :1])  # every column is the one window
    assert "1 window of 3 min" in text.plain


def test_text_layout_axes_and_colour_bar_at_80x14() -> None:
    text, cells = heat_map_text(doubling_grid(), 80, 14)
    lines = text.plain.splitlines()
    assert len(lines) == 14 and all(len(line) <= 80 for line in lines)
    assert lines[0].startswith("DAVAR x: ADEV over run time and tau, 20 windows of 3 min")
    assert cells is not None and len(cells.cells) == 10 and len(cells.cells[0]) == 72
    assert [line[:8] for line in lines[1:11] if "┤" in line[:8]] == [
        "     10┤", "      1┤", "    0.1┤"]
    assert lines[11].startswith("tau [s]└") and lines[12].startswith("t [min]")
    assert lines[12].split()[2:6] == ["0", "10", "20", "30"]
    assert lines[13].startswith("ADEV 0.") and lines[13].endswith("deg/h (log colour)")
    assert heat_map_text(None, 80, 14)[0].plain == "DAVAR: record too short"
    assert "enlarge" in heat_map_text(doubling_grid(), 80, 4)[0].plain


def test_the_discarded_warm_up_is_marked_on_the_time_axis() -> None:
    from dataclasses import replace

    grid = replace(doubling_grid(), warmup_s=900.0)  # 15 min of the hour
    lines = heat_map_text(grid, 80, 14)[0].plain.splitlines()
    assert lines[0].endswith(", ▲ 15 min warm-up")
    axis = lines[11][len("tau [s]└"):]
    assert axis.count("▲") == 1
    # 15 of the 60 minutes the axis spans (its ends are the outer windows' edges)
    assert axis.index("▲") / len(axis) == pytest.approx(0.25, abs=0.03)
    assert "▲" not in heat_map_text(doubling_grid(), 80, 14)[0].plain  # none discarded


def test_ticks() -> None:
    assert tau_ticks((0.1, 10.0), 10) == [(0, "10"), (5, "1"), (9, "0.1")]
    assert [label for _, label in tau_ticks((0.1, 2.0), 10)] == ["1", "0.3", "0.1"]
    narrow = tau_ticks((1.1, 1.3), 4)  # no nice value inside: the ends' own taus
    assert [r for r, _ in narrow] == [0, 3]
    assert time_ticks((0.0, 3600.0), 60) == [(0, "0"), (10, "10"), (20, "20"), (30, "30"),
                                             (40, "40"), (50, "50")]
    assert [label for _, label in time_ticks((0.0, 12 * 3600.0), 72)][:3] == ["0", "120", "240"]


# -- the DAVAR tab ----------------------------------------------------------------------------

@pytest.mark.slow
def test_davar_tab_draws_the_heat_map_at_80x24(tmp_path: Path) -> None:
    asyncio.run(_davar_tab(write_run(tmp_path / "runs" / "run-davar.h5"), tmp_path))


async def _davar_tab(run: Path, tmp_path: Path) -> None:
    app = StationApp(settings(tmp_path, run.parent, check_units=False))
    async with app.run_test(size=SIZE) as pilot:
        sheet = SpecSheetScreen(run, tmp_path / "reports", None)
        await app.push_screen(sheet)
        await until(pilot, lambda: sheet.graded is not None, 40, "the grading")
        await pilot.press("d")
        heat_map = sheet.query_one("#davar-map", DavarHeatMap)
        await until(pilot, lambda: heat_map.grid is not None and heat_map.cells is not None,
                    30, "the DAVAR")
        text = screen_text(app)
        for words in ("DAVAR x: ADEV over run time and tau", "tau [s]", "t [min]",
                      "deg/h (log colour)"):
            assert words in text, words
        cells = heat_map.cells
        assert cells is not None and len(cells.cells) >= 8  # rows of the map at 80x24
        assert len(cells.cells[0]) == heat_map.content_size.width - 8
        assert all(u is not None and v is not None for row in cells.cells for u, v in row)
        assert f"ADEV {cells.adev_min_deg_h:.3g} " in text
        await pilot.resize_terminal(100, 30)  # resampled to the new size
        await until(pilot, lambda: heat_map.cells is not None
                    and len(heat_map.cells.cells[0]) == 100 - 8, 10, "the resize")
        assert len(heat_map.cells.cells) > len(cells.cells)
        await pilot.press("u")  # another unit: the map is computed again for it
        await until(pilot, lambda: "SN-2" in screen_text(app) and heat_map.grid is not None,
                    30, "unit 2's DAVAR")
