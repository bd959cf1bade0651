"""Test sequences of a profile: the steps of a static turn-on or temperature test, and limits.

A profile may define sequences, each a ``[sequence.NAME]`` table (keys in
``profiles/README.md``)::

    [sequence.turn_on]
    description = "turn-on to turn-on repeatability, IEEE Std 952 / 1431"
    steps = ["power_on", "record 20min", "power_off", "cool_down 40min", "repeat 6"]
    bias_after_s = 600            # from power-on: the warm-up left out of each cycle's bias
    warmup_band_deg_h = 0.5       # the warm-up ends when the bias stays this close to its end
    warmup_average_s = 30

    [sequence.turn_on.figures.turn_on_repeatability]
    unit = "deg/h"
    limits = { navigation = 0.3, tactical = 1.0 }

A step is ``power_on``, ``power_off``, ``wait D``, ``cool_down D``, ``record D``,
``set_chamber T`` (degC), ``wait_stable`` (the chamber's air within ``stable_band_c``
of its set point for ``stable_hold_s``, at most ``stable_timeout_s``) or ``repeat N``:
the steps since the previous ``repeat`` (or the start) run N times in all. A ``record``
right after ``power_on`` starts listening before the power comes on, so that it sees
the turn-on; the station cycles the units' supplies and sets the chamber through the
devices named at record time (``--power``, ``--chamber``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any, Literal, Protocol

from station.errors import ProfileError, UsageError
from station.model.durations import parse_duration

StepKind = Literal["power_on", "power_off", "wait", "cool_down", "record", "set_chamber",
                   "wait_stable"]
#: Steps that take a duration.
TIMED_STEPS = ("wait", "cool_down", "record")
STEP_KINDS: tuple[str, ...] = ("power_on", "power_off", "wait", "cool_down", "record",
                               "set_chamber", "wait_stable", "repeat")
#: Most turn-ons the repeatability needs (IEEE Std 952 and 1431: N >= 5).
MIN_REPEATABILITY_CYCLES = 5

#: Units of the sequence figures per dimension: size of one unit in the canonical one
#: (the first of each table).
SEQUENCE_UNITS: dict[str, dict[str, float]] = {
    "rate": {"deg/h": 1.0, "deg/s": 3600.0, "mdeg/s": 3.6},
    "time": {"s": 1.0, "ms": 1e-3, "min": 60.0, "h": 3600.0},
    "tempco": {"deg/h/degC": 1.0, "deg/s/degC": 3600.0},
}


@dataclass(frozen=True)
class SequenceFigureKind:
    """A figure a sequence measures: its dimension, label and JSON key (canonical unit)."""

    dimension: str
    label: str
    key: str


#: The figures a sequence can grade.
SEQUENCE_FIGURES: dict[str, SequenceFigureKind] = {
    "turn_on_repeatability": SequenceFigureKind("rate", "turn-on to turn-on bias repeatability",
                                                "turn_on_repeatability_deg_h"),
    "warmup_time": SequenceFigureKind("time", "warm-up time", "warmup_time_s"),
    "turn_on_time": SequenceFigureKind("time", "turn-on time", "turn_on_time_s"),
    "temperature_coefficient": SequenceFigureKind(
        "tempco", "|bias temperature coefficient|", "temperature_coefficient_deg_h_per_c"),
    "hysteresis": SequenceFigureKind("rate", "thermal hysteresis of the bias", "hysteresis_deg_h"),
}


@dataclass(frozen=True)
class SequenceFigureSpec:
    """A sequence figure with its upper limit per grade, in ``unit``."""

    name: str
    unit: str
    limits: dict[str, float]

    @property
    def kind(self) -> SequenceFigureKind:
        """Dimension, label and JSON key."""
        return SEQUENCE_FIGURES[self.name]

    @property
    def unit_factor(self) -> float:
        """Size of one ``unit`` in the canonical unit."""
        return SEQUENCE_UNITS[self.kind.dimension][self.unit]

    @property
    def label(self) -> str:
        """Human-readable name."""
        return self.kind.label


@dataclass(frozen=True)
class Step:
    """One step of an expanded sequence.

    Attributes
    ----------
    index : int
        Position in the expanded sequence (0-based): what the run file and a resumed
        sequence call the step.
    kind : str
        ``power_on``, ``power_off``, ``wait``, ``cool_down``, ``record``,
        ``set_chamber`` or ``wait_stable``.
    text : str
        The step as the profile wrote it.
    cycle : int
        Iteration (1-based) of the ``repeat`` block the step is in.
    duration_s : float or None
        For ``wait``, ``cool_down`` and ``record``, s.
    temperature_c : float or None
        For ``set_chamber``, degC.
    """

    index: int
    kind: StepKind
    text: str
    cycle: int
    duration_s: float | None = None
    temperature_c: float | None = None

    @property
    def label(self) -> str:
        """``step 7 (cycle 2): record 20min``."""
        return f"step {self.index + 1} (cycle {self.cycle}): {self.text}"


@dataclass(frozen=True)
class SequenceSpec:
    """A validated test sequence.

    Attributes
    ----------
    name, description : str
        Its key in the profile and what it is.
    steps : tuple of Step
        The expanded steps, ``repeat`` blocks unrolled.
    bias_after_s : float
        From power-on, s: data before are the warm-up, left out of a cycle's bias.
    warmup_band_deg_h : float or None
        Half width of the band the warm-up ends in, deg/h (None: no warm-up time).
    warmup_average_s : float
        Length of the averages the bias trend is made of, s.
    stable_band_c, stable_hold_s, stable_timeout_s : float
        ``wait_stable``: within this many degC of the set point for this long (s), at most
        this long in all (s).
    turn_on_timeout_s : float
        Longest a unit may take from power-on to its first sample, s.
    ramp_bin_c : float
        Temperature bins of a record whose temperature moves, degC.
    plateau_span_c : float
        A record whose temperature moves less than this is one plateau point, degC.
    figures : tuple of SequenceFigureSpec
        Figures with limits (and informational ones, with none).
    """

    name: str
    description: str
    steps: tuple[Step, ...]
    bias_after_s: float
    warmup_band_deg_h: float | None
    warmup_average_s: float
    stable_band_c: float
    stable_hold_s: float
    stable_timeout_s: float
    turn_on_timeout_s: float
    ramp_bin_c: float
    plateau_span_c: float
    figures: tuple[SequenceFigureSpec, ...]

    @property
    def uses_chamber(self) -> bool:
        """Whether a step sets or waits for the chamber."""
        return any(s.kind in ("set_chamber", "wait_stable") for s in self.steps)

    @property
    def uses_power(self) -> bool:
        """Whether a step switches the supplies."""
        return any(s.kind in ("power_on", "power_off") for s in self.steps)

    @property
    def turn_on_records(self) -> int:
        """``record`` steps that start at a ``power_on`` (each measures one turn-on)."""
        return sum(1 for a, b in zip(self.steps, self.steps[1:], strict=False)
                   if a.kind == "power_on" and b.kind == "record")

    def figure(self, name: str) -> SequenceFigureSpec | None:
        """The figure spec named ``name``, None when the sequence has none."""
        return next((f for f in self.figures if f.name == name), None)


def plateau_record(steps: tuple[Step, ...], index: int) -> Step | None:
    """The ``record`` step of the temperature plateau that step ``index`` is in: past the
    plateau's ``wait_stable``, up to its record (None: not in a plateau)."""
    chamber = [s.kind for s in steps[:index] if s.kind in ("set_chamber", "wait_stable")]
    if not chamber or chamber[-1] != "wait_stable":
        return None
    for s in steps[index:]:
        if s.kind in ("set_chamber", "wait_stable"):
            return None
        if s.kind == "record":
            return s
    return None


