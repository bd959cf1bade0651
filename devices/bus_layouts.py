"""The frame layouts and register maps a bus URL names: built-in ones (a gyro's and an
IMU's), a TOML file's ``[can]`` / ``[modbus]`` table (a profile, or a layout file beside
it), or a shipped layout file (``profiles/layouts/NAME.toml``), with the URL's ``accel``
switch applied."""

from __future__ import annotations

import os
import tomllib
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, Protocol, Self, TypeVar

from devices.codecs.can_frame import (
    PER_AXIS_IMU_LAYOUT,
    PER_AXIS_LAYOUT,
    SHARED_IMU_LAYOUT,
    SHARED_LAYOUT,
    CanFrameLayout,
)
from devices.codecs.modbus_map import (
    GYRO_FLOAT32_MAP,
    GYRO_INT32_MAP,
    IMU_FLOAT32_MAP,
    IMU_INT32_MAP,
    ModbusRegisterMap,
)
from devices.errors import DeviceConfigurationError
from devices.model_files import shipped_profiles_dir


def _profile_table(name: str, key: str) -> dict[str, Any]:
    try:
        with open(name, "rb") as fh:
            return dict(tomllib.load(fh)[key])
    except (OSError, KeyError, tomllib.TOMLDecodeError) as exc:
        raise DeviceConfigurationError(f"{key} layout {name!r}: not a built-in name, and "
                                       f"no [{key}] table in such a file ({exc})") from exc


class _Layout(Protocol):
    """What a CAN layout and a Modbus map share here: their accelerometer fields."""

    @property
    def accel(self) -> tuple[object, ...]: ...

    def without_accel(self) -> Self: ...


L = TypeVar("L", bound=_Layout)

#: Built-in CAN layouts by name: a gyro's, and an IMU's (with accelerometers).
CAN_LAYOUTS: dict[str, CanFrameLayout] = {
    "shared": SHARED_LAYOUT, "per_axis": PER_AXIS_LAYOUT,
    "shared_imu": SHARED_IMU_LAYOUT, "per_axis_imu": PER_AXIS_IMU_LAYOUT}
#: Built-in Modbus register maps by name: a gyro's, and an IMU's.
MODBUS_MAPS: dict[str, ModbusRegisterMap] = {
    "int32": GYRO_INT32_MAP, "float32": GYRO_FLOAT32_MAP,
    "int32_imu": IMU_INT32_MAP, "float32_imu": IMU_FLOAT32_MAP}


def _named(name: str, builtin: Mapping[str, L], parse: Callable[[Mapping[str, Any]], L],
           key: str, what: str, accel: bool | None, imu_hint: str) -> L:
    """A built-in layout by name, else the ``[key]`` table of the profile file ``name``;
    ``accel`` applied (see :func:`can_layout`)."""
    if name in builtin:
        layout = builtin[name]
    else:
        try:
            layout = parse(_profile_table(name, key))
        except ValueError as exc:
            raise DeviceConfigurationError(f"{what} {name!r}: {exc}") from exc
    if accel and not layout.accel:
        raise DeviceConfigurationError(
            f"accel=1: {what} {name!r} carries no accelerometers ({imu_hint} do)")
    return layout.without_accel() if accel is False else layout


def shipped_can_layout(name: str) -> Path | None:
    """The shipped layout file ``profiles/layouts/NAME.toml`` (None: there is none)."""
    path = shipped_profiles_dir() / "layouts" / f"{name}.toml"
    return path if "/" not in name and path.is_file() else None


def can_layout(name: str, accel: bool | None = None) -> CanFrameLayout:
    """A frame layout by name (``shared``, ``per_axis``; an IMU's ``shared_imu``,
    ``per_axis_imu``), from the ``[can]`` table of a TOML file (a profile, or a layout
    file), or a shipped layout file by its name (``MM7.10``: ``profiles/layouts/MM7.10.toml``).

    ``accel`` is the URL's ``accel`` key (:func:`devices.url_query.accel_switch`): False
    reads an IMU's layout as a gyro's, True refuses a layout without accelerometers, None
    takes the layout as it is.

    Raises
    ------
    DeviceConfigurationError
        Unknown name, unreadable file, a file without a valid ``[can]`` table, or
        ``accel=1`` with a layout that carries no accelerometers.
    """
    shipped = None if name in CAN_LAYOUTS or os.path.exists(name) else shipped_can_layout(name)
    return _named(name if shipped is None else str(shipped), CAN_LAYOUTS,
                  CanFrameLayout.from_table, "can", "CAN layout", accel,
                  "layout=shared_imu, per_axis_imu or a [[can.accel]] table")


def register_map(name: str, accel: bool | None = None) -> ModbusRegisterMap:
    """A register map by name (``int32``, ``float32``; an IMU's ``int32_imu``,
    ``float32_imu``) or from a profile's ``[modbus]``; ``accel`` as :func:`can_layout`.

    Raises
    ------
    DeviceConfigurationError
        Unknown name, bad table, or ``accel=1`` with a map without accelerometers.
    """
    return _named(name, MODBUS_MAPS, ModbusRegisterMap.from_table, "modbus", "Modbus map",
                  accel, "map=int32_imu, float32_imu or a [[modbus.accel]] table")
