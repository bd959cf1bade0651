"""Product profiles: what a gyro model is, how it is tested, and the limits of each grade.

A profile is a TOML file, ``profiles/<name>.toml`` (the keys are documented in
``profiles/README.md``)::

    name = "SRS2000"
    version = "1"
    model = "SRS2000"

    [transport]
    url = "sim+serial://SRS2000?protocol=xbus&rate=10"

    [test]
    sample_rate_hz = 10.0
    duration_s = 14400.0
    warmup_s = 300.0
    axes = ["x"]

    [grading]
    rule = "guard-banded"          # strict | guard-banded | simple
    confidence = 0.95
    grades = ["navigation", "tactical"]

    [figures.arw]
    unit = "deg/sqrt(h)"
    limits = { navigation = 1.0e-4, tactical = 3.0e-4 }

:func:`load_profile` reads and validates one (a limit below what the transport's rate word
resolves is refused: :mod:`station.model.quantization`); every error is a
:class:`~station.errors.ProfileError` naming the file, the line and the key at fault.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, get_args

from analysis.fit.methods import FIT_METHODS, FitMethod
from analysis.gmwm.models import GmwmModel, GmwmModelError
from analysis.units.conversions import DEG_PER_URAD, S_PER_H
from devices.model_files import shipped_profiles_dir
from devices.url_text import url_keys, with_keys
from station.errors import ProfileError
from station.model.figure_names import (
    BIAS_STABILITY_RE,
    bias_stability_average_s as bias_stability_average_s,
)
from station.model.quantization import check_limits_resolved
from station.model.sequences import SequenceSpec, parse_sequences
from station.model.toml_lines import key_lines

DecisionRule = Literal["strict", "guard-banded", "simple"]
DECISION_RULES: tuple[DecisionRule, ...] = get_args(DecisionRule)
DEFAULT_CONFIDENCE = 0.95
DEFAULT_FIT_METHOD: FitMethod = "logwls"
FigureSource = Literal["read-off", "fit"]
FIGURE_SOURCES: tuple[FigureSource, ...] = get_args(FigureSource)
#: Where ``arw`` and ``bias_instability`` come from unless a profile says otherwise: the
#: IEEE 952 read-offs data sheets quote (the fit is graded with ``arw_fit`` etc.).
DEFAULT_FIGURE_SOURCE: FigureSource = "read-off"
#: Figures measured both ways; the profile's ``figure_source`` picks which one they grade.
DUAL_FIGURES = ("arw", "bias_instability", "accel_vrw", "accel_bias_instability")
#: Where profile names are looked up: ``<repo>/profiles``, or the installed copy of it.
PROFILE_DIR = shipped_profiles_dir()

_RAD_IN_DEG = 180.0 / math.pi
#: Units accepted per dimension: size of one such unit in the dimension's canonical unit
#: (the first entry of each table).
UNITS: dict[str, dict[str, float]] = {
    "rate": {"deg/h": 1.0, "deg/s": S_PER_H, "mdeg/s": S_PER_H / 1000.0,
             "rad/s": S_PER_H * _RAD_IN_DEG},
    "arw": {"deg/sqrt(h)": 1.0, "deg/h/sqrt(Hz)": 1.0 / 60.0, "deg/s/sqrt(Hz)": 60.0,
            "rad/sqrt(s)": 60.0 * _RAD_IN_DEG},
    "angle": {"urad": 1.0, "arcsec": math.pi / 180.0 / 3600.0 * 1e6, "deg": 1.0 / DEG_PER_URAD},
    "rrw": {"deg/h^1.5": 1.0, "deg/h/sqrt(h)": 1.0},
    "ramp": {"deg/h^2": 1.0, "deg/s^2": S_PER_H**2},
    # accelerometers (SI; mg and ug of standard gravity, 9.80665 m/s^2)
    "accel": {"ug": 1.0, "mg": 1e3, "m/s^2": 1e6 / 9.80665},
    "vrw": {"m/s/sqrt(h)": 1.0, "m/s^2/sqrt(Hz)": 60.0, "ug/sqrt(Hz)": 60.0 * 9.80665e-6},
    "accel_rw": {"m/s/h^1.5": 1.0, "m/s^3/sqrt(Hz)": S_PER_H**1.5},
}


@dataclass(frozen=True)
class FigureKind:
    """One figure a profile may name: its dimension and what it is."""

    dimension: str
    label: str

    @property
    def canonical_unit(self) -> str:
        """The unit grading computes the figure in."""
        return next(iter(UNITS[self.dimension]))


#: The figures grading can compute (see :mod:`station.evaluation.grading` for how and their
#: intervals).
FIGURE_KINDS: dict[str, FigureKind] = {
    "bias": FigureKind("rate", "|bias|"),
    "arw": FigureKind("arw", "ARW"),
    "bias_instability": FigureKind("rate", "bias instability"),
    "adev_min": FigureKind("rate", "Allan deviation minimum"),
    "quantization": FigureKind("angle", "Q quantization (fit)"),
    "arw_fit": FigureKind("arw", "N ARW (fit)"),
    "bias_instability_fit": FigureKind("rate", "B bias instability (fit)"),
    "rrw": FigureKind("rrw", "K rate random walk (fit)"),
    "rate_ramp": FigureKind("ramp", "R rate ramp (fit)"),
    # accelerometer axes (IEEE Std 1293-2018 annex C): station.evaluation.accel_grading
    "accel_bias": FigureKind("accel", "|accel bias| (gravity removed)"),
    "accel_vrw": FigureKind("vrw", "velocity random walk"),
    "accel_bias_instability": FigureKind("accel", "accel bias instability"),
    "accel_adev_min": FigureKind("accel", "accel Allan deviation minimum"),
    "accel_vrw_fit": FigureKind("vrw", "N velocity random walk (fit)"),
    "accel_bias_instability_fit": FigureKind("accel", "B accel bias instability (fit)"),
    "accel_random_walk": FigureKind("accel_rw", "K acceleration random walk (fit)"),
}


def is_accel_figure(name: str) -> bool:
    """Whether figure ``name`` is an accelerometer's (graded on accelerometer axes)."""
    return name.startswith("accel_")


