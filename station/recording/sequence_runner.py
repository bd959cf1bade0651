"""Running a test sequence: supplies, chamber and recordings, step by step, resumable.

:class:`SequenceRunner` runs the steps of a :class:`~station.model.sequences.SequenceSpec`
for every unit of the fixture. It drives the recorder only through its public entry
points (:class:`~station.recording.recorder.Recorder`: a run per ``record`` step, each a run file
of its own, a *segment*), switches the supplies (:class:`~devices.protocols.PowerSwitch`)
and sets the chamber (:class:`~devices.protocols.TemperatureChamber`), and keeps the
journal of all of it in the sequence file (:mod:`station.storage.sequence_files`),
rewritten atomically after every change.

A ``record`` right after ``power_on`` listens before the power comes on: the supplies are
switched once every unit is read (the recorder's ``on_listening``), so its segment holds
the turn-on. Durations count on the sequence's clock (a simulated fixture's warped time,
else the station's).

Stopped (Ctrl-C) or killed at any step, the sequence resumes when started again
(:mod:`station.recording.sequence_resume`): the
journal says which step was running; a segment left open by a killed recorder is closed
(:func:`station.storage.hdf5_recover.recover_run`) and kept, marked interrupted; the supplies and
the chamber are put back as the journal left them; the interrupted step runs for what
was left of it; the interruption and the resumption are in the journal. Three cases are
redone rather than continued, so that a resumed sequence measures what an uninterrupted
one does:

* a supply found off that the journal left on is switched on again journaled against no
  step: a switch-on the profile did not ask for, and a switch-on all the same (a unit
  powered again takes a new turn-on bias): the figures count it as one of its own
  (:mod:`station.evaluation.sequence_cycles`), the temperature fit gives it its own bias;
* a turn-on record whose supplies were found off is redone in full from a new switch-on
  (when its recorder listens); the parts recorded before are kept, marked superseded;
* a step resumed inside a temperature plateau (after its ``wait_stable``, up to its
  ``record``) first waits for the chamber to be stable at the set point again, and the
  plateau's ``record`` is redone in full (the parts before superseded): a chamber that
  drifted, or a fixture that started again at ambient, records no ramp.
"""

from __future__ import annotations

import dataclasses
import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Protocol, TypeVar

from devices.errors import DeviceError
from devices.protocols import PowerSwitch, TemperatureChamber
from station.errors import RecorderError, RecordFormatError, SequenceError, StationError
from station.model.documents import Subscriber, utc_now
from station.model.profiles import Profile
from station.model.runs import RunMetadata
from station.model.sequence_runs import JournalEntry, JournalKind, Segment, SequenceRun
from station.model.sequences import SequenceSpec, Step
from station.recording.recorder import Recorder, RunConfig
from station.recording.sequence_resume import SequenceResume
from station.storage.hdf5 import REASON_DURATION
from station.storage.runs import open_run
from station.storage.sequence_files import write_sequence

#: Journal progress of a timed step at least this often, as a share of the step.
PROGRESS_SHARE = 0.05
#: Wall seconds the sequence waits at most between checks of a stop request.
TICK_WALL_S = 0.05
#: Attempts at each exchange with a supply switch or the chamber.
DEVICE_ATTEMPTS = 3
T = TypeVar("T")
__all__ = ["SequenceClock", "SequenceConfig", "SequenceError", "SequenceRunner",
           "new_sequence_run"]


class SequenceClock(Protocol):
    """The clock durations are counted on: seconds, ``warp`` of them per wall second."""

    warp: float

    def __call__(self) -> float: ...


class _WallClock:
    warp = 1.0

    def __call__(self) -> float:
        return time.monotonic()


@dataclass(frozen=True)
class SequenceConfig:
    """What a sequence runs on.

    Attributes
    ----------
    spec : SequenceSpec
        The steps.
    profile : Profile
        The product profile (each segment is recorded with it).
    urls : tuple of str
        Device URL of each unit as the recorder opens it.
    given_urls : tuple of str
        The URLs as the operator gave them (what a resumed sequence is matched by).
    power_urls : tuple of str
        Each unit's supply switch, as given ("" for none).
    chamber_url : str
        The chamber ("" for none).
    path : Path
        The sequence file.
    operator, lot, bench_json : str
        For the run files.
    chamber_log_s : float
        Sequence seconds between the chamber readings the journal keeps.
    """

    spec: SequenceSpec
    profile: Profile
    urls: tuple[str, ...]
    given_urls: tuple[str, ...]
    power_urls: tuple[str, ...]
    chamber_url: str
    path: Path
    operator: str = ""
    lot: str = ""
    bench_json: str = ""
    chamber_log_s: float = 60.0


