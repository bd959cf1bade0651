"""The station's noise figures in the conventions of the tools that consume them.

The station reports the IEEE Std 952-1997 coefficients in data-sheet units: the angle
random walk ``N`` in deg/sqrt(h), the bias instability ``B`` in deg/h, the rate random
walk ``K`` in deg/h^1.5 (:mod:`analysis.fit`, :mod:`analysis.figures.readoffs`). Kalman filters,
calibration tools and simulators want other names for the same quantities, in radians
and per sqrt(Hz); this module holds each conversion once, with its formula.

Conventions (``docs/units.md`` has the full table):

* **Continuous-time noise density** (Kalibr's ``gyroscope_noise_density``, OpenVINS',
  MATLAB's ``NoiseDensity``): the white rate noise whose Allan variance is ``N^2 / tau``
  (IEEE Std 952-1997 Annex C), so it *is* ``N``, in rad/s/sqrt(Hz) = rad/sqrt(s):
  ``N [rad/s/sqrt(Hz)] = N [deg/sqrt(h)] x (pi/180) / 60``.
* **Discrete-time noise** (the standard deviation of one sample at ``fs``): ``sigma_d =
  N sqrt(fs)`` (Kalibr's IMU noise model: ``sigma_d = sigma / sqrt(dt)``).
* **Random walk** (Kalibr's ``gyroscope_random_walk``, MATLAB's ``RandomWalk``): the rate
  random walk whose Allan variance is ``K^2 tau / 3`` (IEEE Std 952 Annex C), a
  bias diffusion of density ``K`` in rad/s^2/sqrt(Hz) = (rad/s) sqrt(Hz) = rad/s^1.5:
  ``K [rad/s^2/sqrt(Hz)] = K [deg/h^1.5] x (pi/180) / 3600^1.5``; discrete ``K sqrt(dt)``.
* **Bias instability** is not a noise density: flicker noise has no finite-dimensional
  state model. Its Allan deviation is flat at ``sqrt(2 ln 2 / pi) B = 0.664 B`` (IEEE Std
  952 Annex C). The station (and MATLAB's Allan-variance workflow) report
  ``B = sigma_min / 0.664``; imu_utils, kalibr_allan and allan_variance_ros report
  ``sigma_min`` itself, 0.664 times ours.
* **First-order Gauss-Markov** bias (gnss-ins-sim's ``gyro_b_stability`` with
  ``gyro_b_corr``): stationary standard deviation ``s`` and correlation time ``T``; a
  filter's state ``db/dt = -b/T + w`` needs the driving density ``s sqrt(2 / T)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from analysis.figures.readoffs import BIAS_INSTABILITY_FACTOR
from analysis.units.conversions import RAD_PER_DEG, S_PER_H

#: Seconds per hour to the power 1.5 (s^1.5 per h^1.5), for rate random walks.
S_PER_H_1_5: float = S_PER_H * math.sqrt(S_PER_H)
#: sqrt(s per h): deg/sqrt(h) per deg/sqrt(s).
RT_S_PER_H = math.sqrt(S_PER_H)


def _finite(value: float, name: str) -> float:
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return x


def _positive(value: float, name: str) -> float:
    x = _finite(value, name)
    if x <= 0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    return x


def noise_density_rad_s_rt_hz(arw_deg_rt_h: float) -> float:
    """Continuous-time rate noise density from the angle random walk.

    ``N [rad/s/sqrt(Hz)] = N [deg/sqrt(h)] x (pi / 180) / 60`` (IEEE Std 952-1997
    Annex C: white rate noise of two-sided density ``N^2`` has Allan variance ``N^2 / tau``,
    and 1 deg/sqrt(h) = (1/60) deg/sqrt(s) = (1/60) (deg/s)/sqrt(Hz)).

    Parameters
    ----------
    arw_deg_rt_h : float
        Angle random walk N, deg/sqrt(h).

    Returns
    -------
    float
        Noise density, rad/s/sqrt(Hz) (Kalibr's ``gyroscope_noise_density``).

    Raises
    ------
    ValueError
        A value that is not finite.
    """
    return _finite(arw_deg_rt_h, "arw_deg_rt_h") * RAD_PER_DEG / RT_S_PER_H


def noise_density_deg_s_rt_hz(arw_deg_rt_h: float) -> float:
    """Continuous-time rate noise density in deg/s/sqrt(Hz) (data sheets): ``N / 60``.

    Raises
    ------
    ValueError
        A value that is not finite.
    """
    return _finite(arw_deg_rt_h, "arw_deg_rt_h") / RT_S_PER_H


def arw_deg_rt_h_from_density(noise_density_rad_s_rt_hz: float) -> float:
    """Angle random walk (deg/sqrt(h)) from a noise density in rad/s/sqrt(Hz):
    ``N = density x 60 x 180 / pi``, the inverse of :func:`noise_density_rad_s_rt_hz`.

    Raises
    ------
    ValueError
        A value that is not finite.
    """
    return (
        _finite(noise_density_rad_s_rt_hz, "noise_density_rad_s_rt_hz") * RT_S_PER_H / RAD_PER_DEG
    )


def discrete_noise_std(noise_density: float, sample_rate_hz: float) -> float:
    """Standard deviation of one sample of white noise of continuous density ``noise_density``.

    ``sigma_d = sigma_c sqrt(fs)`` (the mean over one sample period ``dt = 1/fs`` of white
    noise of density ``sigma_c`` has variance ``sigma_c^2 / dt``; Kalibr's IMU noise model).
    The unit is the density's times sqrt(Hz): rad/s/sqrt(Hz) -> rad/s.

    Raises
    ------
    ValueError
        A density that is not finite, or a rate that is not positive.
    """
    return _finite(noise_density, "noise_density") * math.sqrt(
        _positive(sample_rate_hz, "sample_rate_hz")
    )


def random_walk_rad_s2_rt_hz(rrw_deg_h_1_5: float) -> float:
    """Continuous-time bias random walk density from the rate random walk coefficient K.

    ``K [rad/s^2/sqrt(Hz)] = K [deg/h^1.5] x (pi / 180) / 3600^1.5`` (IEEE Std 952-1997
    Annex C: a rate random walk of density ``K`` has Allan variance ``K^2 tau / 3``, read
    on the +1/2 line at tau = 3 s). rad/s^2/sqrt(Hz) (Kalibr's ``gyroscope_random_walk``)
    and (rad/s) sqrt(Hz) (MATLAB's ``RandomWalk``) are the same unit, rad/s^1.5.

    Raises
    ------
    ValueError
        A value that is not finite.
    """
    return _finite(rrw_deg_h_1_5, "rrw_deg_h_1_5") * RAD_PER_DEG / S_PER_H_1_5


def rrw_deg_h_1_5_from_random_walk(random_walk_rad_s2_rt_hz: float) -> float:
    """Rate random walk K (deg/h^1.5) from a bias random walk density in rad/s^2/sqrt(Hz),
    the inverse of :func:`random_walk_rad_s2_rt_hz`.

    Raises
    ------
    ValueError
        A value that is not finite.
    """
    return (
        _finite(random_walk_rad_s2_rt_hz, "random_walk_rad_s2_rt_hz") * S_PER_H_1_5 / RAD_PER_DEG
    )


def discrete_random_walk_std(random_walk: float, sample_rate_hz: float) -> float:
    """Standard deviation of the bias step over one sample: ``sigma_bd = sigma_b sqrt(dt)
    = sigma_b / sqrt(fs)`` (Kalibr's IMU noise model); rad/s^2/sqrt(Hz) -> rad/s.

    Raises
    ------
    ValueError
        A density that is not finite, or a rate that is not positive.
    """
    return _finite(random_walk, "random_walk") / math.sqrt(
        _positive(sample_rate_hz, "sample_rate_hz")
    )


def rate_rad_s(rate_deg_h: float) -> float:
    """A rate (bias, bias instability, Gauss-Markov sigma): deg/h -> rad/s, ``x pi / 180 / 3600``.

    Raises
    ------
    ValueError
        A value that is not finite.
    """
    return _finite(rate_deg_h, "rate_deg_h") * RAD_PER_DEG / S_PER_H


def allan_floor(bias_instability: float) -> float:
    """The Allan deviation's flicker floor ``sigma_min = 0.664 B`` (IEEE Std 952-1997 Annex C,
    ``sqrt(2 ln 2 / pi) = 0.6643``), in ``B``'s unit: what imu_utils, kalibr_allan and
    allan_variance_ros call the bias instability.

    Raises
    ------
    ValueError
        A value that is not finite.
    """
    return _finite(bias_instability, "bias_instability") * BIAS_INSTABILITY_FACTOR


def bias_instability_from_floor(sigma_min: float) -> float:
    """The station's bias instability ``B = sigma_min / 0.664`` from an Allan minimum
    (IEEE Std 952-1997 Annex C), in ``sigma_min``'s unit; inverse of :func:`allan_floor`.

    Raises
    ------
    ValueError
        A value that is not finite.
    """
    return _finite(sigma_min, "sigma_min") / BIAS_INSTABILITY_FACTOR


def gauss_markov_driving_density(sigma: float, correlation_time_s: float) -> float:
    """Density of the white noise driving a first-order Gauss-Markov process.

    ``db/dt = -b / T + w`` with ``w`` of density ``q`` has stationary variance
    ``q^2 T / 2`` (the Lyapunov equation ``0 = -2 P / T + q^2``), so ``q = s sqrt(2 / T)``
    for a stationary standard deviation ``s``. The unit is
    ``s``'s per sqrt(s): rad/s -> rad/s^2/sqrt(Hz).

    Raises
    ------
    ValueError
        A sigma that is not finite, or a correlation time that is not positive.
    """
    return _finite(sigma, "sigma") * math.sqrt(
        2.0 / _positive(correlation_time_s, "correlation_time_s")
    )


@dataclass(frozen=True)
class GaussMarkovBias:
    """A first-order Gauss-Markov bias term: stationary std (deg/h) and correlation time (s)."""

    sigma_deg_h: float
    tau_s: float

    def as_json(self) -> dict[str, float]:
        """``sigma_deg_h``, ``sigma_rad_s``, ``tau_s`` and ``driving_density_rad_s2_rt_hz``."""
        sigma = rate_rad_s(self.sigma_deg_h)
        return {
            "sigma_deg_h": self.sigma_deg_h,
            "sigma_rad_s": sigma,
            "tau_s": self.tau_s,
            "driving_density_rad_s2_rt_hz": gauss_markov_driving_density(sigma, self.tau_s),
        }


@dataclass(frozen=True)
class AxisNoise:
    """The noise figures of one gyro axis in the station's convention, and every tool's.

    Attributes
    ----------
    name : str
        Axis (column) name.
    sample_rate_hz : float
        Rate of the record the figures come from, Hz (for the discrete forms).
    arw_deg_rt_h : float
        Angle random walk N, deg/sqrt(h).
    bias_instability_deg_h : float or None
        B = sigma_min / 0.664, deg/h (None: not measured).
    rrw_deg_h_1_5 : float
        Rate random walk K, deg/h^1.5 (an upper bound where ``sources`` says so).
    bias_deg_h : float
        Mean rate over the record, deg/h.
    gauss_markov : tuple of GaussMarkovBias
        First-order Gauss-Markov terms of a GMWM model, shortest correlation time first.
    sources : dict
        Where each figure comes from (``"arw"``, ``"bias_instability"``, ``"rrw"``).
    """

    name: str
    sample_rate_hz: float
    arw_deg_rt_h: float
    bias_instability_deg_h: float | None
    rrw_deg_h_1_5: float
    bias_deg_h: float
    gauss_markov: tuple[GaussMarkovBias, ...] = ()
    sources: dict[str, str] | None = None

    @property
    def noise_density_rad_s_rt_hz(self) -> float:
        """Continuous noise density, rad/s/sqrt(Hz) (:func:`noise_density_rad_s_rt_hz`)."""
        return noise_density_rad_s_rt_hz(self.arw_deg_rt_h)

    @property
    def random_walk_rad_s2_rt_hz(self) -> float:
        """Continuous bias random walk, rad/s^2/sqrt(Hz) (:func:`random_walk_rad_s2_rt_hz`)."""
        return random_walk_rad_s2_rt_hz(self.rrw_deg_h_1_5)

    @property
    def main_gauss_markov(self) -> GaussMarkovBias | None:
        """The Gauss-Markov term of the largest sigma (the one a single-term tool gets)."""
        return max(self.gauss_markov, key=lambda g: g.sigma_deg_h, default=None)

    def as_json(self) -> dict[str, object]:
        """Every figure, each key ending in its unit, in the deg and the rad families."""
        nd, rw = self.noise_density_rad_s_rt_hz, self.random_walk_rad_s2_rt_hz
        b = self.bias_instability_deg_h
        return {
            "name": self.name,
            "sample_rate_hz": self.sample_rate_hz,
            "arw_deg_rt_h": self.arw_deg_rt_h,
            "noise_density_deg_s_rt_hz": noise_density_deg_s_rt_hz(self.arw_deg_rt_h),
            "noise_density_rad_s_rt_hz": nd,
            "noise_discrete_rad_s": discrete_noise_std(nd, self.sample_rate_hz),
            "bias_instability_deg_h": b,
            "bias_instability_rad_s": None if b is None else rate_rad_s(b),
            "allan_floor_deg_h": None if b is None else allan_floor(b),
            "allan_floor_rad_s": None if b is None else rate_rad_s(allan_floor(b)),
            "rrw_deg_h_1_5": self.rrw_deg_h_1_5,
            "random_walk_rad_s2_rt_hz": rw,
            "random_walk_discrete_rad_s": discrete_random_walk_std(rw, self.sample_rate_hz),
            "bias_deg_h": self.bias_deg_h,
            "bias_rad_s": rate_rad_s(self.bias_deg_h),
            "gauss_markov": [g.as_json() for g in self.gauss_markov],
            "sources": dict(self.sources or {}),
        }
