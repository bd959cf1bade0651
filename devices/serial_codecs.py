"""The codec of a serial stream's protocol, as a device URL configures it (``protocol=``
and the protocol's keys): STIM300 (TS1524 rev. 31), KVH DSP-1750 and Xsens Xbus."""

from __future__ import annotations

from typing import Any

from devices.codecs.base import StreamCodec
from devices.codecs.kvh1750 import SYNC as KVH_SYNC, Kvh1750Codec
from devices.codecs.stim300 import Stim300Codec
from devices.codecs.xbus import PREAMBLE, XbusCodec
from devices.errors import CodecError, DeviceConfigurationError
from devices.sim.params import query_number
from devices.url_query import accel_switch

#: The protocols of a serial URL's ``protocol=`` key.
SERIAL_PROTOCOLS = ("stim300", "kvh1750", "xbus")


def stream_codec(protocol: str, query: dict[str, str], rate_hz: float | None
                 ) -> tuple[StreamCodec[Any], bytes, str]:
    """(codec, sync header, default model name) of a serial protocol.

    Parameters
    ----------
    protocol : str
        One of :data:`SERIAL_PROTOCOLS`.
    query : dict
        The URL's keys.
    rate_hz : float or None
        The unit's output rate, Hz; None where it is not known (a byte dump replayed on
        the device's own time): a protocol whose codec needs it is refused.

    Raises
    ------
    DeviceConfigurationError
        An unknown protocol, a key the protocol cannot take, or no rate where one is needed.
    """
    accel = accel_switch(query)
    try:
        if protocol == "stim300":
            codec = stim300_codec(query, rate_hz)
            return codec, bytes([codec.identifier]), "STIM300"
        if protocol == "kvh1750":
            output = query.get("output", "rate")
            if rate_hz is None and output == "delta":
                raise DeviceConfigurationError(
                    "a KVH delta output is scaled by the unit's output rate: give it (URL key "
                    "rate=HZ)")
            # (the rate scales only a delta output; format B's time stamps time a dump
            # replayed without one)
            return (Kvh1750Codec(query.get("unit", "deg"), output,  # type: ignore[arg-type]
                                 rate_hz or 1.0, accel=accel is not False,
                                 message_format=query["format"].upper() if "format" in query  # type: ignore[arg-type]
                                 else None,
                                 tempunits=query.get("tempunits", "C").upper()),  # type: ignore[arg-type]
                    KVH_SYNC, "DSP-1750")
        if protocol == "xbus":
            return (XbusCodec(accel=accel is not False, high_rate=url_switch(query, "hr")),
                    bytes([PREAMBLE]), "MTi")
    except CodecError as exc:
        raise DeviceConfigurationError(str(exc)) from exc
    raise DeviceConfigurationError(f"unknown serial protocol {protocol!r}; "
                                   f"known: {', '.join(SERIAL_PROTOCOLS)}")


def url_switch(query: dict[str, str], key: str) -> bool:
    """A 0/1 URL key (absent: 0).

    Raises
    ------
    DeviceConfigurationError
        A value other than 0 or 1.
    """
    text = query.get(key, "0")
    if text not in ("0", "1"):
        raise DeviceConfigurationError(f"URL key {key}={text!r} must be 0 or 1")
    return text == "1"


def stim300_codec(query: dict[str, str], rate_hz: float | None) -> Stim300Codec:
    """The STIM300 codec a URL configures (TS1524 rev. 31: ``datagram`` Tables 5-20/5-21,
    ``accel_range`` 5/10/30/80 g, ``termination`` none/crlf and ``gyro_output`` /
    ``accel_output`` Table 5-11; ``counter=datagram``: the framing borrowed by a simulated
    unit of another model, whose counter counts datagrams at any rate).

    Raises
    ------
    CodecError
        A rate, datagram, range or output the unit cannot send.
    DeviceConfigurationError
        No rate (``rate_hz`` None) where the counter counts internal samples: a STIM300
        sends no time of its own, so only its nominal rate times its samples.
    """
    ident = query_number("datagram", query.get("datagram", "0x94"), lambda t: int(t, 0))
    accel_g = query_number("accel_range", query.get("accel_range", "10"), int)
    termination = query.get("termination", "none")
    counting = query.get("counter", "internal")
    for key, value, known in (("termination", termination, ("none", "crlf")),
                              ("counter", counting, ("internal", "datagram"))):
        if value not in known:
            raise CodecError(f"STIM300 {key} must be {' or '.join(known)}, got {value!r}")
    if rate_hz is None and counting == "internal":
        raise DeviceConfigurationError(
            "protocol stim300 carries no device time: give the unit's nominal output rate "
            "(URL key rate=HZ)")
    return Stim300Codec(ident, accel_range_g=accel_g, accel=accel_switch(query),
                        rate_hz=None if counting == "datagram" else rate_hz,
                        crlf=termination == "crlf",
                        gyro_output=query.get("gyro_output", "rate"),
                        accel_output=query.get("accel_output", "acceleration"))
