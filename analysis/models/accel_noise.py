"""Accelerometer noise model of an IMU, and its seeded streaming simulator.

A noise-model TOML (``profiles/models/*.toml``) may hold an ``[accelerometer]`` table
beside the gyro terms (``profiles/README.md``)::

    [accelerometer]
    vrw_m_s_rt_h = 0.07          # velocity random walk, m/s/sqrt(h) (white noise)
    bias_instability_ug = 50.0   # bias instability (flicker plateau / 0.664), micro-g
    accel_rw_m_s_h1_5 = 0.0      # acceleration random walk, m/s/h^1.5
    bias_mg = 0.0                # constant bias, milli-g
    tempco_mg_per_c = 0.0        # bias temperature sensitivity, milli-g per degC
    reference_c = 25.0           # temperature of zero temperature effect, degC

Each term is the accelerometer twin of a gyro term, with m/s in place of deg: velocity
random walk (m/s/sqrt(h)) is angle random walk (deg/sqrt(h)), acceleration random walk
(m/s/h^1.5) is rate random walk (deg/h^1.5), a bias in m/s/h is a bias in deg/h. The
simulator therefore runs :class:`analysis.models.simulation.GyroSimulator` (the streaming forms of
:mod:`analysis.models.noise`'s generators) on the equivalent model; its output is in m/s^2.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from analysis.errors import ModelError
from analysis.models.simulation import GyroSimulator
from analysis.models.terms import (
    AngleRandomWalk,
    Bias,
    BiasInstability,
    NoiseModel,
    NoiseTerm,
    RateRandomWalk,
)
from analysis.units.conversions import S_PER_H, STANDARD_GRAVITY_M_S2
from analysis.units.earth import Direction, axis_direction, match_axis

#: The TOML table of a noise model that holds the accelerometer terms.
ACCELEROMETER_TABLE = "accelerometer"
#: Seed-sequence key of the accelerometer stream (the gyros draw from the seed itself).
_ACCEL_STREAM = 0xACC


@dataclass(frozen=True)
class AccelNoiseModel:
    """Accelerometer noise terms, in data-sheet units (module docstring).

    Raises
    ------
    ModelError
        A coefficient that is not a finite number, or a negative noise coefficient.
    """

    vrw_m_s_rt_h: float = 0.0
    bias_instability_ug: float = 0.0
    accel_rw_m_s_h1_5: float = 0.0
    bias_mg: float = 0.0
    tempco_mg_per_c: float = 0.0
    reference_c: float = 25.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, int | float) \
                    or not math.isfinite(value):
                raise ModelError(f"[accelerometer] {f.name} must be a finite number, "
                                 f"got {value!r}")
        for name in ("vrw_m_s_rt_h", "bias_instability_ug", "accel_rw_m_s_h1_5"):
            if getattr(self, name) < 0:
                raise ModelError(f"[accelerometer] {name} must be >= 0, got {getattr(self, name)}")

    @classmethod
    def from_table(cls, table: Mapping[str, Any]) -> AccelNoiseModel:
        """The model of an ``[accelerometer]`` table, refusing unknown keys.

        Raises
        ------
        ModelError
            Unknown key, or a value :meth:`__post_init__` refuses.
        """
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(table) - known)
        if unknown:
            raise ModelError(f"[accelerometer] unknown key(s) {', '.join(unknown)}; known: "
                             f"{', '.join(sorted(known))}")
        return cls(**{k: float(v) if isinstance(v, int) and not isinstance(v, bool) else v
                      for k, v in table.items()})

    def as_noise_model(self) -> NoiseModel:
        """The equivalent gyro model, whose "deg" stands for m/s (module docstring)."""
        g_m_s_h = STANDARD_GRAVITY_M_S2 * S_PER_H  # m/s per h in 1 g
        terms: list[NoiseTerm] = []
        if self.vrw_m_s_rt_h:
            terms.append(AngleRandomWalk(N_deg_rt_h=self.vrw_m_s_rt_h))
        if self.bias_instability_ug:
            terms.append(BiasInstability(B_deg_h=self.bias_instability_ug * 1e-6 * g_m_s_h))
        if self.accel_rw_m_s_h1_5:
            terms.append(RateRandomWalk(K_deg_h_1_5=self.accel_rw_m_s_h1_5))
        if self.bias_mg:
            terms.append(Bias(value_deg_h=self.bias_mg * 1e-3 * g_m_s_h))
        return NoiseModel(terms=tuple(terms), name="accelerometer")


def gravity_by_axis(orientation: Mapping[str, Direction], axis_names: Sequence[str]
                    ) -> NDArray[np.float64]:
    """Specific force of gravity (m/s^2) each named axis of an IMU at rest on a bench
    measures: +g times the up component of the axis' direction (``orientation``, as
    :func:`analysis.units.earth.parse_orientation` gives it); 0 for an axis with no direction.

    Raises
    ------
    OrientationError
        A direction that is not valid.
    """
    keys = list(orientation)
    out = np.zeros(len(axis_names))
    for i, name in enumerate(axis_names):
        key = match_axis(name, keys)
        if key is not None:
            out[i] = STANDARD_GRAVITY_M_S2 * float(axis_direction(orientation[key])[2])
    return out


class AccelSimulator:
    """Seeded streaming accelerometer signal, m/s^2: noise, gravity and temperature.

    Parameters
    ----------
    model : AccelNoiseModel
        The noise terms (every axis the same model, drawn independently).
    sample_rate_hz : float
        Sample rate, Hz.
    n_axes : int
        Accelerometer axes.
    seed : int or None
        The unit's seed (the gyros' own): the accelerometers draw from a stream of their
        own derived from it, so the same seed gives the same samples.
    gravity_m_s2 : sequence of float, optional
        Gravity each axis sees (m/s^2); default +9.80665 on the last axis (z up).
    short_reads : bool
        Read a few samples at a time (see :class:`GyroSimulator`).
    """

    def __init__(self, model: AccelNoiseModel, sample_rate_hz: float, *, n_axes: int = 3,
                 seed: int | None = None, gravity_m_s2: Sequence[float] | None = None,
                 short_reads: bool = False) -> None:
        if gravity_m_s2 is None:
            gravity_m_s2 = [0.0] * (n_axes - 1) + [STANDARD_GRAVITY_M_S2]
        if len(gravity_m_s2) != n_axes:
            raise ValueError(f"gravity_m_s2 needs {n_axes} values, got {len(gravity_m_s2)}")
        self.model = model
        self.n_axes = n_axes
        self.gravity_m_s2 = np.asarray(gravity_m_s2, dtype=np.float64)
        stream_seed = (None if seed is None else
                       int(np.random.SeedSequence([seed, _ACCEL_STREAM]).generate_state(1)[0]))
        self._sim = GyroSimulator(model.as_noise_model(), sample_rate_hz, n_axes=n_axes,
                                  seed=stream_seed, short_reads=short_reads)

    def temperature_effect(self, temperature_c: NDArray[np.float64]) -> NDArray[np.float64]:
        """Bias from the temperature sensitivity (m/s^2, shape (n, 1)) at each sample's
        temperature (degC)."""
        per_c = self.model.tempco_mg_per_c * 1e-3 * STANDARD_GRAVITY_M_S2
        return per_c * (np.asarray(temperature_c, dtype=np.float64)[:, None]
                        - self.model.reference_c)

    def read(self, n_samples: int, temperature_c: NDArray[np.float64]) -> NDArray[np.float64]:
        """The next ``n_samples`` samples (m/s^2, shape (n, n_axes)) at the given sensor
        temperatures (degC, shape (n,))."""
        noise = self._sim.read(n_samples).rate_deg_s  # m/s^2 here (module docstring)
        return noise + self.gravity_m_s2 + self.temperature_effect(temperature_c)
