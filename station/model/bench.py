"""The bench a unit is tested on: where it is (latitude) and how each gyro axis points.

A bench file is a small TOML file of the station, not of the product (the same profile
is tested in several plants; the latitude is the plant's, the directions the fixture's)::

    # Bench 3, hall B
    name = "bench-3"
    latitude_deg = 45.0          # geodetic latitude, north positive
    height_m = 120.0             # height above the ellipsoid (accelerometers' gravity)
    [axes]                       # each sensitive axis: up, down, north, south, east, west,
    x = "up"                     # or a vector [east, north, up]
    y = "north"
    z = [0.0, -1.0, 0.0]

or, instead of ``[axes]``, ``rotation = [[...], [...], [...]]``: the rows are the body
axes x, y, z in east-north-up axes. Axis names match record columns as profiles do
(``gyro_x`` is ``x``).

``station record --bench FILE`` stores the bench in the run file (root attribute
``bench``, JSON) and hands it to simulated units (which then add the Earth's rotation);
``station analyze``, ``grade`` and ``report`` read it from the run file, or from
``--bench FILE`` (which wins) for any record. The bias figures are then reported with the
Earth-rate projection on each axis removed (:mod:`analysis.units.earth`).
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from analysis.units.earth import (
    Direction,
    OrientationError,
    axis_direction,
    earth_rate_by_axis,
    format_orientation,
    match_axis,
    rotation_rows,
)
from devices.url_text import is_simulated, with_keys
from station.errors import BenchError

_KEYS = {"name", "latitude_deg", "height_m", "axes", "rotation"}


@dataclass(frozen=True)
class Bench:
    """Latitude (deg, None when unknown) and the direction of each named axis."""

    name: str = ""
    latitude_deg: float | None = None
    axes: dict[str, Direction] = field(default_factory=dict)
    path: str = ""
    #: Height above the WGS-84 ellipsoid (m), for the normal gravity of accelerometers.
    height_m: float | None = None

    def earth_rate_deg_h(self, axis_names: Sequence[str]) -> list[float | None]:
        """Earth rate on each axis (deg/h); None where the bench gives no latitude or direction."""
        return earth_rate_by_axis(self.latitude_deg, self.axes, axis_names)

    def direction_text(self, axis_name: str) -> str:
        """How the bench says axis ``axis_name`` points (``up``, ``[0, 0.71, 0.71]``, ``?``)."""
        key = match_axis(axis_name, list(self.axes))
        if key is None and len(self.axes) == 1:
            key = next(iter(self.axes))
        if key is None:
            return "?"
        d = self.axes[key]
        return d if isinstance(d, str) else "[" + ", ".join(f"{v:.3g}" for v in d) + "] (ENU)"

    def as_json(self) -> str:
        """The JSON text stored in a run file."""
        axes = {k: v if isinstance(v, str) else [float(x) for x in v] for k, v in self.axes.items()}
        return json.dumps({"name": self.name, "latitude_deg": self.latitude_deg, "axes": axes,
                           **({"height_m": self.height_m} if self.height_m is not None else {})})

    def sim_url(self, url: str) -> str:
        """A ``sim+`` device URL with the bench's ``latitude`` and ``orientation`` keys added
        (keys the URL already has win); other URLs are returned as they are."""
        if not is_simulated(url) or self.latitude_deg is None or not self.axes:
            return url
        keys = {"latitude": f"{self.latitude_deg:.10g}",
                "orientation": format_orientation(self.axes)}
        return with_keys(url, keys, keep_given=True)


def _number_in(value: Any, key: str, what: str, low: float, high: float, path: str
               ) -> float | None:
    """``value`` as a float in ``low .. high`` (None stays None)."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) \
            or not math.isfinite(value) or not low <= value <= high:
        raise BenchError(f"{path or 'bench'}: {key} must be a number{what} in {low:g} .. "
                         f"{high:g}, got {value!r}")
    return float(value)


def _checked(name: str, latitude: Any, axes: dict[str, Any], path: str,
             height: Any = None) -> Bench:
    latitude = _number_in(latitude, "latitude_deg", "", -90, 90, path)
    height = _number_in(height, "height_m", " of m", -1000, 10000, path)
    for axis, direction in axes.items():
        try:
            axis_direction(direction)
        except OrientationError as exc:
            raise BenchError(f"{path or 'bench'}: axis {axis!r}: {exc}") from exc
    return Bench(str(name), latitude, dict(axes), path, height)


def load_bench(path: str | Path) -> Bench:
    """Read a bench file (see the module docstring).

    Raises
    ------
    BenchError
        Unreadable or not TOML, unknown keys, bad latitude or direction, both ``[axes]``
        and ``rotation`` or neither.
    """
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            table = tomllib.load(fh)
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise BenchError(f"cannot read the bench file {path}: {exc}") from exc
    unknown = sorted(set(table) - _KEYS)
    if unknown:
        raise BenchError(f"{path}: unknown key(s) {', '.join(unknown)}; a bench file has "
                         f"{', '.join(sorted(_KEYS))}")
    if ("axes" in table) == ("rotation" in table):
        raise BenchError(f"{path}: give either an [axes] table (x = \"up\", ...) or a rotation "
                         f"matrix, not {'both' if 'axes' in table else 'neither'}")
    if "axes" in table:
        if not isinstance(table["axes"], dict) or not table["axes"]:
            raise BenchError(f"{path}: [axes] must map axis names to directions")
        axes = dict(table["axes"])
    else:
        try:
            axes = dict(zip(("x", "y", "z"), (list(r) for r in rotation_rows(table["rotation"])),
                            strict=True))
        except OrientationError as exc:
            raise BenchError(f"{path}: {exc}") from exc
    return _checked(table.get("name", path.stem), table.get("latitude_deg"), axes, str(path),
                    table.get("height_m"))


def bench_from_json(text: str) -> Bench | None:
    """The bench stored in a run file ("" or unreadable text: None)."""
    if not text:
        return None
    try:
        doc = json.loads(text)
        return _checked(doc.get("name", ""), doc.get("latitude_deg"), dict(doc.get("axes", {})), "",
                        doc.get("height_m"))
    except (ValueError, AttributeError, TypeError):
        return None


def earth_rate_note(bench: Bench | None, axis: str, removed_deg_h: float | None) -> str:
    """What a report says about the Earth rate of one axis."""
    if removed_deg_h is not None and bench is not None:
        return (f"Earth rate {removed_deg_h:+.4g} deg/h removed from the bias (latitude "
                f"{bench.latitude_deg:g} deg, axis {bench.direction_text(axis)})")
    if bench is None or bench.latitude_deg is None:
        return "Earth rate not removed from the bias: no bench latitude (--bench FILE)"
    return f"Earth rate not removed from the bias: the bench gives no direction for axis {axis!r}"
