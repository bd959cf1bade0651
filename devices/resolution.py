"""The resolution of a rate word on the link: the least significant bit each protocol sends.

A fixed-point rate word moves in steps of one LSB, whatever the gyro does between them;
a floating-point word moves in steps relative to its value. Grading needs the step to tell
a figure the link resolves from one it cannot (``station.evaluation.resolution``):

========  ===========================================  =====================================
protocol  rate word                                    step (deg/s)
========  ===========================================  =====================================
stim300   int24, 2^-14 deg/s (datasheet TS1524,        6.1e-5, fixed
          table 5-20: rate = value / 2^14)
kvh1750   float32, deg or rad, rate or delta angle     2^-23 x the value (float32 mantissa)
          (DSP-1750 manual, message format A)
xbus      RateOfTurn 0x8020, float32 rad/s             2^-23 x the value
          (MT Low Level Communication Protocol)
can       the layout's ``scale`` per LSB               the coarsest axis' scale, fixed
canopen   int32 x object 0x2003 "Rate scale" (EDS      the scale read at set-up (1e-6)
          default 1e-6 deg/s)
modbus    the map's register kind and ``scale``        int: the scale; float32: 2^-23 x value
========  ===========================================  =====================================

A float32 word's step at value v lies between 2^-24 |v| and 2^-23 |v|; the larger is taken.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from urllib.parse import urlsplit

from devices.codecs.modbus_map import RegisterField
from devices.codecs.stim300_sheet import RATE_LSB_PER_DEG_S
from devices.errors import DeviceConfigurationError
from devices.url_text import url_keys

#: Relative step of a float32 word: one unit in the last place of a 24-bit significand,
#: at most 2^-23 of the value.
FLOAT32_RELATIVE_STEP = 2.0**-23
#: The CANopen gyro's rate scale when its node is not asked (EDS object 0x2003's default).
CANOPEN_DEFAULT_SCALE_DEG_S = 1e-6


@dataclass(frozen=True)
class RateResolution:
    """The step of a link's rate word.

    Attributes
    ----------
    lsb_deg_s : float
        The fixed step of a fixed-point word, deg/s (0.0 for a floating-point word).
    lsb_relative : float
        The step of a floating-point word relative to its value (2^-23 for float32;
        0.0 for a fixed-point word).
    """

    lsb_deg_s: float = 0.0
    lsb_relative: float = 0.0

    def step_at(self, magnitude_deg_s: float) -> float:
        """The step of the word at a rate of ``magnitude_deg_s`` (deg/s, its size), deg/s."""
        return max(self.lsb_deg_s, self.lsb_relative * abs(magnitude_deg_s))

    def describe(self) -> str:
        """One phrase: ``"LSB 6.1e-05 deg/s"`` or ``"float32 (2^-23 of the value)"``."""
        if self.lsb_deg_s > 0:
            return f"LSB {self.lsb_deg_s:.3g} deg/s"
        return f"floating point (step {self.lsb_relative:.3g} of the value)"


def fixed(lsb_deg_s: float) -> RateResolution:
    """A fixed-point word with an LSB of ``lsb_deg_s`` deg/s."""
    return RateResolution(lsb_deg_s=abs(lsb_deg_s))


FLOAT32 = RateResolution(lsb_relative=FLOAT32_RELATIVE_STEP)
#: Neither step known (a :class:`~devices.protocols.DeviceDescription`'s 0.0 and 0.0).
UNKNOWN_RESOLUTION = RateResolution()
STIM300 = fixed(1.0 / RATE_LSB_PER_DEG_S)


def codec_resolution(protocol: str) -> RateResolution | None:
    """The resolution of a serial protocol's rate word (its codec's ``name``); None for
    one not listed above."""
    if protocol == "stim300":
        return STIM300
    if protocol in ("kvh1750", "xbus"):
        return FLOAT32
    return None


def scale_resolution(scales: Iterable[float]) -> RateResolution:
    """The resolution of fixed-point rate signals of ``scales`` deg/s per LSB (the coarsest)."""
    return fixed(max(abs(s) for s in scales))


def register_resolution(fields: Iterable[RegisterField]) -> RateResolution:
    """The resolution of a register map's rate fields (the coarsest of them)."""
    fields = tuple(fields)
    if any(f.kind == "float32" for f in fields):
        return FLOAT32
    return fixed(max(abs(f.scale) for f in fields))


def url_resolution(url: str) -> RateResolution | None:
    """The resolution of the rate word a device URL's protocol sends, without opening it;
    None where the URL does not say (a ``replay://`` capture, an unknown scheme).

    Raises
    ------
    DeviceConfigurationError
        A layout or register map the URL names that cannot be read.
    """
    from devices.bus_layouts import can_layout, register_map  # (they import the adapters)

    scheme = urlsplit(url).scheme.lower().removeprefix("sim+")
    query = url_keys(url)
    if scheme == "serial":
        return codec_resolution(query.get("protocol", "stim300"))
    if scheme == "can":
        return scale_resolution(s.scale for s in can_layout(query.get("layout", "shared"),
                                                            False).axes)
    if scheme == "canopen":
        return fixed(CANOPEN_DEFAULT_SCALE_DEG_S)
    if scheme in ("modbus+tcp", "modbus+rtu"):
        return register_resolution(register_map(query.get("map", "int32"), False).axes)
    return None


def safe_url_resolution(url: str) -> RateResolution | None:
    """:func:`url_resolution`, None where the URL's layout or map cannot be read (the
    device's own opening then says why)."""
    try:
        return url_resolution(url)
    except DeviceConfigurationError:
        return None


def description_resolution(lsb_deg_s: float, lsb_relative: float) -> RateResolution | None:
    """The resolution a description's (or a run file's) two fields give; None: not known."""
    if is_finite_step(lsb_deg_s) or is_finite_step(lsb_relative):
        return RateResolution(lsb_deg_s if is_finite_step(lsb_deg_s) else 0.0,
                              lsb_relative if is_finite_step(lsb_relative) else 0.0)
    return None


def is_finite_step(value: float | None) -> bool:
    """Whether ``value`` is a usable step (finite, > 0)."""
    return value is not None and math.isfinite(value) and value > 0