def figure_kind(name: str) -> FigureKind | None:
    """The kind of figure ``name`` (a key of :data:`FIGURE_KINDS` or ``bias_stability_<T>s``)."""
    if name in FIGURE_KINDS:
        return FIGURE_KINDS[name]
    m = BIAS_STABILITY_RE.match(name)
    if m:
        return FigureKind("rate", f"bias stability {m.group(1)} s")
    return None


@dataclass(frozen=True)
class FigureSpec:
    """A figure a profile asks for, with its upper limit per grade in ``unit``.

    ``limits`` maps grade name -> upper limit; a grade without an entry places no
    requirement on this figure; a figure with no limits at all is informational.
    """

    name: str
    unit: str
    limits: dict[str, float]
    line: int | None = None
    source: str = ""

    @property
    def kind(self) -> FigureKind:
        """The figure's kind (dimension, label)."""
        kind = figure_kind(self.name)
        assert kind is not None  # checked on load
        return kind

    @property
    def label(self) -> str:
        """Human-readable name of the figure (with ``(read-off)`` or ``(fit)`` where it could be
        either)."""
        return f"{self.kind.label} ({self.source})" if self.source else self.kind.label

    @property
    def unit_factor(self) -> float:
        """Size of one ``unit`` in the figure's canonical unit."""
        return UNITS[self.kind.dimension][self.unit]

    @property
    def graded(self) -> bool:
        """Whether any grade limits this figure."""
        return bool(self.limits)


