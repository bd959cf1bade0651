"""The query part of a device URL: each key once, and only keys the scheme knows.

A misspelt key (``dorp=0.5``) silently ignored, or a repeated one (``drop=0.1&drop=0.5``)
of which the last wins, records a night with settings nobody asked for: both are refused
with a message that names the key.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from urllib.parse import parse_qsl

from devices.errors import DeviceConfigurationError
from devices.sim.params import BENCH_KEYS, FAULT_KEYS, FIXTURE_KEYS

#: Keys every simulated device takes (``sim+`` URLs): the noise model, rate, warp, seed,
#: history, the fault knobs, where the gyro sits on its bench (latitude, orientation) and
#: the simulated fixture powering it with its turn-on behaviour.
SIM_KEYS = frozenset({"model", "rate", "warp", "seed", "history", *FAULT_KEYS, *BENCH_KEYS,
                      *FIXTURE_KEYS})
#: Keys of each serial protocol on top of ``protocol``, ``capture`` and the transport's.
SERIAL_PROTOCOL_KEYS = {"stim300": frozenset({"datagram", "accel", "accel_range", "termination",
                                               "gyro_output", "accel_output", "counter"}),
                        "kvh1750": frozenset({"unit", "output", "accel", "format", "tempunits"}),
                        "xbus": frozenset({"accel", "hr"})}
#: Keys of a simulated serial protocol only (``gnss``: Hz of an MTi-G's GNSS messages).
SIM_SERIAL_PROTOCOL_KEYS = {"xbus": frozenset({"gnss"})}
#: Keys of a hardware URL besides the protocol's own: what the adapter needs to know.
HARDWARE_KEYS = frozenset({"rate", "model", "serial"})
#: Keys of a python-can bus a CAN or CANopen URL may set.
CAN_BUS_KEYS = frozenset({"interface", "bitrate", "port", "bind"})


def parse_query(text: str, url: str) -> dict[str, str]:
    """The query keys of ``url`` (its query part ``text``), each given once.

    Raises
    ------
    DeviceConfigurationError
        A key given more than once.
    """
    query: dict[str, str] = {}
    for key, value in parse_qsl(text, keep_blank_values=True):
        if key in query:
            raise DeviceConfigurationError(
                f"URL key {key!r} is given twice in {url!r} ({key}={query[key]} and "
                f"{key}={value}): give it once")
        query[key] = value
    return query


def check_keys(query: dict[str, str], allowed: Iterable[str], url: str) -> None:
    """Refuse a key ``allowed`` does not hold, naming it and the nearest known key.

    Raises
    ------
    DeviceConfigurationError
        An unknown key.
    """
    known = sorted(set(allowed))
    for key in query:
        if key not in known:
            near = difflib.get_close_matches(key, known, n=1)
            hint = f"; did you mean {near[0]!r}?" if near else ""
            raise DeviceConfigurationError(
                f"unknown URL key {key!r} in {url!r}{hint} (keys of this URL: "
                f"{', '.join(known)})")



def accel_switch(query: dict[str, str]) -> bool | None:
    """The URL's ``accel`` key: True (``accel=1``), False (``accel=0``), or None when not
    given (the protocol's default: on wherever its frames carry accelerometers).

    Raises
    ------
    DeviceConfigurationError
        A value other than 0 or 1.
    """
    text = query.get("accel")
    if text is None:
        return None
    if text not in ("0", "1"):
        raise DeviceConfigurationError(f"URL key accel={text!r} must be 0 or 1")
    return text == "1"