class _Fails(Protocol):
    """What the profile parser's checker lends: ProfileErrors located in the file."""

    def fail(self, key: tuple[str, ...], message: str) -> ProfileError: ...

    def table(self, data: dict[str, Any], key: tuple[str, ...], allowed: set[str], *,
              required: bool = False) -> dict[str, Any]: ...

    def number(self, table: dict[str, Any], key: tuple[str, ...], *,
               default: float | None = None, positive: bool = False,
               nonnegative: bool = False, optional: bool = False) -> float | None: ...


_KEYS = {"description", "steps", "bias_after_s", "warmup_band_deg_h", "warmup_average_s",
         "stable_band_c", "stable_hold_s", "stable_timeout_s", "turn_on_timeout_s",
         "ramp_bin_c", "plateau_span_c", "figures"}
_TEMP_RE = re.compile(r"^([-+]?\d+(?:\.\d*)?)\s*(c|degc|°c)?$", re.IGNORECASE)


_Parsed = tuple[str, str, float | None, float | None]


def _parse_step(text: str, where: str) -> _Parsed:
    """(kind, text, duration s, temperature degC) of one step string; UsageError naming
    ``where`` when it is not a step."""
    kind, _, arg = text.strip().partition(" ")
    kind, arg = kind.strip().lower(), arg.strip()
    if kind not in STEP_KINDS:
        raise UsageError(f"{where}: unknown step {text!r}; a step is one of "
                         f"{', '.join(STEP_KINDS)}")
    duration = temperature = None
    if kind in TIMED_STEPS:
        if not arg:
            raise UsageError(f"{where}: {kind} needs a duration ({kind} 20min)")
        try:
            duration = parse_duration(arg)
        except UsageError as exc:
            raise UsageError(f"{where}: {exc}") from None
    elif kind == "set_chamber":
        m = _TEMP_RE.match(arg)
        if not m:
            raise UsageError(f"{where}: set_chamber needs a temperature in degC "
                             f"(set_chamber 45), got {arg!r}")
        temperature = float(m.group(1))
    elif kind == "repeat":
        if not arg.isdigit() or int(arg) < 1:
            raise UsageError(f"{where}: repeat needs a whole number of times >= 1, got {arg!r}")
        duration = float(arg)
    elif arg:
        raise UsageError(f"{where}: {kind} takes no argument, got {arg!r}")
    return kind, text.strip(), duration, temperature


