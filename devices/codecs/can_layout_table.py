"""A raw CAN layout written down as a TOML ``[can]`` table: its keys, checked (pure).

A user describes their own unit in such a table, in a layout file or in a profile
(``docs/how-to/write-a-can-layout.md``; the shipped example is the Bosch MM7.10,
``profiles/layouts/MM7.10.toml``). Every key and its default::

    dlc = 8                   # data bytes per frame
    crc = "e2e_p01"           # AUTOSAR E2E Profile 1 CRC, or "none"
    crc_byte = 7
    data_id = 0               # Profile 1 DataID (0..0xFFFF)
    data_id_mode = "both"     # "both", "low", "alt" or "nibble"
    counter_byte = 6
    counter_bits = 8          # 4 (a nibble), 8, or 0: no counter
    counter_nibble = "low"    # a 4-bit counter's nibble: "low" or "high"
    counter_modulus = 0       # 0: 15 for 4 bits (Profile 1: 0..14), 256 for 8 bits
    [[can.axes]]              # one per rate axis, deg/s: raw * scale + offset
    arbitration_id = 0x181
    start_byte = 0
    length = 4                # bytes, 1..4
    signed = true
    byte_order = "little"     # or "big"
    scale = 1e-6
    offset = 0.0
    name = "RollRate"         # optional, for the reader
    [can.temperature]         # optional, degC, keys as an axis
    [[can.accel]]             # optional, one per accelerometer axis, m/s^2
    [[can.status]]            # optional status fields
    arbitration_id = 0x178
    start_bit = 20            # bit 8 k + i is bit i of byte k
    bits = 4
    invalid_mask = 0x7        # the bits that flag a sample not valid (default: all)
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from devices.codecs.can_signals import CanBitField, CanSignal
from devices.errors import CodecError

_INT_KEYS = ("counter_byte", "counter_bits", "counter_modulus", "crc_byte", "data_id", "dlc")
_TEXT_KEYS = ("counter_nibble", "crc", "data_id_mode")
_TABLE_KEYS = ("axes", "temperature", "accel", "status")
_SIGNAL_KEYS = {"arbitration_id": int, "start_byte": int, "length": int, "signed": bool,
                "byte_order": str, "scale": float, "offset": float, "name": str}
_STATUS_KEYS = {"arbitration_id": int, "start_bit": int, "bits": int, "invalid_mask": int,
                "name": str}
_REQUIRED = {"signal": ("arbitration_id", "start_byte", "length"),
             "status": ("arbitration_id", "start_bit", "bits")}


def _value(where: str, key: str, value: Any, kind: type) -> Any:
    """``value`` checked against ``kind`` (an int is a float too; a bool is no int)."""
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if not isinstance(value, kind) or kind is int and isinstance(value, bool):
        raise CodecError(f"{where}.{key}: expected {kind.__name__}, got {value!r}")
    return value


def _entry(where: str, table: Any, keys: Mapping[str, type], what: str) -> dict[str, Any]:
    """The keys of one signal or status table, checked; ``name`` dropped."""
    if not isinstance(table, Mapping):
        raise CodecError(f"{where}: expected a table, got {table!r}")
    unknown = sorted(set(table) - set(keys))
    if unknown:
        raise CodecError(f"{where}: unknown key(s) {', '.join(unknown)} (known: "
                         f"{', '.join(keys)})")
    missing = [k for k in _REQUIRED[what] if k not in table]
    if missing:
        raise CodecError(f"{where}: missing key(s) {', '.join(missing)}")
    return {k: _value(where, k, v, keys[k]) for k, v in table.items() if k != "name"}


def _signals(table: Mapping[str, Any], key: str) -> tuple[CanSignal, ...]:
    entries = table.get(key, ())
    if not isinstance(entries, list | tuple):
        raise CodecError(f"can.{key}: expected an array of tables ([[can.{key}]])")
    return tuple(CanSignal(**_entry(f"can.{key}[{i}]", t, _SIGNAL_KEYS, "signal"))
                 for i, t in enumerate(entries))


def layout_options(table: Mapping[str, Any]) -> dict[str, Any]:
    """The keyword arguments of :class:`~devices.codecs.can_frame.CanFrameLayout` a
    ``[can]`` table gives (keys and defaults: the module's docstring).

    Parameters
    ----------
    table : mapping
        The parsed ``[can]`` table.

    Returns
    -------
    dict
        ``axes``, ``accel``, ``temperature``, ``status`` and the table's scalar keys.

    Raises
    ------
    CodecError
        A missing, unknown or mistyped key, named in the message.
    """
    unknown = sorted(set(table) - {*_INT_KEYS, *_TEXT_KEYS, *_TABLE_KEYS})
    if unknown:
        raise CodecError(f"[can]: unknown key(s) {', '.join(unknown)}")
    if "axes" not in table:
        raise CodecError("[can]: no [[can.axes]] (one table per rate axis)")
    options: dict[str, Any] = {k: _value("can", k, table[k], int) for k in _INT_KEYS
                               if k in table}
    options.update((k, _value("can", k, table[k], str)) for k in _TEXT_KEYS if k in table)
    temp = table.get("temperature")
    status = table.get("status", ())
    if not isinstance(status, list | tuple):
        raise CodecError("can.status: expected an array of tables ([[can.status]])")
    options["axes"] = _signals(table, "axes")
    options["accel"] = _signals(table, "accel")
    options["temperature"] = None if temp is None else CanSignal(
        **_entry("can.temperature", temp, _SIGNAL_KEYS, "signal"))
    options["status"] = tuple(
        CanBitField(**_entry(f"can.status[{i}]", t, _STATUS_KEYS, "status"))
        for i, t in enumerate(status))
    return options
