"""Gyro noise models: the terms, their theoretical Allan variance, and their TOML text form.

A :class:`NoiseModel` is a plain frozen value holding at most one term of each kind. Each
term is a frozen dataclass whose fields are named exactly as its TOML keys and are in the
units engineers use on data sheets (urad, deg/sqrt(h), deg/h, deg/h^1.5, deg/h^2, s, degC);
properties give the base units the analysis works in (deg, s, deg/s).

Every term has its theoretical Allan variance ``avar(tau_s)`` in (deg/s)^2 (closed forms:
Lv et al. 2015 eq. 3 and Zhang et al. 2015 eq. 7-11 for the five IEEE terms, IEEE Std
952-1997 Annex C for the Gauss-Markov and sinusoidal terms, :mod:`analysis.allan.curves` and the
docstrings for the rest); the model's curve is the sum (Zhang 2015 eq. 12), which assumes
the terms are independent.

The TOML form names each term in a table of its own (``[arw]``, ``[bias_instability]``,
...) with optional top-level ``name`` and ``source`` strings; ``profiles/README.md``
documents every key. Text in, text out: reading files is the devices layer's job.
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Iterator, Mapping
from dataclasses import MISSING, dataclass, field, fields, replace
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan.curves import (
    FLICKER_AVAR_FACTOR,
    as_tau,
    deterministic_avar,
    gauss_markov_avar,
    sinusoid_avar,
)
from analysis.errors import ModelError
from analysis.units import conversions as units


def _key(unit: str, *, minimum: str = "any", default: float | None = None, doc: str = "") -> Any:
    """A dataclass field carrying its unit, its allowed range and its documentation."""
    meta = {"unit": unit, "minimum": minimum, "doc": doc}
    if default is None:
        return field(metadata=meta)
    return field(default=default, metadata=meta)


# ----------------------------------------------------------------------------------- terms


@dataclass(frozen=True)
class NoiseTerm:
    """Base of the model terms: field checks, TOML table conversion, Allan deviation."""

    name: ClassVar[str] = ""
    title: ClassVar[str] = ""

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ModelError(f"[{self.name}] {f.name} must be a number, got {value!r}")
            value = float(value)
            if not math.isfinite(value):
                raise ModelError(f"[{self.name}] {f.name} must be finite, got {value}")
            minimum = f.metadata.get("minimum", "any")
            if minimum == "positive" and not value > 0:
                raise ModelError(f"[{self.name}] {f.name} must be > 0, got {value}")
            if minimum == "nonnegative" and value < 0:
                raise ModelError(f"[{self.name}] {f.name} must be >= 0, got {value}")
            object.__setattr__(self, f.name, value)

    def avar(self, tau_s: ArrayLike, *, duration_s: float | None = None) -> NDArray[np.float64]:
        """Theoretical Allan variance in (deg/s)^2 at ``tau_s`` (s); see each term."""
        raise NotImplementedError

    def adev(self, tau_s: ArrayLike, *, duration_s: float | None = None) -> NDArray[np.float64]:
        """Theoretical Allan deviation in deg/s at ``tau_s`` (s)."""
        return np.sqrt(self.avar(tau_s, duration_s=duration_s))

    def to_table(self) -> dict[str, float]:
        """The term's TOML table as a dict: key (with its unit) -> value."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_table(cls, table: Mapping[str, Any]) -> NoiseTerm:
        """Build the term from its TOML table, refusing unknown or missing keys.

        Raises
        ------
        ModelError
            Unknown key, missing required key, or a value out of range.
        """
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(table) - known)
        if unknown:
            raise ModelError(
                f"[{cls.name}] unknown key(s) {', '.join(unknown)}; known: "
                f"{', '.join(sorted(known))}"
            )
        try:
            return cls(**dict(table))
        except TypeError as exc:
            required = [f.name for f in fields(cls) if f.default is MISSING]
            raise ModelError(f"[{cls.name}] needs key(s) {', '.join(required)}: {exc}") from exc

    @classmethod
    def keys(cls) -> Iterator[tuple[str, str, str, str]]:
        """(key, unit, allowed range, description) of every TOML key of the term."""
        for f in fields(cls):
            yield f.name, f.metadata["unit"], f.metadata["minimum"], f.metadata["doc"]