def expand_steps(texts: list[str], where: str = "steps") -> tuple[Step, ...]:
    """The steps of a sequence with its ``repeat`` blocks unrolled.

    Raises
    ------
    UsageError
        An unknown step, a missing or bad duration, temperature or count, or a ``repeat``
        with no step before it.
    """
    out: list[Step] = []
    block: list[_Parsed] = []
    for n, text in enumerate(texts):
        parsed = _parse_step(text, f"{where}[{n}]")
        if parsed[0] != "repeat":
            block.append(parsed)
            continue
        if not block:
            raise UsageError(f"{where}[{n}]: repeat with no step before it (since the previous "
                             f"repeat)")
        _unroll(out, block, int(parsed[2] or 1))
        block = []
    _unroll(out, block, 1)
    return tuple(out)


def _unroll(out: list[Step], block: list[_Parsed], count: int) -> None:
    for cycle in range(1, count + 1):
        for kind, text, duration, temperature in block:
            out.append(Step(len(out), kind, text, cycle, duration, temperature))  # type: ignore[arg-type]


def parse_sequences(c: _Fails, data: dict[str, Any], grades: tuple[str, ...]
                    ) -> dict[str, SequenceSpec]:
    """Every ``[sequence.NAME]`` table of a profile, validated.

    Raises
    ------
    ProfileError
        A bad step, key, unit or limit, or limits a sequence cannot measure (file, line
        and key named).
    """
    tables = c.table(data, ("sequence",), set())
    return {name: _parse_sequence(c, data, name, grades) for name in tables}


def _parse_sequence(c: _Fails, data: dict[str, Any], name: str, grades: tuple[str, ...]
                    ) -> SequenceSpec:
    key = ("sequence", name)
    t = c.table(data, key, _KEYS, required=True)
    texts = t.get("steps")
    if not isinstance(texts, list) or not texts or not all(isinstance(s, str) for s in texts):
        raise c.fail(key + ("steps",), f"must be a non-empty array of step strings "
                                       f"(\"power_on\", \"record 20min\", ...), got {texts!r}")
    try:
        steps = expand_steps(texts)
    except UsageError as exc:
        raise c.fail(key + ("steps",), str(exc)) from None
    if not any(s.kind == "record" for s in steps):
        raise c.fail(key + ("steps",), "no record step: the sequence would measure nothing")

    def num(k: str, default: float | None, **kw: bool) -> float | None:
        return c.number(t, key + (k,), default=default, **kw)

    figures = _parse_figures(c, data, key, grades)
    spec = SequenceSpec(
        name=name, description=str(t.get("description", "")), steps=steps,
        bias_after_s=num("bias_after_s", 0.0, nonnegative=True) or 0.0,
        warmup_band_deg_h=num("warmup_band_deg_h", None, positive=True, optional=True),
        warmup_average_s=num("warmup_average_s", 30.0, positive=True) or 30.0,
        stable_band_c=num("stable_band_c", 0.5, positive=True) or 0.5,
        stable_hold_s=num("stable_hold_s", 300.0, nonnegative=True) or 0.0,
        stable_timeout_s=num("stable_timeout_s", 3 * 3600.0, positive=True) or 1.0,
        turn_on_timeout_s=num("turn_on_timeout_s", 60.0, positive=True) or 60.0,
        ramp_bin_c=num("ramp_bin_c", 1.0, positive=True) or 1.0,
        plateau_span_c=num("plateau_span_c", 0.5, positive=True) or 0.5,
        figures=figures)
    _check_measurable(c, key, spec)
    return spec


