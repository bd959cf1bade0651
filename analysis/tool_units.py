"""Moved to :mod:`analysis.figures.tool_units`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.figures.tool_units import (
    RT_S_PER_H as RT_S_PER_H,
    S_PER_H_1_5 as S_PER_H_1_5,
    AxisNoise as AxisNoise,
    GaussMarkovBias as GaussMarkovBias,
    allan_floor as allan_floor,
    arw_deg_rt_h_from_density as arw_deg_rt_h_from_density,
    bias_instability_from_floor as bias_instability_from_floor,
    discrete_noise_std as discrete_noise_std,
    discrete_random_walk_std as discrete_random_walk_std,
    gauss_markov_driving_density as gauss_markov_driving_density,
    noise_density_deg_s_rt_hz as noise_density_deg_s_rt_hz,
    noise_density_rad_s_rt_hz as noise_density_rad_s_rt_hz,
    random_walk_rad_s2_rt_hz as random_walk_rad_s2_rt_hz,
    rate_rad_s as rate_rad_s,
    rrw_deg_h_1_5_from_random_walk as rrw_deg_h_1_5_from_random_walk,
)
from analysis.moved import warn_moved

warn_moved("analysis.tool_units", "analysis.figures.tool_units")