@dataclass(frozen=True)
class Profile:
    """A validated product profile (times in s, rates in Hz, limits in each figure's unit).

    Attributes
    ----------
    name, version, model : str
        Profile name (its file stem by convention), its version, the gyro model it tests.
    sample_rate_hz : float or None
        Output rate to configure, Hz; None to take the device's (or record's) rate.
    range_deg_s : float or None
        Measurement range, deg/s: the recorder takes a sample whose rate is larger on any
        axis for a bad one (a corrupted frame its checksum let through); None: no check.
    accel_range_g : float or None
        ``[test] accel_range_g``: accelerometer range of an IMU, g; a larger acceleration
        on any axis is a bad sample. None: the protocol's own range.
    axes : tuple of str
        Axes to record and grade.
    duration_s, warmup_s : float
        Test length and the warm-up discarded from its start before analysis, s.
    transport : dict
        How to reach the device (``url`` and transport options).
    settings : dict
        Device settings (filter, range, ...), passed on to the recorder as they are.
    grades : tuple of str
        Grade names, best first; an axis that makes none gets ``reject``.
    rule : str
        Decision rule: ``strict``, ``guard-banded`` or ``simple`` (see
        :mod:`station.evaluation.grading`).
    confidence : float
        Two-sided confidence level of every figure's interval (0 < c < 1).
    fit_method : str
        Noise-term fit method (:data:`analysis.fit.FIT_METHODS`).
    gmwm_model : str or None
        ``[test] gmwm_model``: the GMWM model (``"wn+gm+rw"``) or ``"auto"`` every spec
        sheet of the profile shows beside the Allan read-offs; None: none.
    figure_source : str
        ``"read-off"`` or ``"fit"``: what ``arw`` and ``bias_instability`` grade.
    figures : tuple of FigureSpec
        The figures to compute, in report order.
    path : str
        The file the profile was read from.
    sha256 : str
        Hash of the file's bytes: which exact profile graded a unit.
    """

    name: str
    version: str
    model: str
    sample_rate_hz: float | None
    axes: tuple[str, ...]
    duration_s: float
    warmup_s: float
    transport: dict[str, Any]
    grades: tuple[str, ...]
    rule: DecisionRule
    confidence: float
    figures: tuple[FigureSpec, ...]
    settings: dict[str, Any] = field(default_factory=dict)
    fit_method: FitMethod = DEFAULT_FIT_METHOD
    gmwm_model: str | None = None
    figure_source: FigureSource = DEFAULT_FIGURE_SOURCE
    reject: str = "reject"
    description: str = ""
    source: str = ""
    path: str = ""
    sha256: str = ""
    range_deg_s: float | None = None
    accel_range_g: float | None = None
    #: Test sequences (``[sequence.NAME]`` tables, :mod:`station.model.sequences`).
    sequences: dict[str, SequenceSpec] = field(default_factory=dict)

    def sequence(self, name: str) -> SequenceSpec:
        """The sequence named ``name``.

        Raises
        ------
        ProfileError
            The profile defines no such sequence (the message lists those it has).
        """
        if name not in self.sequences:
            have = ", ".join(self.sequences) or "none"
            raise ProfileError(f"profile {self.name} has no sequence {name!r} (its sequences: "
                               f"{have}); add a [sequence.{name}] table", path=self.path)
        return self.sequences[name]

    def figure(self, name: str) -> FigureSpec:
        """The figure spec named ``name``."""
        for f in self.figures:
            if f.name == name:
                return f
        raise KeyError(f"profile {self.name} has no figure {name!r}")

    @property
    def ref(self) -> str:
        """``name@version``: how reports and the database name this profile."""
        return f"{self.name}@{self.version}"