@dataclass(frozen=True)
class Quantization(NoiseTerm):
    """Quantization noise: white angle noise of standard deviation Q (Lv 2015 eq. 3)."""

    name: ClassVar[str] = "quantization"
    title: ClassVar[str] = "quantization noise"
    Q_urad: float = _key("urad", minimum="nonnegative", doc="quantization coefficient Q")

    @property
    def q_deg(self) -> float:
        """Q in deg."""
        return units.q_urad_to_deg(self.Q_urad)

    def avar(self, tau_s: ArrayLike, *, duration_s: float | None = None) -> NDArray[np.float64]:
        """``3 Q^2 / tau^2`` in (deg/s)^2 (Lv 2015 eq. 3; Zhang 2015 eq. 7)."""
        return 3.0 * self.q_deg**2 / as_tau(tau_s) ** 2


@dataclass(frozen=True)
class AngleRandomWalk(NoiseTerm):
    """Angle random walk: white rate noise of coefficient N."""

    name: ClassVar[str] = "arw"
    title: ClassVar[str] = "angle random walk"
    N_deg_rt_h: float = _key("deg/sqrt(h)", minimum="nonnegative", doc="angle random walk N")

    @property
    def n_deg_rt_s(self) -> float:
        """N in deg/sqrt(s)."""
        return units.arw_deg_rt_h_to_deg_rt_s(self.N_deg_rt_h)

    def avar(self, tau_s: ArrayLike, *, duration_s: float | None = None) -> NDArray[np.float64]:
        """``N^2 / tau`` in (deg/s)^2 (Lv 2015 eq. 3; Zhang 2015 eq. 8)."""
        return self.n_deg_rt_s**2 / as_tau(tau_s)


@dataclass(frozen=True)
class BiasInstability(NoiseTerm):
    """Bias instability: flicker (1/f) rate noise, Allan plateau 0.664 B."""

    name: ClassVar[str] = "bias_instability"
    title: ClassVar[str] = "bias instability"
    B_deg_h: float = _key("deg/h", minimum="nonnegative", doc="bias instability B")

    @property
    def b_deg_s(self) -> float:
        """B in deg/s."""
        return units.rate_deg_h_to_deg_s(self.B_deg_h)

    def avar(self, tau_s: ArrayLike, *, duration_s: float | None = None) -> NDArray[np.float64]:
        """``(2 ln 2 / pi) B^2 = (0.664 B)^2`` in (deg/s)^2 (Zhang 2015 eq. 9; Lv 2015 eq. 3)."""
        tau = as_tau(tau_s)
        return np.full(tau.shape, FLICKER_AVAR_FACTOR * self.b_deg_s**2)


@dataclass(frozen=True)
class RateRandomWalk(NoiseTerm):
    """Rate random walk: the rate integrates white noise, coefficient K."""

    name: ClassVar[str] = "rate_random_walk"
    title: ClassVar[str] = "rate random walk"
    K_deg_h_1_5: float = _key("deg/h^1.5", minimum="nonnegative", doc="rate random walk K")

    @property
    def k_deg_s_1_5(self) -> float:
        """K in deg/s^1.5."""
        return units.rrw_deg_h_1_5_to_deg_s_1_5(self.K_deg_h_1_5)

    def avar(self, tau_s: ArrayLike, *, duration_s: float | None = None) -> NDArray[np.float64]:
        """``K^2 tau / 3`` in (deg/s)^2 (Lv 2015 eq. 3; Zhang 2015 eq. 10)."""
        return self.k_deg_s_1_5**2 * as_tau(tau_s) / 3.0


@dataclass(frozen=True)
class RateRamp(NoiseTerm):
    """Rate ramp: a rate growing linearly in time, ``R t``."""

    name: ClassVar[str] = "rate_ramp"
    title: ClassVar[str] = "rate ramp"
    R_deg_h2: float = _key("deg/h^2", doc="rate ramp R (its sign is the ramp's direction)")

    @property
    def r_deg_s2(self) -> float:
        """R in deg/s^2."""
        return units.ramp_deg_h2_to_deg_s2(self.R_deg_h2)

    def avar(self, tau_s: ArrayLike, *, duration_s: float | None = None) -> NDArray[np.float64]:
        """``R^2 tau^2 / 2`` in (deg/s)^2 (Lv 2015 eq. 3; Zhang 2015 eq. 11)."""
        return self.r_deg_s2**2 * as_tau(tau_s) ** 2 / 2.0


