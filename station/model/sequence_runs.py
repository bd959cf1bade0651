"""A recorded test sequence as evaluation and reports see it: its journal and its segments.

A sequence (:mod:`station.model.sequences`) runs its steps for every unit on the fixture;
each ``record`` step is a run file of its own (a *segment*), and the sequence file keeps
the journal of everything else: when each step started and ended, when each unit's
supply came on and went off, the chamber's set points and readings, interruptions and
resumptions. :func:`station.storage.sequence_files.read_sequence` reads it into a
:class:`SequenceRun`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from station.model.sequences import Step

JournalKind = Literal["start", "resume", "interrupted", "step_start", "step_done", "progress",
                      "power_on", "power_off", "setpoint", "chamber", "stable", "segment",
                      "error", "done"]
JOURNAL_KINDS: tuple[str, ...] = ("start", "resume", "interrupted", "step_start", "step_done",
                                  "progress", "power_on", "power_off", "setpoint", "chamber",
                                  "stable", "segment", "error", "done")


@dataclass(frozen=True)
class JournalEntry:
    """One line of a sequence's journal.

    Attributes
    ----------
    kind : str
        One of :data:`JOURNAL_KINDS`.
    utc : str
        When, UTC ISO 8601.
    wall_s : float
        When, s since the epoch (the station's clock; turn-on times are measured on it).
    clock_s : float
        When, s on the sequence's clock (the fixture's simulated time for a simulated
        fixture, else ``wall_s``): what durations are counted on.
    step : int
        Index of the step it belongs to (-1: none).
    cycle : int
        Repeat cycle of that step (0: none).
    unit : str
        The unit it concerns ("" for all).
    value : float
        A number: a temperature (degC) for ``setpoint``/``chamber``, the time the step
        has run (s, sequence clock) for ``progress``, ``step_done`` and ``interrupted``;
        NaN otherwise.
    detail : str
        Free text.
    """

    kind: JournalKind
    utc: str
    wall_s: float
    clock_s: float
    step: int = -1
    cycle: int = 0
    unit: str = ""
    value: float = float("nan")
    detail: str = ""


@dataclass(frozen=True)
class Segment:
    """A ``record`` step's run file.

    Attributes
    ----------
    step, cycle : int
        The step (index) and repeat cycle it recorded.
    file : str
        Its path, relative to the sequence file's folder.
    interrupted : bool
        It ended early (the station stopped, crashed or the unit failed); the step was
        then recorded again from where it was.
    superseded : bool
        The step was redone in full after it (a turn-on whose supplies a resume found off,
        switched on again; a temperature plateau resumed from its settle): kept in the
        file, left out of every figure.
    """

    step: int
    cycle: int
    file: str
    interrupted: bool = False
    superseded: bool = False


@dataclass(frozen=True)
class SequenceRun:
    """A sequence file: what ran, on which units, and what happened.

    Attributes
    ----------
    path : str
        The sequence file.
    name : str
        The sequence's name in its profile.
    profile, profile_version, profile_sha256, profile_path : str
        The profile.
    steps : tuple of Step
        The expanded steps.
    unit_ids, unit_urls : tuple of str
        Units in order (``unit1``...) and their device URLs.
    power_urls : tuple of str
        The supply switch of each unit ("" for none).
    chamber_url : str
        The chamber ("" for none).
    time_warp : float
        Sequence clock seconds per wall second (a simulated fixture's warp; 1 otherwise).
    journal : tuple of JournalEntry
        Everything that happened, in order.
    segments : tuple of Segment
        Every recorded segment, in order.
    state : str
        ``running`` (or killed while running), ``done`` or ``failed``.
    operator, lot, start_utc : str
        Run metadata.
    """

    path: str
    name: str
    profile: str
    profile_version: str
    profile_sha256: str
    profile_path: str
    steps: tuple[Step, ...]
    unit_ids: tuple[str, ...]
    unit_urls: tuple[str, ...]
    power_urls: tuple[str, ...]
    chamber_url: str
    time_warp: float
    journal: tuple[JournalEntry, ...]
    segments: tuple[Segment, ...]
    state: str
    operator: str = ""
    lot: str = ""
    start_utc: str = ""

    @property
    def done(self) -> bool:
        """Whether every step ran."""
        return self.state == "done"

    def next_step(self) -> int:
        """Index of the step to run next: the first not done (``len(steps)`` when all are)."""
        finished = {e.step for e in self.journal if e.kind == "step_done"}
        return next((s.index for s in self.steps if s.index not in finished), len(self.steps))

    def elapsed_s(self, step: int) -> float:
        """How long step ``step`` has run (s, sequence clock), from its journal entries."""
        done = [e.value for e in self.journal if e.step == step
                and e.kind in ("progress", "step_done", "interrupted") and e.value == e.value]
        return max(done, default=0.0)

    def switch_ons(self, unit_id: str) -> tuple[JournalEntry, ...]:
        """Every switch-on of the unit's supply, in order: those the profile asked for and
        those a resume made (:meth:`asked_for` tells them apart)."""
        return tuple(e for e in self.journal if e.kind == "power_on" and e.unit == unit_id)

    def asked_for(self, entry: JournalEntry) -> bool:
        """Whether a switch-on is one the profile asked for: journaled against a
        ``power_on`` step. A supply that a resume found off and switched on again is
        journaled against no step (-1): it counts as no turn-on."""
        return 0 <= entry.step < len(self.steps) and self.steps[entry.step].kind == "power_on"

    def interruptions(self) -> tuple[JournalEntry, ...]:
        """The journal's ``interrupted`` entries."""
        return tuple(e for e in self.journal if e.kind == "interrupted")