def new_sequence_run(config: SequenceConfig, warp: float) -> SequenceRun:
    """The sequence file's content before the first step."""
    p = config.profile
    return SequenceRun(
        path=str(config.path), name=config.spec.name, profile=p.name,
        profile_version=p.version, profile_sha256=p.sha256,
        profile_path=str(Path(p.path).resolve()) if p.path else "", steps=config.spec.steps,
        unit_ids=tuple(f"unit{i + 1}" for i in range(len(config.urls))),
        unit_urls=config.given_urls, power_urls=config.power_urls,
        chamber_url=config.chamber_url, time_warp=warp, journal=(), segments=(),
        state="running", operator=config.operator, lot=config.lot, start_utc=utc_now())


class _Stopped(Exception):
    """The operator asked the sequence to stop."""


class SequenceRunner(SequenceResume):
    """Runs (or resumes) one sequence.

    Parameters
    ----------
    config : SequenceConfig
        What to run.
    power : sequence of PowerSwitch
        Each unit's supply switch, opened (empty when the sequence switches none).
    chamber : TemperatureChamber or None
        The chamber, opened.
    clock : SequenceClock, optional
        Where durations are counted (default the station's monotonic clock).
    existing : SequenceRun or None
        A sequence file to resume.
    subscribers : callable, optional
        ``subscribers(step)``: document subscribers for the segment of a ``record`` step
        (a progress line).
    notify : callable, optional
        Receives one line per step as it starts.
    """

    def __init__(self, config: SequenceConfig, *, power: Sequence[PowerSwitch] = (),
                 chamber: TemperatureChamber | None = None, clock: SequenceClock | None = None,
                 existing: SequenceRun | None = None,
                 subscribers: Callable[[Step], list[Subscriber]] | None = None,
                 notify: Callable[[str], None] | None = None) -> None:
        self.config = config
        self.power = list(power)
        self.chamber = chamber
        self.clock: SequenceClock = clock if clock is not None else _WallClock()
        self.run = existing if existing is not None else new_sequence_run(config, self.clock.warp)
        self.resumed = existing is not None
        self._subscribers = subscribers or (lambda step: [])
        self._notify = notify or (lambda text: None)
        self._stop_reason: str | None = None
        self._recorder: Recorder | None = None
        self._lock = threading.RLock()  # journal, and the chamber's one Modbus link
        self._last_chamber_log = -math.inf
        self._deferred_power_on = None  # the resume's marks (see SequenceResume)
        self._resettle_at = self._redo_step = None
        self._restored_at = None

    # -- the journal -----------------------------------------------------------------
    def _log(self, kind: JournalKind, step: Step | None = None, *, unit: str = "",
             value: float = math.nan, detail: str = "", wall_s: float | None = None) -> None:
        entry = JournalEntry(kind, utc_now(), time.time() if wall_s is None else wall_s,
                             self.clock(), -1 if step is None else step.index,
                             0 if step is None else step.cycle, unit, value, detail[:200])
        with self._lock:
            self.run = dataclasses.replace(self.run, journal=(*self.run.journal, entry))

    def _save(self) -> None:
        with self._lock:
            write_sequence(self.run)

    def _set_segments(self, segments: tuple[Segment, ...]) -> None:
        with self._lock:
            self.run = dataclasses.replace(self.run, segments=segments)
        self._save()

    # -- control ---------------------------------------------------------------------
    def request_stop(self, reason: str) -> None:
        """Stop at once (a recording in progress is closed properly); the sequence stays
        resumable. Safe from a signal handler."""
        if self._stop_reason is None:
            self._stop_reason = reason
            if self._recorder is not None:
                self._recorder.request_stop(reason)

    def _check_stop(self) -> None:
        if self._stop_reason is not None:
            raise _Stopped(self._stop_reason)

    # -- the devices -----------------------------------------------------------------
    def _retried(self, action: Callable[[], T], device: PowerSwitch | TemperatureChamber,
                 step: Step | None) -> T:
        """``action()``, tried again (the link reopened) after a lost or refused exchange:
        a relay module or a controller that misses one answer does not end a night's test.

        Raises
        ------
        DeviceError
            The last of :data:`DEVICE_ATTEMPTS` attempts failed.
        """
        for attempt in range(1, DEVICE_ATTEMPTS + 1):
            try:
                return action()
            except DeviceError as exc:
                if attempt == DEVICE_ATTEMPTS:
                    raise
                self._log("error", step, detail=f"{device.describe()}: {exc}; trying again")
                time.sleep(0.1 * attempt)
                try:
                    device.open()
                except DeviceError:
                    pass
        raise AssertionError("unreachable")

    def _switch(self, on: bool, step: Step | None) -> None:
        for unit, switch in zip(self.run.unit_ids, self.power, strict=True):
            try:  # the instant a turn-on time counts from
                wall = self._retried(partial(switch.set_power, on), switch, step)
            except DeviceError as exc:
                raise SequenceError(f"{unit}: its supply ({switch.describe()}) did not switch "
                                    f"{'on' if on else 'off'}: {exc}") from exc
            self._log("power_on" if on else "power_off", step, unit=unit, wall_s=wall,
                      detail=switch.describe())

    def _chamber_temperature(self) -> float:
        chamber = self.chamber
        assert chamber is not None
        with self._lock:
            try:
                return self._retried(chamber.temperature_c, chamber, None)
            except DeviceError as exc:
                raise SequenceError(f"the chamber ({chamber.describe()}) does not answer: "
                                    f"{exc}") from exc

    def _log_chamber(self, step: Step | None, *, force: bool = False,
                     value: float | None = None) -> None:
        """Journal the chamber's air temperature when ``chamber_log_s`` has passed since the
        last reading journaled (or ``force``)."""
        if self.chamber is None:
            return
        now = self.clock()
        if not force and now - self._last_chamber_log < self.config.chamber_log_s:
            return
        self._last_chamber_log = now
        self._log("chamber", step, value=self._chamber_temperature() if value is None else value)

    # -- running ---------------------------------------------------------------------
    def execute(self) -> SequenceRun:
        """Run the steps from where the journal says; returns the sequence as saved.

        A stop request ends it early with an ``interrupted`` entry (state ``running``:
        start it again to resume).

        Raises
        ------
        SequenceError, RecorderError
            A step that cannot be done: the supplies are switched off, the journal says
            why, the state is ``failed``.
        """
        if self.resumed:
            self._resume()
        else:
            self._log("start", detail=f"sequence {self.run.name} of profile {self.run.profile}")
        self._save()
        steps = self.run.steps
        index = self.run.next_step()
        try:
            while index < len(steps):
                self._check_stop()
                step = steps[index]
                if index == self._resettle_at:
                    self._settle_again(step)
                if step.kind == "power_on" and index + 1 < len(steps) and \
                        steps[index + 1].kind == "record":
                    self._record(steps[index + 1], power_on=step)
                    index += 2
                elif step.kind == "record" and self._deferred_power_on is not None:
                    self._record(step, power_on=self._deferred_power_on)
                    self._deferred_power_on = None
                    index += 1
                else:
                    self._step(step)
                    index += 1
        except _Stopped as stop:
            current = self.run.steps[min(index, len(steps) - 1)]
            self._log("interrupted", current, value=self.run.elapsed_s(current.index),
                      detail=f"{stop}: stopped during {current.label}; start the sequence "
                             f"again to resume")
            self._save()
            return self.run
        except (StationError, DeviceError) as exc:
            self._fail(exc, steps[min(index, len(steps) - 1)])
            raise
        self._log("done", detail="every step done")
        with self._lock:
            self.run = dataclasses.replace(self.run, state="done")
        self._save()
        return self.run

    def _fail(self, exc: Exception, step: Step) -> None:
        self._log("error", step, detail=f"{type(exc).__name__}: {exc}")
        try:
            if self.power:
                self._switch(False, step)
        except (StationError, DeviceError) as off:
            self._log("error", step, detail=f"switching the supplies off failed too: {off}")
        with self._lock:
            self.run = dataclasses.replace(self.run, state="failed")
        self._save()

    def _step(self, step: Step) -> None:
        if step.kind == "record":
            self._record(step)  # (journals its own step_start)
            return
        self._notify(step.label)
        if self.run.elapsed_s(step.index) == 0.0:
            self._log("step_start", step)
        elapsed = self.run.elapsed_s(step.index)
        if step.kind == "power_on":
            self._switch(True, step)
        elif step.kind == "power_off":
            self._switch(False, step)
        elif step.kind in ("wait", "cool_down"):
            assert step.duration_s is not None
            self._wait(step, step.duration_s - elapsed, elapsed)
            elapsed = step.duration_s
        elif step.kind == "set_chamber":
            self._set_chamber(step)
        elif step.kind == "wait_stable":
            elapsed = self._wait_stable(step, elapsed)
        self._log("step_done", step, value=elapsed)
        self._save()

    def _wait(self, step: Step, remaining_s: float, done_s: float, *,
              progress: bool = True) -> None:
        """Sleep ``remaining_s`` on the sequence clock, journaling progress (cumulative
        from ``done_s``; unless not ``progress``) and the chamber; a stop request ends it."""
        start = self.clock()
        last_progress = start
        every = max(PROGRESS_SHARE * (remaining_s + done_s), 1e-9)
        while True:
            now = self.clock()
            if now - start >= remaining_s:
                return
            self._check_stop()
            self._log_chamber(step)
            if progress and now - last_progress >= every:
                last_progress = now
                self._log("progress", step, value=done_s + now - start)
                self._save()
            left_wall = (remaining_s - (now - start)) / self.clock.warp
            time.sleep(max(0.0, min(TICK_WALL_S, left_wall)))

    def _set_chamber(self, step: Step) -> None:
        if self.chamber is None:
            raise SequenceError(f"{step.label}: no chamber; give --chamber URL")
        assert step.temperature_c is not None
        chamber, target = self.chamber, step.temperature_c
        with self._lock:
            try:
                self._retried(lambda: chamber.set_temperature(target), chamber, step)
            except DeviceError as exc:
                raise SequenceError(f"{step.label}: the chamber ({self.chamber.describe()}) "
                                    f"refused the set point: {exc}") from exc
        self._log("setpoint", step, value=step.temperature_c, detail=self.chamber.describe())
        self._log_chamber(step, force=True)

    def _wait_stable(self, step: Step, done_s: float) -> float:
        """Wait until the air has stayed within the band of the set point for the hold time;
        returns the step's time so far (s)."""
        spec = self.config.spec
        target = self._setpoint()
        if self.chamber is None or target is None:
            raise SequenceError(f"{step.label}: no chamber set point to wait for "
                                f"(set_chamber T first, and give --chamber URL)")
        start = self.clock()
        inside_since: float | None = None
        poll_s = max(spec.stable_hold_s / 30.0, 1.0)
        while True:
            self._check_stop()
            now = self.clock()
            value = self._chamber_temperature()
            self._log_chamber(step, value=value)
            if abs(value - target) <= spec.stable_band_c:
                inside_since = now if inside_since is None else inside_since
                if now - inside_since >= spec.stable_hold_s:
                    self._log("stable", step, value=value,
                              detail=f"within {spec.stable_band_c:g} degC of {target:g} degC "
                                     f"for {spec.stable_hold_s:g} s")
                    return done_s + now - start
            else:
                inside_since = None
            if done_s + now - start > spec.stable_timeout_s:
                raise SequenceError(
                    f"{step.label}: the chamber reads {value:g} degC, not within "
                    f"{spec.stable_band_c:g} degC of {target:g} degC after "
                    f"{spec.stable_timeout_s:g} s: check the chamber, or raise "
                    f"stable_timeout_s / stable_band_c in the profile")
            time.sleep(max(TICK_WALL_S, min(poll_s / self.clock.warp, 1.0)))

    def _settle_again(self, step: Step) -> None:
        """Resumed inside a plateau: the chamber held stable at its set point again before
        the plateau goes on (journaled ``stable`` against ``step``)."""
        self._notify(f"{step.label}: the chamber settles again before the plateau resumes")
        self._wait_stable(step, 0.0)
        if self._restored_at is not None:  # and the warm-up of a unit switched on again
            self._wait(step, self.config.spec.bias_after_s - (self.clock() - self._restored_at),
                       0.0, progress=False)
        self._resettle_at = None
        self._save()

    # -- recording -------------------------------------------------------------------
    def _segment_file(self, step: Step) -> str:
        folder = f"{Path(self.run.path).stem}.segments"
        attempt = sum(1 for s in self.run.segments if s.step == step.index)
        return f"{folder}/s{step.index:03d}-c{step.cycle:02d}-{attempt}.h5"

    def _recorded_s(self, step: Step) -> float:
        """Time already recorded by the step's earlier segments (s, the shortest unit)."""
        total = 0.0
        for seg in self.run.segments:
            if seg.step != step.index or seg.superseded:
                continue
            try:
                run = open_run(Path(self.run.path).parent / seg.file)
            except (OSError, RecordFormatError):
                continue
            if run.units:
                total += min(u.record.duration_s for u in run.units)
        return total

    def _record(self, step: Step, *, power_on: Step | None = None) -> None:
        assert step.duration_s is not None
        if power_on is not None or step.index == self._redo_step:
            self._redo_step = None  # recorded in full: from its switch-on, or its settle
            if any(s.step == step.index for s in self.run.segments):
                self._set_segments(tuple(dataclasses.replace(s, superseded=True)
                                         if s.step == step.index else s
                                         for s in self.run.segments))
        remaining = step.duration_s - self._recorded_s(step)
        if remaining <= 0.5 / max(1.0, self.clock.warp):
            self._log("step_done", step, value=step.duration_s)
            self._save()
            return
        if power_on is not None and self.run.elapsed_s(power_on.index) == 0.0:
            self._notify(power_on.label)
            self._log("step_start", power_on)
        self._notify(step.label)
        if power_on is None and self.run.elapsed_s(step.index) == 0.0:
            self._log("step_start", step)
        spec, cfg = self.config.spec, self.config
        answer_s = 5.0 + (spec.turn_on_timeout_s / self.clock.warp if power_on else 0.0)
        file = self._segment_file(step)
        path = Path(self.run.path).parent / file
        path.parent.mkdir(parents=True, exist_ok=True)

        def listening() -> None:
            if power_on is not None:
                self._switch(True, power_on)
                self._log("step_done", power_on)
                self._log("step_start", step)
            self._set_segments((*self.run.segments, Segment(step.index, step.cycle, file, True)))

        recorder = Recorder(RunConfig(cfg.urls, remaining, path, profile=cfg.profile,
                                      metadata=RunMetadata(operator=cfg.operator, lot=cfg.lot,
                                                           bench=cfg.bench_json),
                                      answer_timeout_s=answer_s),
                            self._subscribers(step), on_listening=listening)
        self._recorder = recorder
        if self._stop_reason is not None:
            recorder.request_stop(self._stop_reason)
        try:
            recorder.prepare()
        except RecorderError as exc:
            self._recorder = None
            hint = (f" (turn_on_timeout_s = {spec.turn_on_timeout_s:g} s after power-on)"
                    if power_on is not None else "")
            raise SequenceError(f"{step.label}: the recording did not start{hint}: {exc}"
                                ) from exc
        stop_thread = threading.Event()
        logger = threading.Thread(target=self._log_chamber_until, args=(stop_thread, step),
                                  name="chamber-log", daemon=True)
        logger.start()
        try:
            stop = recorder.run()
        finally:
            stop_thread.set()
            logger.join(timeout=5.0)
            self._recorder = None
        clean = stop.reason == REASON_DURATION
        self._log("segment", step, detail=f"{file}: {stop.reason}")
        segments = tuple(dataclasses.replace(s, interrupted=not clean) if s.file == file else s
                         for s in self.run.segments)
        self._set_segments(segments)
        failed = [f"{w.unit_id}: {w.error}" for w in recorder.workers if w.error]
        if failed:
            self._log("error", step, detail="; ".join(failed))
        self._check_stop()
        if not clean:
            raise SequenceError(f"{step.label}: the recording stopped early ({stop.reason}); "
                                f"{path} keeps what it recorded")
        self._log("step_done", step, value=step.duration_s)
        self._save()

    def _log_chamber_until(self, stop: threading.Event, step: Step) -> None:
        while not stop.wait(max(TICK_WALL_S, self.config.chamber_log_s / self.clock.warp / 4)):
            try:
                self._log_chamber(step)
            except SequenceError:
                return