@dataclass(frozen=True)
class GaussMarkov(NoiseTerm):
    """First-order Gauss-Markov rate: stationary std sigma, correlation time tau_s."""

    name: ClassVar[str] = "gauss_markov"
    title: ClassVar[str] = "Gauss-Markov process"
    sigma_deg_h: float = _key("deg/h", minimum="nonnegative", doc="stationary standard deviation")
    tau_s: float = _key("s", minimum="positive", doc="correlation time T")

    @property
    def sigma_deg_s(self) -> float:
        """sigma in deg/s."""
        return units.rate_deg_h_to_deg_s(self.sigma_deg_h)

    def avar(self, tau_s: ArrayLike, *, duration_s: float | None = None) -> NDArray[np.float64]:
        """Closed form of :func:`gauss_markov_avar` (IEEE Std 952-1997 Annex C), (deg/s)^2."""
        return gauss_markov_avar(tau_s, self.sigma_deg_s, self.tau_s)


@dataclass(frozen=True)
class Sinusoid(NoiseTerm):
    """Sinusoidal rate (thermal cycling, a nearby motor): amplitude, period, phase."""

    name: ClassVar[str] = "sinusoid"
    title: ClassVar[str] = "sinusoid"
    amplitude_deg_h: float = _key("deg/h", minimum="nonnegative", doc="amplitude (peak)")
    period_s: float = _key("s", minimum="positive", doc="period (1 / frequency)")
    phase_deg: float = _key("deg", default=0.0, doc="phase at t = 0 (sine convention)")

    @property
    def amplitude_deg_s(self) -> float:
        """Amplitude in deg/s."""
        return units.rate_deg_h_to_deg_s(self.amplitude_deg_h)

    @property
    def frequency_hz(self) -> float:
        """Frequency in Hz."""
        return 1.0 / self.period_s

    def avar(self, tau_s: ArrayLike, *, duration_s: float | None = None) -> NDArray[np.float64]:
        """Allan variance in (deg/s)^2 of the sinusoid.

        Without ``duration_s``: the phase-averaged closed form of :func:`sinusoid_avar`
        (IEEE Std 952-1997 Annex C), the expectation for a record of unknown phase. With
        it: exact for this phase over a record of that length (:func:`deterministic_avar`).
        """
        if duration_s is None:
            return sinusoid_avar(tau_s, self.amplitude_deg_s, self.period_s)
        return deterministic_avar(
            tau_s,
            duration_s=duration_s,
            cycle_amplitude=self.amplitude_deg_s,
            period_s=self.period_s,
            phase_deg=self.phase_deg,
        )


@dataclass(frozen=True)
class Bias(NoiseTerm):
    """Constant bias (turn-on bias): no Allan variance."""

    name: ClassVar[str] = "bias"
    title: ClassVar[str] = "constant bias"
    value_deg_h: float = _key("deg/h", doc="bias")

    @property
    def value_deg_s(self) -> float:
        """Bias in deg/s."""
        return units.rate_deg_h_to_deg_s(self.value_deg_h)

    def avar(self, tau_s: ArrayLike, *, duration_s: float | None = None) -> NDArray[np.float64]:
        """Zero at every tau: every Allan difference cancels a constant."""
        return np.zeros(as_tau(tau_s).shape)


@dataclass(frozen=True)
class TemperatureBias(NoiseTerm):
    """Temperature-driven bias ``c (T(t) - T_ref)`` on a profile the model generates.

    The temperature is a warm-up exponential plus a day/night cycle:
    ``T(t) = final_c + (start_c - final_c) exp(-t / warmup_s)
    + cycle_amplitude_c sin(2 pi t / cycle_period_s + cycle_phase_deg)``.
    """

    name: ClassVar[str] = "temperature_bias"
    title: ClassVar[str] = "temperature-driven bias"
    coefficient_deg_s_per_c: float = _key("deg/s per degC", doc="bias sensitivity to temperature")
    reference_c: float = _key("degC", default=25.0, doc="temperature of zero temperature bias")
    start_c: float = _key("degC", default=25.0, doc="temperature at t = 0 (switch-on)")
    final_c: float = _key("degC", default=25.0, doc="temperature the warm-up settles to")
    warmup_s: float = _key("s", minimum="positive", default=600.0, doc="warm-up time constant")
    cycle_amplitude_c: float = _key("degC", minimum="nonnegative", default=0.0,
                                    doc="amplitude of the temperature cycle")
    cycle_period_s: float = _key("s", minimum="positive", default=86400.0,
                                 doc="period of the temperature cycle")
    cycle_phase_deg: float = _key("deg", default=0.0, doc="phase of the cycle at t = 0")

    def temperature_mean_c(self, t0_s: ArrayLike, dt_s: float) -> NDArray[np.float64]:
        """Mean temperature (degC) over each interval ``[t0, t0 + dt)``, exactly.

        Parameters
        ----------
        t0_s : array_like
            Start of each interval in s since switch-on.
        dt_s : float
            Interval length in s (the sample period).
        """
        t0 = np.asarray(t0_s, dtype=np.float64)
        w = self.warmup_s
        warm = (self.start_c - self.final_c) * np.exp(-t0 / w) * (-np.expm1(-dt_s / w)) * w / dt_s
        omega = 2.0 * np.pi / self.cycle_period_s
        phase = np.deg2rad(self.cycle_phase_deg)
        half = omega * dt_s / 2.0
        cycle = (self.cycle_amplitude_c * np.sin(half) / half
                 * np.sin(omega * (t0 + dt_s / 2.0) + phase))
        return np.asarray(self.final_c + warm + cycle, dtype=np.float64)

    def avar(self, tau_s: ArrayLike, *, duration_s: float | None = None) -> NDArray[np.float64]:
        """Allan variance of the temperature bias in (deg/s)^2 over a record of ``duration_s``.

        The bias is ``A exp(-t/W)`` (warm-up, ``A = c (start_c - final_c)``) plus a
        sinusoid of amplitude ``|c| cycle_amplitude_c``, deterministic, so its Allan
        variance is exact for a record of ``duration_s`` (:func:`deterministic_avar`);
        with ``duration_s=None`` (an endless record) the warm-up vanishes and the cycle
        gives the phase-averaged :func:`sinusoid_avar`.
        """
        c = self.coefficient_deg_s_per_c
        return deterministic_avar(
            tau_s, duration_s=duration_s, warmup_amplitude=c * (self.start_c - self.final_c),
            warmup_s=self.warmup_s, cycle_amplitude=c * self.cycle_amplitude_c,
            period_s=self.cycle_period_s, phase_deg=self.cycle_phase_deg,
        )


