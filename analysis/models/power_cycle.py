"""A gyro's behaviour at turn-on and with temperature: the model simulated units follow.

What the static sequence tests measure (:mod:`analysis.sequences.turn_on`,
:mod:`analysis.sequences.temperature_sensitivity`) has a truth here, set by a simulation:

* at each application of power the unit is silent for a *turn-on time* (drawn per
  turn-on, normal about ``turn_on_s`` with spread ``turn_on_jitter_s``), then sends;
* its bias gets a *turn-on bias* drawn anew per turn-on (normal, zero mean, spread
  ``turn_on_bias_deg_h``: the truth of the turn-on to turn-on repeatability);
* a *warm-up transient* ``A exp(-t / tau_w)`` (t since power-on) decays on top;
* the bias follows the die temperature ``T``: ``c1 (T - T_ref) + c2 (T - T_ref)^2``;
* the die temperature follows the air of its chamber through a first-order lag
  (``unit_tau_s``) and rises by ``self_heating_c`` while powered (:class:`ThermalModel`);
  the chamber's air follows its set point through its own lag.

Each sample is the mean over its sample period (:mod:`analysis.models.simulation`'s convention):
the transient's sample means are exact; the temperature terms use the die temperature
of the sample.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray


def _check_nonnegative(obj: object, *names: str) -> None:
    for name in names:
        value = getattr(obj, name)
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {value}")


@dataclass(frozen=True)
class TurnOn:
    """What one turn-on drew: its turn-on time (s) and its turn-on bias per axis (deg/h)."""

    turn_on_s: float
    bias_deg_h: tuple[float, ...]


@dataclass(frozen=True)
class PowerCycleModel:
    """A simulated gyro's turn-on, warm-up and temperature behaviour.

    Attributes
    ----------
    turn_on_s : float
        Mean time from the application of power to the start of the first valid sample, s.
    turn_on_jitter_s : float
        Standard deviation of the turn-on time across turn-ons, s.
    turn_on_bias_deg_h : float
        Standard deviation of the bias drawn at each turn-on, deg/h.
    warmup_deg_h : float
        Amplitude of the warm-up transient at power-on, deg/h (either sign).
    warmup_tau_s : float
        Its time constant, s.
    tempco_deg_h_per_c : float
        Linear bias sensitivity to the die temperature, deg/h per degC.
    tempco2_deg_h_per_c2 : float
        Quadratic sensitivity, deg/h per degC^2.
    reference_c : float
        Temperature of zero temperature bias, degC.
    """

    turn_on_s: float = 1.0
    turn_on_jitter_s: float = 0.0
    turn_on_bias_deg_h: float = 0.0
    warmup_deg_h: float = 0.0
    warmup_tau_s: float = 300.0
    tempco_deg_h_per_c: float = 0.0
    tempco2_deg_h_per_c2: float = 0.0
    reference_c: float = 25.0

    def __post_init__(self) -> None:
        _check_nonnegative(self, "turn_on_s", "turn_on_jitter_s", "turn_on_bias_deg_h")
        if not (math.isfinite(self.warmup_tau_s) and self.warmup_tau_s > 0):
            raise ValueError(f"warmup_tau_s must be a finite number > 0, got {self.warmup_tau_s}")
        for name in ("warmup_deg_h", "tempco_deg_h_per_c", "tempco2_deg_h_per_c2",
                     "reference_c"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)}")

    def draw(self, rng: np.random.Generator, n_axes: int = 1) -> TurnOn:
        """The turn-on time (s, never negative) and turn-on bias of each of ``n_axes`` axes
        (deg/h, independent) of one turn-on."""
        t = self.turn_on_s + self.turn_on_jitter_s * float(rng.standard_normal())
        bias = self.turn_on_bias_deg_h * rng.standard_normal(n_axes)
        return TurnOn(max(0.0, t), tuple(float(b) for b in bias))

    def transient_deg_h(self, t0_s: ArrayLike, dt_s: float) -> NDArray[np.float64]:
        """Mean of the warm-up transient (deg/h) over each interval ``[t0, t0 + dt)``,
        ``t0`` in s since power-on (exact)."""
        t0 = np.asarray(t0_s, dtype=np.float64)
        tau = self.warmup_tau_s
        if dt_s <= 0:
            return np.asarray(self.warmup_deg_h * np.exp(-t0 / tau), dtype=np.float64)
        return np.asarray(self.warmup_deg_h * np.exp(-t0 / tau) * (-np.expm1(-dt_s / tau))
                          * tau / dt_s, dtype=np.float64)

    def temperature_bias_deg_h(self, temperature_c: ArrayLike) -> NDArray[np.float64]:
        """The bias (deg/h) the die temperature (degC) adds."""
        d = np.asarray(temperature_c, dtype=np.float64) - self.reference_c
        return np.asarray(self.tempco_deg_h_per_c * d + self.tempco2_deg_h_per_c2 * d * d,
                          dtype=np.float64)

    def warmup_time_s(self, band_deg_h: float, *, record_s: float,
                      die_temperature_c: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                      step_s: float = 0.1) -> float:
        """The true warm-up time of a cycle (s since power-on) as the station defines it.

        The noise-free bias (transient plus temperature terms along
        ``die_temperature_c(t)``) is compared with its mean over the second half of a
        record of ``record_s`` seconds from power-on; the warm-up time is the last time it
        lies outside ``+- band_deg_h`` of that mean (0 when never).
        """
        t = np.arange(0.0, record_s, step_s)
        bias = self.transient_deg_h(t, 0.0) + self.temperature_bias_deg_h(die_temperature_c(t))
        reference = float(bias[t >= record_s / 2].mean())
        outside = np.flatnonzero(np.abs(bias - reference) > band_deg_h)
        return 0.0 if outside.size == 0 else float(t[outside[-1]] + step_s)


@dataclass(frozen=True)
class ThermalModel:
    """The die temperature of a unit: a first-order lag behind the air, plus self-heating.

    ``dT/dt = (T_air + S * powered - T) / unit_tau_s``.

    Attributes
    ----------
    unit_tau_s : float
        Thermal time constant of the unit in its chamber, s.
    self_heating_c : float
        Rise of the die above the air once warm, degC, while powered.
    """

    unit_tau_s: float = 120.0
    self_heating_c: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.unit_tau_s) and self.unit_tau_s > 0):
            raise ValueError(f"unit_tau_s must be a finite number > 0, got {self.unit_tau_s}")
        if not math.isfinite(self.self_heating_c):
            raise ValueError(f"self_heating_c must be finite, got {self.self_heating_c}")

    def step(self, die_c: float, air_start_c: float, air_end_c: float, powered: bool,
             dt_s: float) -> float:
        """The die temperature (degC) ``dt_s`` later, the air moving linearly from
        ``air_start_c`` to ``air_end_c`` meanwhile (exact for that input)."""
        return first_order_step(die_c, air_start_c + self.self_heating_c * powered,
                                air_end_c + self.self_heating_c * powered, self.unit_tau_s,
                                dt_s)

    def warm_die_c(self, air_c: float, t_since_on_s: ArrayLike, *, start_c: float | None = None
                   ) -> NDArray[np.float64]:
        """Die temperature (degC) at ``t`` s after power-on in air held at ``air_c``, from
        ``start_c`` (default: the air's, a unit fully cooled down)."""
        t = np.asarray(t_since_on_s, dtype=np.float64)
        t_start = air_c if start_c is None else start_c
        warm = air_c + self.self_heating_c
        return np.asarray(warm + (t_start - warm) * np.exp(-t / self.unit_tau_s),
                          dtype=np.float64)


def first_order_step(x_c: float, target_start_c: float, target_end_c: float, tau_s: float,
                     dt_s: float) -> float:
    """A first-order lag ``dx/dt = (u - x) / tau`` advanced by ``dt_s`` while its input ``u``
    moves linearly from ``target_start_c`` to ``target_end_c`` (exact)."""
    if dt_s <= 0:
        return x_c
    a = math.exp(-dt_s / tau_s)
    slope = (target_end_c - target_start_c) / dt_s
    # x(t) = u(t) - slope * tau + C exp(-t / tau), C from x(0)
    c = x_c - target_start_c + slope * tau_s
    return target_end_c - slope * tau_s + c * a
