"""What ``station analyze`` reports for one axis (:class:`AxisAnalysis`), with its gaps and
spikes, and the keys an accelerometer axis' JSON takes: the one record of an analysed axis
that the analysis (:mod:`station.evaluation.analyze`), the accelerometer path
(:mod:`station.evaluation.accel_axes`) and the text views read, apart from all of them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from analysis.allan.deviations import DEVIATION_LABELS, DeviationResult, from_allan
from analysis.allan.estimators import AllanResult
from analysis.allan.outliers import SpikeDetection
from analysis.figures.accel import STANDARD_GRAVITY_M_S2, AccelFigures
from analysis.figures.spec import SpecFigures
from analysis.figures.tones import Tone
from analysis.figures.zones import TauZone
from analysis.fit.least_squares import NoiseCoefficients
from analysis.fit.model import COEFFICIENT_NAMES
from analysis.gmwm.selection import GmwmSelection
from analysis.units.conversions import DEG_PER_URAD, S_PER_H

#: What an axis measures.
Quantity = Literal["rate", "acceleration"]

#: ug per "deg/h" of an m/s^2 series (the gyro figures' time factor taken off).
_UG = 1e6 / STANDARD_GRAVITY_M_S2 / S_PER_H
#: The fit's coefficients of an m/s^2 series: key and factor from the gyro key's value.
ACCEL_FIT_KEYS = {
    "Q": ("Q_m_s", DEG_PER_URAD),  # urad -> deg -> the series' unit times s: m/s
    "N": ("N_m_s_rt_h", 1.0),
    "B": ("B_ug", _UG),
    "K": ("K_m_s_h1_5", 1.0),
    "R": ("R_m_s_h2", 1.0),
}



def accel_unit(curve: DeviationResult) -> str:
    """The unit of an accelerometer axis' deviation: m/s^2 (m/s for an angle-like tdev)."""
    return "m/s" if curve.unit == "angle" else "m/s^2"


def accel_curve_keys(curve: DeviationResult) -> dict[str, list[float]]:
    """``adev_m_s2``, ``adev_ci_low_m_s2``, ``adev_ci_high_m_s2`` (tdev: ``_m_s``): an
    accelerometer axis' deviation and its interval under keys naming their unit."""
    suffix = "m_s" if curve.unit == "angle" else "m_s2"
    return {f"adev{k}_{suffix}": v.tolist() for k, v in (
        ("", curve.deviation), ("_ci_low", curve.deviation_ci_low),
        ("_ci_high", curve.deviation_ci_high))}


def accel_fit_dict(fit_json: dict[str, object]) -> dict[str, object]:
    """The ``fit`` object of an accelerometer axis: the gyro keys renamed (and scaled) to
    the accelerometer units of :data:`ACCEL_FIT_KEYS`."""
    out = dict(fit_json)
    for term, (key, factor) in ACCEL_FIT_KEYS.items():
        old = COEFFICIENT_NAMES[term]
        for suffix in ("", "_stderr"):
            value = out.pop(f"{old}{suffix}", None)
            out[f"{key}{suffix}"] = (value * factor if isinstance(value, float) else value)
    return out


#: How many spikes a report lists one by one.
SPIKES_LISTED = 100


@dataclass(frozen=True)
class GapReport:
    """Samples missing from an axis' record: gaps, seconds lost, share of the record's time."""

    count: int = 0
    missing_s: float = 0.0
    share: float = 0.0

    def as_json(self) -> dict[str, object]:
        """The ``gaps`` object of ``station analyze --json``."""
        return {"count": self.count, "missing_s": self.missing_s, "share": self.share}

    def text(self) -> str:
        """One line for tables and notes."""
        if not self.count:
            return "none"
        return f"{self.count} ({self.missing_s:.4g} s, {self.share:.2%} of the time)"


@dataclass(frozen=True)
class OutlierReport:
    """The spikes found in an axis' record and whether the analysis left them out."""

    detection: SpikeDetection | None = None
    removed: bool = False
    rule: str = "not looked for"
    times_s: tuple[float, ...] = ()
    #: An accelerometer axis' spikes are in m/s^2 (a rate axis': deg/s, shown in deg/h).
    quantity: Quantity = "rate"

    @property
    def count(self) -> int:
        """Spikes found (runs of consecutive flagged samples)."""
        return 0 if self.detection is None else len(self.detection.spikes)

    def as_json(self) -> dict[str, object]:
        """The ``outliers`` object of ``station analyze --json`` (sizes in deg/h; an
        accelerometer axis': m/s^2, keys ``scale_m_s2``, ``size_m_s2``)."""
        d = self.detection
        out: dict[str, object] = {"count": self.count, "removed": self.removed, "rule": self.rule}
        if d is not None:
            key, factor = self._size_key()
            out.update({
                "samples": d.count, "share": d.share, "threshold_z": d.threshold_z,
                "false_alarm": d.false_alarm, f"scale_{key}": d.scale * factor,
                "spikes": [{"time_s": t, "n_samples": sp.n_samples, f"size_{key}": sp.size * factor,
                            "z": sp.z} for t, sp in zip(self.times_s, d.spikes[:SPIKES_LISTED],
                                                        strict=False)],
                "listed": min(self.count, SPIKES_LISTED)})
        return out

    def _size_key(self) -> tuple[str, float]:
        """(unit in a key, factor from the samples' unit) of a spike's size."""
        return ("m_s2", 1.0) if self.quantity == "acceleration" else ("deg_h", S_PER_H)

    def text(self) -> str:
        """One line for tables."""
        if self.detection is None:
            return "not looked for"
        if not self.count:
            return "none"
        return f"{self.count} {'removed' if self.removed else 'kept'}"

    def note(self) -> str:
        """The sentence every report carries when spikes were found."""
        d = self.detection
        if d is None or not self.count:
            return ""
        largest = max(d.spikes, key=lambda sp: abs(sp.size))
        key, factor = self._size_key()
        unit = "m/s^2" if key == "m_s2" else "deg/h"
        what = ("removed, each replaced by the line between its neighbours" if self.removed
                else "kept in the analysis")
        return (
            f"{self.count} spike(s) ({d.count} samples beyond {d.threshold_z:.2f} sigma; largest "
            f"{largest.size * factor:+.4g} {unit} at {self.times_s[d.spikes.index(largest)]:.6g} "
            "s) "
            f"{what}: {self.rule}"
        )