class _Checker:
    """Validation helpers that raise ProfileError with the file, line and key."""

    def __init__(self, path: str, text: str) -> None:
        self.path = path
        self.lines = key_lines(text)

    def line_of(self, key: tuple[str, ...]) -> int | None:
        for n in range(len(key), 0, -1):
            if key[:n] in self.lines:
                return self.lines[key[:n]]
        return None

    def fail(self, key: tuple[str, ...], message: str) -> ProfileError:
        return ProfileError(message, path=self.path, line=self.line_of(key), key=".".join(key))

    def table(self, data: dict[str, Any], key: tuple[str, ...], allowed: set[str],
              *, required: bool = False) -> dict[str, Any]:
        value = _get(data, key)
        if value is None:
            if required:
                raise self.fail(key, "missing table")
            return {}
        if not isinstance(value, dict):
            raise self.fail(key, f"must be a table, got {type(value).__name__}")
        if allowed:
            for k in value:
                if k not in allowed:
                    raise self.fail(
                        key + (k,), f"unknown key; expected one of {', '.join(sorted(allowed))}"
                    )
        return value

    def string(self, table: dict[str, Any], key: tuple[str, ...], *, default: str | None = None,
               allow_int: bool = False) -> str:
        value = table.get(key[-1], default)
        if value is None:
            raise self.fail(key, "missing (a string)")
        if allow_int and isinstance(value, int) and not isinstance(value, bool):
            value = str(value)
        if not isinstance(value, str) or not value.strip():
            raise self.fail(key, f"must be a non-empty string, got {value!r}")
        return value

    def number(
        self,
        table: dict[str, Any],
        key: tuple[str, ...],
        *,
        default: float | None = None,
        positive: bool = False,
        nonnegative: bool = False,
        optional: bool = False,
    ) -> float | None:
        value = table.get(key[-1], default)
        if value is None:
            if optional:
                return None
            raise self.fail(key, "missing (a number)")
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise self.fail(key, f"must be a finite number, got {value!r}")
        if positive and value <= 0:
            raise self.fail(key, f"must be > 0, got {value!r}")
        if nonnegative and value < 0:
            raise self.fail(key, f"must be >= 0, got {value!r}")
        return float(value)

    def strings(self, table: dict[str, Any], key: tuple[str, ...], default: list[str] | None = None
                ) -> tuple[str, ...]:
        value = table.get(key[-1], default)
        if (
            not isinstance(value, list)
            or not value
            or not all(isinstance(v, str) and v for v in value)
        ):
            raise self.fail(key, f"must be a non-empty array of strings, got {value!r}")
        if len(set(value)) != len(value):
            raise self.fail(key, f"has duplicates: {value!r}")
        return tuple(value)


def _get(data: dict[str, Any], key: tuple[str, ...]) -> Any:
    for k in key:
        if not isinstance(data, dict) or k not in data:
            return None
        data = data[k]
    return data


_TOP_KEYS = {"name", "version", "model", "description", "source", "transport", "settings", "test",
             "grading", "figures", "sequence"}
_TEST_KEYS = {"sample_rate_hz", "duration_s", "warmup_s", "axes", "fit_method", "range_deg_s",
              "gmwm_model", "accel_range_g"}
_GRADING_KEYS = {"rule", "confidence", "grades", "reject", "figure_source"}
_FIGURE_KEYS = {"unit", "limits"}