@dataclass(frozen=True)
class BiasSteps(NoiseTerm):
    """Bias steps: jumps at random (Poisson) times, each of normal size N(0, size^2)."""

    name: ClassVar[str] = "bias_steps"
    title: ClassVar[str] = "bias steps"
    rate_per_h: float = _key("1/h", minimum="nonnegative", doc="mean number of steps per hour")
    size_deg_h: float = _key("deg/h", minimum="nonnegative", doc="standard deviation of a step")

    @property
    def rate_per_s(self) -> float:
        """Mean number of steps per second."""
        return self.rate_per_h / units.S_PER_H

    @property
    def size_deg_s(self) -> float:
        """Step standard deviation in deg/s."""
        return units.rate_deg_h_to_deg_s(self.size_deg_h)

    def avar(self, tau_s: ArrayLike, *, duration_s: float | None = None) -> NDArray[np.float64]:
        """``lambda s^2 tau / 3`` in (deg/s)^2.

        The bias is a compound Poisson process: steps at rate ``lambda`` (1/s) of
        variance ``s^2``. Its increments over ``t`` have variance ``lambda s^2 t`` and are
        independent, the same second moments as a rate random walk with
        ``K^2 = lambda s^2``, so its Allan variance is that of eq. 10 of Zhang 2015 (the
        distribution is not normal, so its estimates scatter more).
        """
        return self.rate_per_s * self.size_deg_s**2 * as_tau(tau_s) / 3.0


#: Every term kind, in the canonical order of the TOML text and of model curves.
TERM_TYPES: tuple[type[NoiseTerm], ...] = (
    Quantization, AngleRandomWalk, BiasInstability, RateRandomWalk, RateRamp,
    GaussMarkov, Sinusoid, Bias, TemperatureBias, BiasSteps,
)
TERM_NAMES: tuple[str, ...] = tuple(t.name for t in TERM_TYPES)


def term_type(name: str) -> type[NoiseTerm]:
    """The term class of a TOML table name (``"arw"``, ``"sinusoid"``, ...).

    Raises
    ------
    ModelError
        If no term has that name.
    """
    for kind in TERM_TYPES:
        if kind.name == name:
            return kind
    raise ModelError(f"unknown noise term [{name}]; known terms: {', '.join(TERM_NAMES)}")


# ----------------------------------------------------------------------------------- model


