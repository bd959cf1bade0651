"""Where a test sequence stands, step by step, read from its journal; and its figures.

What the TUI's sequence screen shows (and what any other view may show): for each step
its state, how far it has run, the chamber's set point in force and the air temperature
last journaled (:func:`sequence_progress`); the unfinished sequences of a folder a user
can resume (:func:`unfinished_sequences`, :func:`resume_request`), resumed exactly as
``station record --sequence`` resumes them, by running the same request again; and, once
it has ended, each unit's graded sequence figures (:func:`sequence_figures`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal
from urllib.parse import parse_qsl, urlsplit

from station.model.sequence_runs import JournalEntry, SequenceRun
from station.model.sequences import Step
from station.output.report.common import FigureRow
from station.services.sequence import SIM, SequenceRequest, readable_sequences

StepState = Literal["pending", "running", "done", "interrupted", "failed"]


@dataclass(frozen=True)
class StepProgress:
    """One step of a sequence as it stands.

    Attributes
    ----------
    index : int
        Position in the expanded sequence (0-based).
    text : str
        The step as the profile wrote it (``record 30min``).
    cycle : int
        Its repeat cycle (1-based).
    state : str
        ``pending``, ``running``, ``done``, ``interrupted`` (the sequence stopped in it:
        resume to go on) or ``failed``.
    done_s : float
        How long it has run, s on the sequence's clock.
    duration_s : float or None
        How long it runs (``wait``, ``cool_down``, ``record``), s; None for the others.
    setpoint_c : float or None
        The chamber's set point in force during the step, degC (None: no chamber set yet).
    chamber_c : float or None
        The chamber's air temperature last journaled during the step, degC.
    """

    index: int
    text: str
    cycle: int
    state: StepState
    done_s: float
    duration_s: float | None
    setpoint_c: float | None
    chamber_c: float | None

    @property
    def fraction(self) -> float | None:
        """Share of the step done, 0 to 1 (None for a step without a duration that has not
        ended)."""
        if self.state == "done":
            return 1.0
        if not self.duration_s:
            return None
        return min(1.0, max(0.0, self.done_s / self.duration_s))

    @property
    def plateau(self) -> bool:
        """Whether this is a ``record`` at a chamber set point (a temperature plateau)."""
        return self.text.startswith("record") and self.setpoint_c is not None


@dataclass(frozen=True)
class SequenceProgress:
    """A sequence as it stands.

    Attributes
    ----------
    path, name, profile : str
        The sequence file, the sequence's name and its profile's.
    state : str
        ``running``, ``done``, ``failed`` or ``interrupted`` (stopped or killed before its
        end: the same request resumes it).
    steps : tuple of StepProgress
        Every step, in order.
    message : str
        Why it stopped or failed (the journal's last ``interrupted`` or ``error`` line),
        "" otherwise.
    """

    path: str
    name: str
    profile: str
    state: str
    steps: tuple[StepProgress, ...]
    message: str = ""

    @property
    def current(self) -> StepProgress | None:
        """The step running, interrupted or failed (None when none is)."""
        return next((s for s in self.steps if s.state in ("running", "interrupted", "failed")),
                    None)

    @property
    def steps_done(self) -> int:
        """How many steps are done."""
        return sum(1 for s in self.steps if s.state == "done")


def _setpoints(steps: tuple[Step, ...]) -> list[float | None]:
    """The set point each step runs at, from the ``set_chamber`` steps before it."""
    out: list[float | None] = []
    current: float | None = None
    for step in steps:
        if step.kind == "set_chamber":
            current = step.temperature_c
        out.append(current)
    return out


def _running_s(run: SequenceRun, index: int, now_s: float) -> float:
    """How long step ``index``, running now, has run at ``now_s`` (s since the epoch), on
    the sequence's clock: from its latest journal mark (start, progress or the resume)."""
    marks = [e for e in run.journal
             if (e.step == index and e.kind in ("step_start", "progress")) or e.kind == "resume"]
    if not marks:
        return run.elapsed_s(index)
    last: JournalEntry = marks[-1]
    base = last.value if last.kind == "progress" else (
        0.0 if last.kind == "step_start" else run.elapsed_s(index))
    return max(base, 0.0) + max(0.0, now_s - last.wall_s) * run.time_warp


def sequence_progress(run: SequenceRun, *, now_s: float | None = None) -> SequenceProgress:
    """Each step's state, time run and temperatures, from the sequence's journal.

    Parameters
    ----------
    run : SequenceRun
        The sequence as its runner holds it, or as read from its file.
    now_s : float, optional
        Now (s since the epoch, ``time.time()``) when a process is known to run the
        sequence (:class:`~station.services.sequence_process.SequenceProcess`): the next
        step is then ``running`` and its time counts to now on the sequence's clock
        (warped for a simulated fixture). Without it, a sequence that did not end is
        ``interrupted`` at its next step.

    Returns
    -------
    SequenceProgress
    """
    done = {e.step for e in run.journal if e.kind == "step_done"}
    nxt = run.next_step()
    live = now_s is not None and run.state == "running"
    state = run.state if run.state in ("done", "failed") else (
        "running" if live else "interrupted")
    setpoints = _setpoints(run.steps)
    readings: dict[int, float] = {}
    for e in run.journal:
        if e.kind == "chamber" and e.step >= 0 and not math.isnan(e.value):
            readings[e.step] = e.value
    rows = []
    for step in run.steps:
        step_state: StepState
        if step.index in done:
            step_state, done_s = "done", step.duration_s or run.elapsed_s(step.index)
        elif step.index == nxt and state != "done":
            step_state = "running" if state == "running" else (
                "failed" if state == "failed" else "interrupted")
            done_s = (_running_s(run, step.index, now_s) if live and now_s is not None
                      else run.elapsed_s(step.index))
        else:
            step_state, done_s = "pending", 0.0
        if step.duration_s is not None:
            done_s = min(done_s, step.duration_s)
        rows.append(StepProgress(step.index, step.text, step.cycle, step_state, done_s,
                                 step.duration_s, setpoints[step.index],
                                 readings.get(step.index)))
    message = ""
    if state in ("interrupted", "failed"):
        why = [e.detail for e in run.journal if e.kind in ("interrupted", "error")]
        message = why[-1] if why else (
            "the station stopped without closing the sequence (killed, or a crash): start "
            "it again to resume")
    return SequenceProgress(run.path, run.name, run.profile, state, tuple(rows), message)


def unfinished_sequences(folder: Path) -> list[SequenceRun]:
    """The sequences in ``folder`` that neither finished nor failed, newest first: those
    the same request resumes (:func:`~station.services.sequence.find_unfinished`)."""
    found = [run for run in readable_sequences(folder) if run.state == "running"]
    return sorted(found, key=lambda r: r.start_utc, reverse=True)


def _fixture_wired(url: str) -> bool:
    """Whether a simulated unit's URL names the fixture it is wired to (``fixture=``)."""
    return "fixture" in dict(parse_qsl(urlsplit(url).query))


def resume_request(run: SequenceRun, out: Path) -> SequenceRequest:
    """The request that resumes ``run``: the one that started it, as far as its file says.

    A sequence on a simulated fixture (its units are ``sim+`` URLs wired to no fixture of
    their own, or its chamber is ``sim``) is resumed on a simulated fixture again; real
    supply switches and chamber by the URLs it journaled.

    Parameters
    ----------
    run : SequenceRun
        An unfinished sequence (:func:`unfinished_sequences`).
    out : Path
        The folder it is in.

    Returns
    -------
    SequenceRequest
    """
    simulated = run.chamber_url == SIM or (
        bool(run.unit_urls) and all(u.lower().startswith("sim+") and not _fixture_wired(u)
                                    for u in run.unit_urls)
        and any(run.power_urls))
    if simulated:
        power: tuple[str, ...] = (SIM,) if any(run.power_urls) else ()
        chamber = SIM if run.chamber_url else None
    else:
        power = tuple(u for u in run.power_urls if u)
        chamber = run.chamber_url or None
    profile = run.profile_path if run.profile_path and Path(run.profile_path).is_file() \
        else run.profile
    return SequenceRequest(run.name, profile, run.unit_urls, power, chamber, out,
                           run.operator, run.lot)


def sequence_figures(path: Path) -> tuple[tuple[str, FigureRow], ...]:
    """Grade a sequence file (not stored) and return each unit's sequence figures, as
    ``(unit_id, row)``: each row a figure in the profile's unit with its interval, the
    limit of the grade that decided and its verdict (None: no grade decided), and the
    grade the unit's sequence figures give (``grade``, "" when none is limited).

    Raises
    ------
    StationError
        The file cannot be graded (see :func:`station.services.grade.grade`).
    """
    from station.services.grade import GradeRequest, RunSource, grade

    graded = grade(GradeRequest(RunSource(path), store=False)).graded
    rows = []
    for unit in graded.units:
        seq = unit.sequence
        if seq is None:
            continue
        deciding = seq.deciding_grade
        for g in seq.graded:
            rows.append((unit.unit.unit_id, FigureRow(
                "", g.spec.name, g.spec.label, g.spec.unit, g.value, g.ci_low, g.ci_high,
                g.spec.limits.get(deciding) if deciding else None, seq.grade,
                g.verdicts.get(deciding, "pass") if deciding else None, g.note)))
    return tuple(rows)