def _parse_figures(c: _Fails, data: dict[str, Any], key: tuple[str, ...],
                   grades: tuple[str, ...]) -> tuple[SequenceFigureSpec, ...]:
    out = []
    for fname in c.table(data, key + ("figures",), set()):
        fkey = key + ("figures", fname)
        if fname not in SEQUENCE_FIGURES:
            raise c.fail(fkey, f"unknown sequence figure; expected one of "
                               f"{', '.join(SEQUENCE_FIGURES)}")
        spec = c.table(data, fkey, {"unit", "limits"}, required=True)
        units = SEQUENCE_UNITS[SEQUENCE_FIGURES[fname].dimension]
        unit = spec.get("unit", next(iter(units)))
        if unit not in units:
            raise c.fail(fkey + ("unit",), f"{unit!r} is not a unit of "
                                           f"{SEQUENCE_FIGURES[fname].label}; use one of "
                                           f"{', '.join(units)}")
        table = c.table(data, fkey + ("limits",), set(grades))
        limits: dict[str, float] = {}
        for grade in grades:
            if grade in table:
                value = c.number(table, fkey + ("limits", grade), positive=True)
                assert value is not None
                limits[grade] = value
        out.append(SequenceFigureSpec(fname, unit, limits))
    return tuple(out)


def _check_measurable(c: _Fails, key: tuple[str, ...], spec: SequenceSpec) -> None:
    """Refuse limits on a figure the steps cannot measure."""
    limited = {f.name for f in spec.figures if f.limits}
    turn_ons = spec.turn_on_records
    fkey = key + ("figures",)
    if "turn_on_repeatability" in limited and turn_ons < MIN_REPEATABILITY_CYCLES:
        raise c.fail(fkey + ("turn_on_repeatability",),
                     f"the steps record {turn_ons} turn-on(s); the repeatability needs at "
                     f"least {MIN_REPEATABILITY_CYCLES} (\"power_on\", \"record D\", ..., "
                     f"\"repeat {MIN_REPEATABILITY_CYCLES}\")")
    for figure in ("warmup_time", "turn_on_time"):
        if figure in limited and turn_ons < 2:
            raise c.fail(fkey + (figure,), f"the steps record {turn_ons} turn-on(s): a "
                                           f"record right after power_on measures one; "
                                           f"the spread needs at least 2")
    if "warmup_time" in (f.name for f in spec.figures) and spec.warmup_band_deg_h is None:
        raise c.fail(key + ("warmup_band_deg_h",), "warmup_time needs the band its warm-up "
                                                   "ends in (warmup_band_deg_h = 0.5)")
    temps = {s.temperature_c for s in spec.steps if s.kind == "set_chamber"}
    for figure in ("temperature_coefficient", "hysteresis"):
        if figure in limited and len(temps) < 2:
            raise c.fail(fkey + (figure,), f"the steps set {len(temps)} chamber temperature(s); "
                                           f"{figure} needs at least 2 (set_chamber T, "
                                           f"wait_stable, record D, ...)")
    short = [s for a, s in zip(spec.steps, spec.steps[1:], strict=False)
             if a.kind == "power_on" and s.kind == "record"
             and (s.duration_s or 0.0) <= spec.bias_after_s]
    if short and {"turn_on_repeatability", "warmup_time"} & limited:
        raise c.fail(key + ("bias_after_s",), f"{short[0].label} ends before bias_after_s = "
                                              f"{spec.bias_after_s:g} s: no bias is left after "
                                              f"the warm-up; record longer")