def _in_station_units(c: DeviationResult) -> dict[str, list[float]]:
    """The curve in the deg/h family of every other figure: ``adev_deg_h``, ``adev_ci_low_deg_h``,
    ``adev_ci_high_deg_h`` (an angle deviation, tdev: ``adev_deg``... in deg, as it is)."""
    if c.unit == "angle":
        return {"adev_deg": c.deviation.tolist(), "adev_ci_low_deg": c.deviation_ci_low.tolist(),
                "adev_ci_high_deg": c.deviation_ci_high.tolist()}
    return {"adev_deg_h": (c.deviation * S_PER_H).tolist(),
            "adev_ci_low_deg_h": (c.deviation_ci_low * S_PER_H).tolist(),
            "adev_ci_high_deg_h": (c.deviation_ci_high * S_PER_H).tolist()}


@dataclass(frozen=True)
class AxisAnalysis:
    """Everything ``station analyze`` reports for one axis.

    ``allan`` is the Allan variance the fit and the spec figures come from; ``curve`` is
    the deviation shown and listed when another than that Allan deviation was asked for
    (:attr:`shown` is the one to show either way).
    ``rate_deg_s`` is the rate the figures were computed from: on the record's time grid
    (NaN where a sample is missing), spikes replaced when they were removed, the Earth
    rate taken off when the bench gave it. ``allan_alternative`` is the Allan curve the
    other way round (spikes kept when they were removed, and the reverse), when spikes
    were found; ``alternative_label`` says which.
    """

    name: str
    sample_rate_hz: float
    n_samples: int
    allan: AllanResult
    fit: NoiseCoefficients
    figures: SpecFigures
    gaps: GapReport = field(default_factory=GapReport)
    outliers: OutlierReport = field(default_factory=OutlierReport)
    rate_deg_s: NDArray[np.float64] | None = None
    allan_alternative: AllanResult | None = None
    alternative_label: str = ""
    tones: tuple[Tone, ...] = ()
    zones: tuple[TauZone, ...] = ()
    curve: DeviationResult | None = None
    gmwm: GmwmSelection | None = None
    #: What the axis measures; an accelerometer axis' series is in m/s^2 where a rate
    #: axis' is in deg/s, and ``accel`` holds its figures.
    quantity: Quantity = "rate"
    accel: AccelFigures | None = None

    @property
    def shown(self) -> DeviationResult:
        """The deviation shown and listed: ``curve``, else the fit's Allan deviation."""
        return self.curve if self.curve is not None else from_allan(self.allan)

    def as_json(self) -> dict[str, object]:
        """The JSON object of one axis (the ``station analyze --json`` interface).

        ``tau_s``, ``adev``, ``adev_ci_low``, ``adev_ci_high`` and ``n_clusters`` are those
        of the chosen ``deviation`` (``adev`` holds its values, in ``deviation_unit``);
        ``fit`` and ``figures`` always come from the Allan variance named by ``estimator``.
        """
        c, accel = self.shown, self.accel
        unit = ("deg" if c.unit == "angle" else "deg/s") if accel is None else accel_unit(c)
        station_units = _in_station_units(c) if accel is None else accel_curve_keys(c)
        return {
            "name": self.name,
            "quantity": self.quantity,
            "sample_rate_hz": self.sample_rate_hz,
            "n_samples": self.n_samples,
            "estimator": self.allan.estimator,
            "deviation": c.kind,
            "deviation_label": DEVIATION_LABELS[c.kind],
            "deviation_unit": unit,
            "tau_s": c.tau_s.tolist(),
            "adev": c.deviation.tolist(),
            **station_units,
            "adev_ci_low": c.deviation_ci_low.tolist(),
            "adev_ci_high": c.deviation_ci_high.tolist(),
            "n_clusters": c.n_clusters.tolist(),
            "edf": c.edf.tolist(),
            "noise_alpha": c.noise_alpha.tolist(),
            "interval": c.interval,
            "curve_notes": list(c.notes),
            "fit_from": DEVIATION_LABELS[from_allan(self.allan).kind].replace(
                "deviation", "variance"
            ),
            "fit": self.fit.as_dict() if accel is None else accel_fit_dict(self.fit.as_dict()),
            "figures": self.figures.as_dict() if accel is None else accel.as_dict(),
            "gaps": self.gaps.as_json(),
            "outliers": self.outliers.as_json(),
            "tones": [t.as_dict() for t in self.tones],
            "excluded_taus": [z.as_dict() for z in self.zones],
            **({"gmwm": self.gmwm.as_json()} if self.gmwm is not None else {}),
        }
