"""``model``: a noise model's theoretical Allan deviation, and FOG models from two indicators."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from analysis.allan.estimators import resolve_m
from analysis.models.fog import fog_from_indicators
from analysis.models.simulation import n_samples_of
from analysis.models.terms import NoiseModel
from analysis.units.conversions import S_PER_H
from devices.model_files import load_noise_model, save_noise_model
from station.errors import UsageError


@dataclass(frozen=True)
class CurveRequest:
    """A model and the taus to evaluate it at: a named grid (``log``, ``octave``, ``all``)
    of a record of ``duration_s`` at ``rate_hz``, or comma-separated taus in s."""

    model: str
    taus: str = "log"
    rate_hz: float = 10.0
    duration_s: float = 4 * 3600.0


@dataclass(frozen=True, eq=False)  # arrays: compared by identity
class ModelCurve:
    """A model's theoretical Allan deviation (deg/s) and each term's, at ``tau_s`` (s)."""

    model: NoiseModel
    tau_s: NDArray[np.float64]
    adev: NDArray[np.float64]
    terms: dict[str, NDArray[np.float64]]

    def as_json(self) -> dict[str, object]:
        """``{"tau_s", "adev_deg_h", "terms_deg_h": {"<term>": [...]}, "adev", "terms"}``:
        the curve in deg/h like every other figure; ``adev`` and ``terms`` (deg/s) are the
        keys older readers know."""
        return {"tau_s": self.tau_s.tolist(), "adev_deg_h": (self.adev * S_PER_H).tolist(),
                "terms_deg_h": {k: (v * S_PER_H).tolist() for k, v in self.terms.items()},
                "adev": self.adev.tolist(), "terms": {k: v.tolist() for k, v in self.terms.items()}}


def curve_taus(grid: str, sample_rate_hz: float, duration_s: float) -> NDArray[np.float64]:
    """Averaging times (s) of a named grid for a record, or of a comma-separated list.

    Raises
    ------
    UsageError
        If the list holds something that is not a number.
    """
    if grid in ("log", "octave", "all"):
        n = n_samples_of(duration_s, sample_rate_hz)
        return resolve_m(grid, n, sample_rate_hz) / sample_rate_hz
    try:
        taus = np.array([float(x) for x in grid.split(",") if x.strip()])
    except ValueError as exc:
        raise UsageError(f"--taus must be log, octave, all or numbers like 0.1,1,10; got "
                         f"{grid!r}") from exc
    if taus.size == 0:
        raise UsageError("--taus names no averaging time")
    return taus


def model_curve(request: CurveRequest) -> ModelCurve:
    """The theoretical Allan deviation of ``request.model`` on its taus."""
    model = load_noise_model(request.model)
    taus = curve_taus(request.taus, request.rate_hz, request.duration_s)
    adev = model.adev(taus, duration_s=request.duration_s)
    terms = {name: np.sqrt(avar)
             for name, avar in model.term_avars(taus, duration_s=request.duration_s).items()}
    return ModelCurve(model, taus, adev, terms)


@dataclass(frozen=True)
class FogRequest:
    """A data sheet's ARW (deg/sqrt(h)) and bias stability (deg/h, 1 sigma of ``average_s``
    averages), the Markov correlation time (s; default ``average_s``), the model's name,
    and where to write it (None: only returned)."""

    arw_deg_rt_h: float
    bias_stability_deg_h: float
    average_s: float = 100.0
    correlation_s: float | None = None
    name: str = ""
    out: Path | None = None


@dataclass(frozen=True)
class FogModel:
    """The white-noise-plus-Markov FOG model (docs/fog-model.md) and a line saying what it is."""

    model: NoiseModel
    comment: str


def fog_model(request: FogRequest) -> FogModel:
    """The FOG model of two indicators; written to ``request.out`` when given."""
    params = fog_from_indicators(request.arw_deg_rt_h, request.bias_stability_deg_h,
                                 average_s=request.average_s, correlation_s=request.correlation_s)
    model = params.noise_model(request.name)
    comment = (f"white noise + first-order Markov FOG (docs/fog-model.md): Markov sigma "
               f"{params.markov_sigma_deg_h:.6g} deg/h, T {params.correlation_s:g} s")
    if request.out is not None:
        save_noise_model(model, request.out, comment=comment)
    return FogModel(model, comment)