def parse_profile(text: str, *, path: str = "<string>") -> Profile:
    """Validate the TOML text of a profile; ``path`` names it in error messages.

    Raises
    ------
    ProfileError
        On a TOML syntax error, a missing or unknown key, or a value of the wrong type or
        range; the message names the file, line and key.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"line (\d+)", str(exc))
        raise ProfileError(
            f"not valid TOML: {exc}", path=path, line=int(m.group(1)) if m else None
        ) from exc
    c = _Checker(path, text)
    for k in data:
        if k not in _TOP_KEYS:
            raise c.fail((k,), f"unknown key; expected one of {', '.join(sorted(_TOP_KEYS))}")
    name = c.string(data, ("name",))
    test = c.table(data, ("test",), _TEST_KEYS, required=True)
    grading = c.table(data, ("grading",), _GRADING_KEYS, required=True)
    transport = c.table(data, ("transport",), set())
    if transport and not isinstance(transport.get("url"), str):
        raise c.fail(("transport", "url"), "a [transport] table needs url = \"scheme://...\"")
    settings = c.table(data, ("settings",), set())
    fit_method = c.string(test, ("test", "fit_method"), default=DEFAULT_FIT_METHOD)
    if fit_method not in FIT_METHODS:
        raise c.fail(
            ("test", "fit_method"), f"{fit_method!r} is not one of {', '.join(FIT_METHODS)}"
        )
    gmwm_model = (c.string(test, ("test", "gmwm_model")) if "gmwm_model" in test else None)
    if gmwm_model is not None and gmwm_model.strip().lower() != "auto":
        try:
            gmwm_model = GmwmModel.parse(gmwm_model).name
        except GmwmModelError as exc:
            raise c.fail(("test", "gmwm_model"), f"{exc}; or \"auto\"") from exc
    rule = c.string(grading, ("grading", "rule"), default="guard-banded")
    if rule not in DECISION_RULES:
        raise c.fail(("grading", "rule"), f"{rule!r} is not one of {', '.join(DECISION_RULES)}")
    confidence = c.number(grading, ("grading", "confidence"), default=DEFAULT_CONFIDENCE)
    assert confidence is not None
    if not 0.5 <= confidence < 1:
        raise c.fail(("grading", "confidence"), f"must be in [0.5, 1), got {confidence}")
    source = c.string(grading, ("grading", "figure_source"), default=DEFAULT_FIGURE_SOURCE)
    if source not in FIGURE_SOURCES:
        raise c.fail(
            ("grading", "figure_source"), f"{source!r} is not one of {', '.join(FIGURE_SOURCES)}"
        )
    grades = c.strings(grading, ("grading", "grades"))
    reject = c.string(grading, ("grading", "reject"), default="reject")
    if reject in grades or reject == "indeterminate":
        raise c.fail(
            ("grading", "reject"), f"{reject!r} clashes with a grade name or 'indeterminate'"
        )
    duration = c.number(test, ("test", "duration_s"), positive=True)
    warmup = c.number(test, ("test", "warmup_s"), default=0.0, nonnegative=True)
    assert duration is not None and warmup is not None
    if warmup >= duration:
        raise c.fail(
            ("test", "warmup_s"), f"warm-up {warmup} s is not shorter than the test ({duration} s)"
        )
    figures = _parse_figures(c, data, grades, source)
    sample_rate = c.number(test, ("test", "sample_rate_hz"), positive=True, optional=True)
    check_limits_resolved(figures, transport.get("url"), sample_rate, duration - warmup,
                          confidence, c.fail)
    return Profile(
        name=name,
        version=c.string(data, ("version",), allow_int=True),
        model=c.string(data, ("model",)),
        sample_rate_hz=sample_rate,
        range_deg_s=c.number(test, ("test", "range_deg_s"), positive=True, optional=True),
        accel_range_g=c.number(test, ("test", "accel_range_g"), positive=True, optional=True),
        axes=c.strings(test, ("test", "axes")),
        duration_s=duration,
        warmup_s=warmup,
        transport=dict(transport),
        settings=dict(settings),
        grades=grades,
        rule=rule,
        confidence=confidence,
        figures=figures,
        sequences=parse_sequences(c, data, grades),
        fit_method=fit_method,
        gmwm_model=gmwm_model,
        figure_source=source,
        reject=reject,
        description=str(data.get("description", "")),
        source=str(data.get("source", "")),
        path=path,
        sha256=hashlib.sha256(text.encode()).hexdigest(),
    )


def _parse_figures(c: _Checker, data: dict[str, Any], grades: tuple[str, ...], source: str
                   ) -> tuple[FigureSpec, ...]:
    figures = c.table(data, ("figures",), set(), required=True)
    if not figures:
        raise c.fail(("figures",), "names no figure")
    out = []
    for name in figures:
        key = ("figures", name)
        kind = figure_kind(name)
        if kind is None:
            known = ", ".join([*FIGURE_KINDS, "bias_stability_<T>s"])
            raise c.fail(key, f"unknown figure; expected one of {known}")
        spec = c.table(data, key, _FIGURE_KEYS, required=True)
        unit = c.string(spec, key + ("unit",))
        if unit not in UNITS[kind.dimension]:
            raise c.fail(key + ("unit",), f"{unit!r} is not a unit of {kind.label}; use one of "
                         f"{', '.join(UNITS[kind.dimension])}")
        limits_table = c.table(data, key + ("limits",), set(grades))
        limits = {}
        for grade in grades:  # grade order, not file order
            if grade in limits_table:
                value = c.number(limits_table, key + ("limits", grade), positive=True)
                assert value is not None
                limits[grade] = value
        out.append(
            FigureSpec(name, unit, limits, c.line_of(key), source if name in DUAL_FIGURES else "")
        )
    if not any(f.graded for f in out):
        raise c.fail(("figures",), "no figure has limits: nothing to grade")
    return tuple(out)


def resolve_profile_path(ref: str | Path, *, search_dir: Path | None = None) -> Path:
    """The file a profile reference names: an existing path, or ``<search_dir>/<ref>.toml``.

    Raises
    ------
    ProfileError
        When neither exists; the message lists the profiles available.
    """
    path = Path(ref)
    if path.is_file():
        return path
    directory = search_dir or PROFILE_DIR
    name = str(ref).removesuffix(".toml")
    candidate = directory / f"{name}.toml"
    if "/" not in name and candidate.is_file():
        return candidate
    known = ", ".join(available_profiles(directory)) or "none"
    raise ProfileError(f"no profile file {ref!r} and no profile of that name in {directory} "
                       f"(available: {known})")


def available_profiles(directory: Path | None = None) -> list[str]:
    """Names of the profiles in ``directory`` (default ``<repo>/profiles``)."""
    directory = directory or PROFILE_DIR
    return sorted(p.stem for p in directory.glob("*.toml"))


def load_profile(ref: str | Path, *, search_dir: Path | None = None) -> Profile:
    """Read and validate a product profile: a path, or a name in ``<repo>/profiles/``.

    Parameters
    ----------
    ref : str or Path
        A TOML file, or a profile name such as ``"SRS2000"`` (``profiles/SRS2000.toml``).
    search_dir : Path, optional
        Where names are looked up instead of ``<repo>/profiles``.

    Raises
    ------
    ProfileError
        When the profile cannot be found or fails validation (file, line and key named).
    """
    path = resolve_profile_path(ref, search_dir=search_dir)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ProfileError(f"cannot read: {exc}", path=str(path)) from exc
    profile = parse_profile(text, path=str(path))
    url = profile.transport.get("url")
    if not isinstance(url, str):
        return profile
    return dataclasses.replace(
        profile, transport={**profile.transport, "url": anchored_model(url, path.parent)}
    )


def anchored_model(url: str, profile_dir: Path | None = None) -> str:
    """``url`` with a relative ``model=`` file (and a raw CAN ``layout=`` file) made
    absolute, so that a profile's URL works from any folder: the file relative to the
    profile's folder ``profile_dir``, else to the folder above it (a profile in
    ``profiles/`` naming ``profiles/models/X.toml``), else to the shipped profiles' folder
    (``models/X.toml``, ``layouts/X.toml``). A file found nowhere is left as it is (the
    device URL then says so)."""
    keys = url_keys(url)
    bases = [] if profile_dir is None else [profile_dir, profile_dir.parent]
    for key in ("model", "layout"):
        name = keys.get(key, "")
        if not name.endswith(".toml") or Path(name).is_absolute():
            continue
        for base in (*bases, PROFILE_DIR, PROFILE_DIR.parent):
            anchored = (base / name).resolve()
            if anchored.is_file():
                url = with_keys(url, {key: str(anchored)})
                break
    return url