@dataclass(frozen=True)
class NoiseModel:
    """A gyro noise model: at most one term of each kind, plus a name and its source.

    Attributes
    ----------
    terms : tuple of NoiseTerm
        The terms, kept in the canonical order of :data:`TERM_NAMES`.
    name : str
        Short name (e.g. the gyro type).
    source : str
        Where the values come from (e.g. a paper's table).
    """

    terms: tuple[NoiseTerm, ...] = ()
    name: str = ""
    source: str = ""

    def __post_init__(self) -> None:
        terms = tuple(self.terms)
        for term in terms:
            if not isinstance(term, NoiseTerm) or type(term) not in TERM_TYPES:
                raise ModelError(f"not a noise term: {term!r}")
        names = [t.name for t in terms]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise ModelError(
                f"a model holds one term of each kind; repeated: {', '.join(duplicates)}"
            )
        ordered = tuple(sorted(terms, key=lambda t: TERM_NAMES.index(t.name)))
        object.__setattr__(self, "terms", ordered)

    @property
    def term_names(self) -> tuple[str, ...]:
        """Names of the model's terms, in canonical order."""
        return tuple(t.name for t in self.terms)

    def __contains__(self, name: object) -> bool:
        return name in self.term_names

    def get(self, name: str) -> NoiseTerm | None:
        """The term called ``name``, or None when the model lacks it."""
        for term in self.terms:
            if term.name == name:
                return term
        return None

    def with_term(self, term: NoiseTerm) -> NoiseModel:
        """A copy with ``term`` added, replacing a term of the same kind."""
        return replace(self, terms=(*[t for t in self.terms if t.name != term.name], term))

    def without_term(self, name: str) -> NoiseModel:
        """A copy without the term called ``name`` (unchanged if it has none)."""
        return replace(self, terms=tuple(t for t in self.terms if t.name != name))

    def term_avars(
        self, tau_s: ArrayLike, *, duration_s: float | None = None
    ) -> dict[str, NDArray[np.float64]]:
        """Theoretical Allan variance of each term in (deg/s)^2, by term name."""
        return {t.name: t.avar(tau_s, duration_s=duration_s) for t in self.terms}

    def avar(self, tau_s: ArrayLike, *, duration_s: float | None = None) -> NDArray[np.float64]:
        """Theoretical Allan variance of the model in (deg/s)^2: the sum of its terms.

        Zhang 2015 eq. 12 (independent terms). ``duration_s`` is the record length in s,
        needed only by transients (the warm-up of ``temperature_bias``).
        """
        total = np.zeros(as_tau(tau_s).shape)
        for values in self.term_avars(tau_s, duration_s=duration_s).values():
            total = total + values
        return total

    def adev(self, tau_s: ArrayLike, *, duration_s: float | None = None) -> NDArray[np.float64]:
        """Theoretical Allan deviation of the model in deg/s."""
        return np.sqrt(self.avar(tau_s, duration_s=duration_s))

    # ----------------------------------------------------------------------- TOML text

    def to_tables(self) -> dict[str, Any]:
        """The model as the nested dict of its TOML document (name, source, one table per term)."""
        doc: dict[str, Any] = {}
        if self.name:
            doc["name"] = self.name
        if self.source:
            doc["source"] = self.source
        for term in self.terms:
            doc[term.name] = term.to_table()
        return doc

    @classmethod
    def from_tables(cls, doc: Mapping[str, Any]) -> NoiseModel:
        """Build a model from the nested dict of its TOML document.

        Raises
        ------
        ModelError
            Unknown table or key, missing key, value of the wrong type or out of range.
        """
        name = doc.get("name", "")
        source = doc.get("source", "")
        if not isinstance(name, str) or not isinstance(source, str):
            raise ModelError("top-level 'name' and 'source' must be strings")
        terms = []
        for key, table in doc.items():
            # The [accelerometer] table of an IMU's model is read by
            # analysis.models.accel_noise.AccelNoiseModel, not a gyro term.
            if key in ("name", "source", "accelerometer"):
                continue
            kind = term_type(key)
            if not isinstance(table, Mapping):
                raise ModelError(f"[{key}] must be a table of keys, got {table!r}")
            terms.append(kind.from_table(table))
        return cls(terms=tuple(terms), name=name, source=source)

    @classmethod
    def from_toml(cls, text: str) -> NoiseModel:
        """Parse a model from TOML text (see ``profiles/README.md`` for the keys).

        Raises
        ------
        ModelError
            If the text is not TOML or does not describe a model.
        """
        try:
            doc = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ModelError(f"not valid TOML: {exc}") from exc
        return cls.from_tables(doc)

    def to_toml(self) -> str:
        """The model as TOML text; ``NoiseModel.from_toml(m.to_toml()) == m``."""
        lines = []
        for key in ("name", "source"):
            value = getattr(self, key)
            if value:
                lines.append(f"{key} = {json.dumps(value)}")
        for term in self.terms:
            lines.append("")
            lines.append(f"[{term.name}]")
            for key, value in term.to_table().items():
                lines.append(f"{key} = {float(value)!r}")
        return "\n".join(lines).lstrip("\n") + "\n"
