"""The accelerometer's noise figures in the conventions of the tools that consume them.

The station reports the IEEE Std 1293-2018 (annex C) accelerometer terms: velocity random
walk ``N`` in m/s/sqrt(h), bias instability ``B`` in ug (``sigma_min / 0.664``),
acceleration random walk ``K`` in m/s/h^1.5. The tools want SI densities:

* **Noise density** (Kalibr's and OpenVINS' ``accelerometer_noise_density``, MATLAB's
  ``accelparams`` ``NoiseDensity``): ``N [m/s^2/sqrt(Hz)] = N [m/s/sqrt(h)] / 60`` (white
  acceleration noise of density ``N`` has Allan variance ``N^2 / tau``).
* **Random walk** (Kalibr's ``accelerometer_random_walk``, MATLAB's ``RandomWalk`` in
  (m/s^2) sqrt(Hz), the same unit m/s^2.5): ``K [m/s^3/sqrt(Hz)] = K [m/s/h^1.5] /
  3600^1.5`` (Allan variance ``K^2 tau / 3``).
* **Bias instability** in m/s^2: ``B [ug] x 1e-6 x 9.80665`` (MATLAB: ``sigma_min /
  0.664`` as the station; allan_variance_ros: ``sigma_min``).

The conversions mirror :mod:`analysis.figures.tool_units`' for the gyro without its deg -> rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from analysis.figures.accel import STANDARD_GRAVITY_M_S2
from analysis.figures.tool_units import S_PER_H_1_5, AxisNoise, allan_floor
from analysis.units.conversions import S_PER_H

#: m/s^2 per ug.
M_S2_PER_UG = 1e-6 * STANDARD_GRAVITY_M_S2


@dataclass(frozen=True)
class AccelNoise:
    """The noise figures of one accelerometer axis in the station's convention, and every
    tool's.

    Attributes
    ----------
    name : str
        Axis (column) name.
    sample_rate_hz : float
        Rate of the record, Hz.
    vrw_m_s_rt_h : float
        Velocity random walk N, m/s/sqrt(h).
    bias_instability_ug : float or None
        B = sigma_min / 0.664, ug (None: not measured).
    accel_random_walk_m_s_h1_5 : float
        Acceleration random walk K, m/s/h^1.5.
    accel_bias_mg : float
        Mean with the gravity projection removed, mg.
    sources : dict
        Where each figure came from (keys ``vrw``, ``bias_instability``,
        ``accel_random_walk``); one that says "upper bound" bounds the figure and does
        not measure it (:attr:`upper_bounds`).
    """

    name: str
    sample_rate_hz: float
    vrw_m_s_rt_h: float
    bias_instability_ug: float | None
    accel_random_walk_m_s_h1_5: float
    accel_bias_mg: float
    sources: dict[str, str] | None = None

    @classmethod
    def of_series(cls, noise: AxisNoise, accel_bias_mg: float) -> AccelNoise:
        """From the :class:`AxisNoise` of a series in m/s^2 (its "deg" figures read as
        m/s^2: ``arw_deg_rt_h`` is N in m/s/sqrt(h), ``bias_instability_deg_h`` is B in
        m/s^2 x 3600, ``rrw_deg_h_1_5`` is K in m/s/h^1.5; its sources renamed)."""
        b = noise.bias_instability_deg_h
        names = {"arw": "vrw", "bias_instability": "bias_instability",
                 "rrw": "accel_random_walk"}
        sources = {names.get(k, k): v for k, v in (noise.sources or {}).items()}
        return cls(noise.name, noise.sample_rate_hz, noise.arw_deg_rt_h,
                   None if b is None else b / S_PER_H / M_S2_PER_UG,
                   noise.rrw_deg_h_1_5, accel_bias_mg, sources)

    @property
    def upper_bounds(self) -> tuple[str, ...]:
        """The figures (``vrw``, ``bias_instability``, ``accel_random_walk``) whose value is
        an upper bound the record sets, not a measurement: a tool given it as a value must
        be told so."""
        return tuple(k for k, v in (self.sources or {}).items() if "upper bound" in v)

    @property
    def noise_density_m_s2_rt_hz(self) -> float:
        """Continuous noise density, m/s^2/sqrt(Hz): ``N / 60``."""
        return self.vrw_m_s_rt_h / math.sqrt(S_PER_H)

    @property
    def random_walk_m_s3_rt_hz(self) -> float:
        """Continuous bias random walk, m/s^3/sqrt(Hz): ``K / 3600^1.5``."""
        return self.accel_random_walk_m_s_h1_5 / S_PER_H_1_5

    @property
    def accel_bias_m_s2(self) -> float:
        """The bias (gravity removed) in m/s^2."""
        return self.accel_bias_mg * 1e-3 * STANDARD_GRAVITY_M_S2

    @property
    def bias_instability_m_s2(self) -> float | None:
        """B in m/s^2 (None: not measured)."""
        b = self.bias_instability_ug
        return None if b is None else b * M_S2_PER_UG

    def as_json(self) -> dict[str, object]:
        """Every figure, each key ending in its unit."""
        b = self.bias_instability_m_s2
        return {
            "name": self.name,
            "quantity": "acceleration",
            "sample_rate_hz": self.sample_rate_hz,
            "vrw_m_s_rt_h": self.vrw_m_s_rt_h,
            "noise_density_m_s2_rt_hz": self.noise_density_m_s2_rt_hz,
            "noise_discrete_m_s2": self.noise_density_m_s2_rt_hz
            * math.sqrt(self.sample_rate_hz),
            "bias_instability_ug": self.bias_instability_ug,
            "bias_instability_m_s2": b,
            "allan_floor_m_s2": None if b is None else allan_floor(b),
            "accel_random_walk_m_s_h1_5": self.accel_random_walk_m_s_h1_5,
            "random_walk_m_s3_rt_hz": self.random_walk_m_s3_rt_hz,
            "accel_bias_mg": self.accel_bias_mg,
            "accel_bias_m_s2": self.accel_bias_m_s2,
            "sources": dict(self.sources or {}),
            "upper_bounds": list(self.upper_bounds),
        }
