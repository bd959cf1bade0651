"""Conversions between the data-sheet units of gyro noise terms and the base units (deg, s).

The analysis works in deg/s for rate and seconds for tau, so a fitted coefficient comes
out in deg-s units; these factors turn it into what a data sheet prints.
"""

from __future__ import annotations

import math

#: deg per microradian.
DEG_PER_URAD = 1e-6 * 180.0 / math.pi
#: seconds per hour.
S_PER_H = 3600.0


def q_urad_to_deg(q_urad: float) -> float:
    """Quantization coefficient: microradian -> deg."""
    return q_urad * DEG_PER_URAD


def q_deg_to_urad(q_deg: float) -> float:
    """Quantization coefficient: deg -> microradian."""
    return q_deg / DEG_PER_URAD


def arw_deg_rt_h_to_deg_rt_s(n: float) -> float:
    """Angle random walk: deg/sqrt(h) -> deg/sqrt(s) (divide by 60)."""
    return n / math.sqrt(S_PER_H)


def arw_deg_rt_s_to_deg_rt_h(n: float) -> float:
    """Angle random walk: deg/sqrt(s) -> deg/sqrt(h) (multiply by 60)."""
    return n * math.sqrt(S_PER_H)


def rate_deg_h_to_deg_s(b: float) -> float:
    """A rate (bias, bias instability): deg/h -> deg/s."""
    return b / S_PER_H


def rate_deg_s_to_deg_h(b: float) -> float:
    """A rate (bias, bias instability): deg/s -> deg/h."""
    return b * S_PER_H


def rrw_deg_h_1_5_to_deg_s_1_5(k: float) -> float:
    """Rate random walk: deg/h^1.5 -> deg/s^1.5."""
    return float(k / S_PER_H**1.5)


def rrw_deg_s_1_5_to_deg_h_1_5(k: float) -> float:
    """Rate random walk: deg/s^1.5 -> deg/h^1.5."""
    return float(k * S_PER_H**1.5)


def ramp_deg_h2_to_deg_s2(r: float) -> float:
    """Rate ramp: deg/h^2 -> deg/s^2."""
    return r / S_PER_H**2


def ramp_deg_s2_to_deg_h2(r: float) -> float:
    """Rate ramp: deg/s^2 -> deg/h^2."""
    return r * S_PER_H**2
