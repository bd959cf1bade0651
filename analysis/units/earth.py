"""The Earth's rotation as a static gyro on a bench sees it.

A gyro at rest on the Earth measures the Earth's rotation rate ``Omega_E`` projected on
its sensitive axis. In local east-north-up axes at geodetic latitude ``phi`` the rate is

    Omega_ENU = Omega_E (0, cos phi, sin phi),

so an axis pointing up reads ``Omega_E sin phi`` (10.64 deg/h at 45 deg N), north
``Omega_E cos phi``, east nothing; down, south and west read the negatives. For a
navigation-grade gyro (bias specified at 0.05 deg/h and below) this is hundreds of times
its bias, so a bias figure must say whether it was taken off.

``Omega_E = 7.2921159e-5 rad/s`` (15.041 deg/h, the sidereal rate of the IERS/WGS 84
conventions).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from analysis.units.conversions import S_PER_H

#: Earth rotation rate, rad/s (WGS 84).
EARTH_RATE_RAD_S = 7.2921159e-5
#: Earth rotation rate, deg/h (15.041).
EARTH_RATE_DEG_H = math.degrees(EARTH_RATE_RAD_S) * S_PER_H
#: Unit vectors of the named directions in local east-north-up axes.
DIRECTIONS: dict[str, tuple[float, float, float]] = {
    "east": (1.0, 0.0, 0.0), "west": (-1.0, 0.0, 0.0),
    "north": (0.0, 1.0, 0.0), "south": (0.0, -1.0, 0.0),
    "up": (0.0, 0.0, 1.0), "down": (0.0, 0.0, -1.0),
}


class OrientationError(ValueError):
    """An axis direction that is neither a named direction nor a unit vector."""


def earth_rate_enu_deg_h(latitude_deg: float) -> NDArray[np.float64]:
    """Earth rotation rate in local east-north-up axes (deg/h) at a geodetic latitude (deg).

    Raises
    ------
    ValueError
        A latitude outside -90 .. 90 deg.
    """
    lat = float(latitude_deg)
    if not (math.isfinite(lat) and -90.0 <= lat <= 90.0):
        raise ValueError(f"latitude must be in -90 .. 90 deg, got {latitude_deg!r}")
    phi = math.radians(lat)
    return EARTH_RATE_DEG_H * np.array([0.0, math.cos(phi), math.sin(phi)])


def axis_direction(spec: str | Sequence[float]) -> NDArray[np.float64]:
    """Unit vector (east, north, up) of a sensitive axis: a named direction or a 3-vector.

    A vector is normalised after checking it is not (near) zero; a name is one of
    :data:`DIRECTIONS` (any case).

    Raises
    ------
    OrientationError
        An unknown name, or a vector that is not 3 finite numbers of non-zero length.
    """
    if isinstance(spec, str):
        key = spec.strip().lower()
        if key not in DIRECTIONS:
            raise OrientationError(f"unknown axis direction {spec!r}; use one of "
                                   f"{', '.join(DIRECTIONS)} or a vector [east, north, up]")
        return np.array(DIRECTIONS[key])
    try:
        v = np.asarray(spec, dtype=float).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise OrientationError(f"axis direction {spec!r} is not a name or 3 numbers") from exc
    norm = float(np.linalg.norm(v)) if v.shape == (3,) and np.isfinite(v).all() else 0.0
    if norm < 1e-9:
        raise OrientationError(
            f"axis direction {spec!r} must be 3 finite numbers [east, north, up], not all zero"
        )
    return v / norm


def rotation_rows(matrix: Sequence[Sequence[float]]) -> tuple[NDArray[np.float64], ...]:
    """The body axes x, y, z (rows) of a rotation matrix from body to east-north-up axes.

    Raises
    ------
    OrientationError
        Not a 3 x 3 orthonormal matrix (to 1e-6).
    """
    try:
        r = np.asarray(matrix, dtype=float)
    except (TypeError, ValueError) as exc:
        raise OrientationError("rotation must be 3 rows of 3 numbers") from exc
    if (
        r.shape != (3, 3)
        or not np.isfinite(r).all()
        or not np.allclose(r @ r.T, np.eye(3), atol=1e-6)
    ):
        raise OrientationError(
            "rotation must be an orthonormal 3 x 3 matrix whose rows are the body "
            "axes x, y, z in [east, north, up]"
        )
    return tuple(r)


def earth_rate_on_axis_deg_h(latitude_deg: float, direction: str | Sequence[float]) -> float:
    """Earth rate (deg/h) a static gyro axis pointing in ``direction`` reads at ``latitude_deg``."""
    return float(earth_rate_enu_deg_h(latitude_deg) @ axis_direction(direction))


Direction = str | Sequence[float]


def axis_token(name: str) -> str:
    """The last token of an axis name, lower case (``gyro_x`` -> ``x``)."""
    return re.split(r"[_\-. ]", name.strip().lower())[-1]


def match_axis(name: str, keys: Sequence[str]) -> str | None:
    """The key of ``keys`` that names axis ``name``: the same name, else the same last token
    (``gyro_x`` is ``x``), else the only key for the only axis; None when none does."""
    if name in keys:
        return name
    tokens = [axis_token(k) for k in keys]
    if tokens.count(axis_token(name)) == 1:
        return keys[tokens.index(axis_token(name))]
    return None


def earth_rate_by_axis(latitude_deg: float | None, orientation: Mapping[str, Direction],
                       axis_names: Sequence[str]) -> list[float | None]:
    """Earth rate (deg/h) on each named axis; None for an axis with no direction given.

    With one axis and one direction, the direction is that axis' whatever its name.

    Raises
    ------
    ValueError
        A bad latitude; :class:`OrientationError` for a bad direction.
    """
    if latitude_deg is None:
        return [None] * len(axis_names)
    omega = earth_rate_enu_deg_h(latitude_deg)
    keys = list(orientation)
    directions = {k: axis_direction(v) for k, v in orientation.items()}
    out: list[float | None] = []
    for name in axis_names:
        key = match_axis(name, keys)
        if key is None and len(keys) == 1 and len(axis_names) == 1:
            key = keys[0]
        out.append(None if key is None else float(omega @ directions[key]))
    return out


def parse_orientation(text: str) -> dict[str, Direction]:
    """``x:up,y:north,z:0/0.7071/0.7071`` -> {axis: direction} (the URL form of a bench).

    Raises
    ------
    OrientationError
        An entry that is not ``axis:direction`` or a direction that is not valid.
    """
    out: dict[str, Direction] = {}
    for item in filter(None, (t.strip() for t in text.split(","))):
        axis, sep, direction = item.partition(":")
        if not sep or not axis.strip() or not direction.strip():
            raise OrientationError(f"orientation entry {item!r} is not axis:direction (x:up)")
        value: Direction = direction.strip()
        if "/" in direction:
            try:
                value = [float(v) for v in direction.split("/")]
            except ValueError as exc:
                raise OrientationError(
                    f"orientation {item!r}: a vector is east/north/up numbers"
                ) from exc
        axis_direction(value)
        out[axis.strip()] = value
    return out


def format_orientation(orientation: Mapping[str, Direction]) -> str:
    """The URL form that :func:`parse_orientation` reads."""
    return ",".join(f"{axis}:{d if isinstance(d, str) else '/'.join(f'{float(v):.9g}' for v in d)}"
                    for axis, d in orientation.items())
