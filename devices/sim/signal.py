"""The rate signal a simulated gyro outputs, drawn from a noise model.

One class wraps :class:`analysis.models.simulation.GyroSimulator` so that every simulated device
draws its signal the same way. The model is whatever
:func:`devices.model_files.load_noise_model` resolves (a TOML path or a preset of
``profiles/models``: ``VG951``, ``SRS2000``, ...); the protocol's own device names
(``STIM300``, ``DSP-1750``, ``MTI-630``) fall back to small data-sheet-like models here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from analysis.errors import ModelError
from analysis.models.accel_noise import AccelNoiseModel, AccelSimulator
from analysis.models.simulation import GyroSimulator
from analysis.models.terms import (
    AngleRandomWalk,
    Bias,
    BiasInstability,
    NoiseModel,
    RateRandomWalk,
)
from devices.model_files import load_accel_model, load_noise_model, resolve_model_path

#: (ARW deg/sqrt(h), bias instability deg/h, RRW deg/h^1.5, bias deg/h) of the device
#: names the simulated protocols use when no model file or preset has that name.
_DEVICE_MODELS: dict[str, tuple[float, float, float, float]] = {
    "STIM300": (0.15, 0.5, 0.3, 36.0),
    "DSP-1750": (0.012, 0.05, 0.02, 36.0),
    "MTI-630": (0.3, 8.0, 3.0, 36.0),
    "GENERIC": (0.2, 1.0, 0.5, 36.0),
}
DEVICE_MODEL_NAMES = tuple(_DEVICE_MODELS)
#: Accelerometers of the same device names (data-sheet-like): velocity random walk
#: m/s/sqrt(h), bias instability micro-g, acceleration random walk m/s/h^1.5, temperature
#: sensitivity milli-g/degC. GENERIC is also the accelerometer of a model file without an
#: ``[accelerometer]`` table.
_DEVICE_ACCELEROMETERS: dict[str, AccelNoiseModel] = {
    "STIM300": AccelNoiseModel(vrw_m_s_rt_h=0.07, bias_instability_ug=50.0,
                               accel_rw_m_s_h1_5=0.01, tempco_mg_per_c=0.05),
    "DSP-1750": AccelNoiseModel(vrw_m_s_rt_h=0.07, bias_instability_ug=50.0,
                                accel_rw_m_s_h1_5=0.01, tempco_mg_per_c=0.05),
    "MTI-630": AccelNoiseModel(vrw_m_s_rt_h=0.035, bias_instability_ug=15.0,
                               accel_rw_m_s_h1_5=0.005, tempco_mg_per_c=0.1),
    "GENERIC": AccelNoiseModel(vrw_m_s_rt_h=0.1, bias_instability_ug=100.0,
                               accel_rw_m_s_h1_5=0.02, tempco_mg_per_c=0.1),
}
#: Temperature a simulated gyro reports when its model has no temperature term, degC.
DEFAULT_TEMPERATURE_C = 25.0


def noise_model(ref: str) -> NoiseModel:
    """The noise model a simulated device URL names: a TOML path or a preset, else one of
    the device models of :data:`DEVICE_MODEL_NAMES`.

    Raises
    ------
    ValueError
        Neither a model file, a preset, nor a device model (``ModelError`` is one).
    """
    try:
        return load_noise_model(ref)
    except ModelError as exc:
        device = _DEVICE_MODELS.get(ref.upper())
        if device is None:
            raise ModelError(f"{exc}; or a device model: {', '.join(DEVICE_MODEL_NAMES)}"
                             ) from exc
    arw, bi, rrw, bias = device
    return NoiseModel(
        terms=(AngleRandomWalk(N_deg_rt_h=arw), BiasInstability(B_deg_h=bi),
               RateRandomWalk(K_deg_h_1_5=rrw), Bias(value_deg_h=bias)),
        name=ref.upper(), source="devices.sim.signal device model")


def accel_model(ref: str) -> AccelNoiseModel:
    """The accelerometer model of a simulated IMU: the ``[accelerometer]`` table of the
    model file or preset ``ref``, else that of the device model of that name, else the
    generic one.

    Raises
    ------
    ModelError
        A model file with a bad ``[accelerometer]`` table.
    """
    try:
        path = resolve_model_path(ref)
    except ModelError:
        path = None  # a device model's name (noise_model refuses any other)
    found = load_accel_model(path) if path is not None else None
    if found is not None:
        return found
    return _DEVICE_ACCELEROMETERS.get(ref.upper(), _DEVICE_ACCELEROMETERS["GENERIC"])


@dataclass(frozen=True)
class SignalChunk:
    """Rates (deg/s, shape (n, n_axes)) and temperature (degC, shape (n,)) of n samples,
    and the accelerations (m/s^2, shape (n, n_accel_axes)) of an IMU (None otherwise)."""

    rate_deg_s: NDArray[np.float64]
    temperature_c: NDArray[np.float64]
    accel_m_s2: NDArray[np.float64] | None = None


#: Fewest samples :meth:`SignalSource.read` draws at once (at 2 kHz, 0.128 s of signal).
READ_AHEAD = 256


class SignalSource:
    """Streaming rate signal of a simulated gyro.

    Parameters
    ----------
    model : str
        Preset name or noise-model TOML path (see :func:`noise_model`).
    sample_rate_hz : float
        Sample rate, Hz.
    n_axes : int
        Number of axes.
    seed : int or None
        Seed; the same seed gives the same samples.
    earth_rate_deg_s : sequence of float, optional
        The Earth's rotation each axis sees where the gyro sits (deg/s), added to every
        sample, as a real gyro at rest measures it (:mod:`analysis.units.earth`).
    n_accel_axes : int
        Accelerometer axes of an IMU (0: a gyro; no accelerations are drawn).
    gravity_m_s2 : sequence of float, optional
        Gravity each accelerometer axis sees at rest, m/s^2 (default: +g on z).
    """

    def __init__(self, model: str, sample_rate_hz: float, *, n_axes: int = 3,
                 seed: int | None = None, earth_rate_deg_s: Sequence[float] | None = None,
                 n_accel_axes: int = 0, gravity_m_s2: Sequence[float] | None = None) -> None:
        self.model = model
        self.n_axes = n_axes
        # a device reads a few samples at a time: short_reads spares it scipy's import
        self._sim = GyroSimulator(noise_model(model), sample_rate_hz, n_axes=n_axes, seed=seed,
                                  short_reads=True)
        self._earth = (
            None if earth_rate_deg_s is None else np.asarray(earth_rate_deg_s, dtype=float)
        )
        self.accel = (AccelSimulator(accel_model(model), sample_rate_hz, n_axes=n_accel_axes,
                                     seed=seed, gravity_m_s2=gravity_m_s2, short_reads=True)
                      if n_accel_axes else None)
        #: Samples drawn and not yet read.
        self._ahead = SignalChunk(np.empty((0, n_axes)), np.empty(0),
                                  None if self.accel is None else np.empty((0, n_accel_axes)))

    def read(self, n_samples: int) -> SignalChunk:
        """The next ``n_samples`` samples of the signal.

        The samples are drawn :data:`READ_AHEAD` at a time at least and handed out from
        what was drawn: a device takes a few samples a pass, and a draw costs about as
        much for 4 samples as for 256 (0.6 ms, a third of a 2 kHz device's pass). The
        numbers are those of one draw of the whole run, however it is read."""
        short = n_samples - len(self._ahead.temperature_c)
        if short > 0:
            self._ahead = _joined(self._ahead, self._draw(max(short, READ_AHEAD)))
        ahead = self._ahead
        self._ahead = SignalChunk(ahead.rate_deg_s[n_samples:], ahead.temperature_c[n_samples:],
                                  None if ahead.accel_m_s2 is None
                                  else ahead.accel_m_s2[n_samples:])
        return SignalChunk(ahead.rate_deg_s[:n_samples], ahead.temperature_c[:n_samples],
                           None if ahead.accel_m_s2 is None else ahead.accel_m_s2[:n_samples])

    def _draw(self, n_samples: int) -> SignalChunk:
        """The next ``n_samples`` samples from the simulators."""
        chunk = self._sim.read(n_samples)
        rate = chunk.rate_deg_s if self._earth is None else chunk.rate_deg_s + self._earth
        temp = chunk.temperature_c
        if temp is None:
            temp = np.full(n_samples, DEFAULT_TEMPERATURE_C)
        temp = np.asarray(temp, dtype=np.float64)
        accel = None if self.accel is None else self.accel.read(n_samples, temp)
        return SignalChunk(rate, temp, accel)


def _joined(first: SignalChunk, second: SignalChunk) -> SignalChunk:
    """The samples of ``first`` followed by those of ``second``."""
    accel = (None if first.accel_m_s2 is None or second.accel_m_s2 is None
             else np.concatenate([first.accel_m_s2, second.accel_m_s2]))
    return SignalChunk(np.concatenate([first.rate_deg_s, second.rate_deg_s]),
                       np.concatenate([first.temperature_c, second.temperature_c]), accel)
