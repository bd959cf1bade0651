"""Resuming a sequence: what a runner does first when it finds its journal unfinished.

:class:`SequenceResume` is the part of :class:`~station.recording.sequence_runner.SequenceRunner`
that journals the interruption, closes the segments a killed recorder left open
(:func:`station.storage.hdf5_recover.recover_run`), puts the supplies and the chamber back
as the journal left them, and marks what is redone rather than continued: a turn-on
record whose supplies were found off (from a new switch-on), and a temperature plateau
(the chamber settled again first, its record in full). The runner reads the marks
(``_deferred_power_on``, ``_resettle_at``, ``_redo_step``, ``_restored_at``) as it runs.
"""

from __future__ import annotations

import dataclasses
import math
import threading
from collections.abc import Callable
from pathlib import Path

from devices.errors import DeviceError
from devices.protocols import PowerSwitch, TemperatureChamber
from station.errors import RecorderError, RecordFormatError, SequenceError
from station.model.sequence_runs import JournalKind, SequenceRun
from station.model.sequences import Step, plateau_record
from station.storage.hdf5_recover import recover_run


class SequenceResume:
    """The resume of a :class:`~station.recording.sequence_runner.SequenceRunner` (its
    base: the runner sets these attributes and journals through ``_log``)."""

    run: SequenceRun
    power: list[PowerSwitch]
    chamber: TemperatureChamber | None
    clock: Callable[[], float]
    _lock: threading.RLock
    #: Resumed into a turn-on record with the supplies found off: they are switched on
    #: when its recorder listens, attributed to this power_on step.
    _deferred_power_on: Step | None = None
    #: Resumed inside a temperature plateau: the step the chamber is settled again
    #: before, and the plateau's record step, redone in full (None: none).
    _resettle_at: int | None = None
    _redo_step: int | None = None
    #: When this resume switched a supply on again (sequence clock s; None: it did not).
    _restored_at: float | None = None

    def _log(self, kind: JournalKind, step: Step | None = None, *, unit: str = "",
             value: float = math.nan, detail: str = "", wall_s: float | None = None) -> None:
        raise NotImplementedError

    def _setpoint(self) -> float | None:
        """The chamber set point the journal left (None: none)."""
        points = [e.value for e in self.run.journal if e.kind == "setpoint"]
        return points[-1] if points else None

    # -- resuming --------------------------------------------------------------------
    def _resume(self) -> None:
        """Journal the interruption, close what a killed recorder left open, and put the
        supplies and the chamber back as the journal left them."""
        run = self.run
        index = run.next_step()
        if index < len(run.steps) and not any(e.kind == "interrupted" and e.step == index
                                              and e.utc > self._last_resume_utc()
                                              for e in run.journal):
            step = run.steps[index]
            self._log("interrupted", step, value=run.elapsed_s(index),
                      detail=f"the station stopped during {step.label} without closing the "
                             f"sequence (killed, or a crash)")
        kept = []
        for seg in run.segments:
            path = Path(run.path).parent / seg.file
            if not path.exists():
                continue  # killed before the segment's file was made: nothing recorded
            if seg.interrupted:
                try:
                    result = recover_run(path, force=True)
                except (RecordFormatError, RecorderError) as exc:
                    self._log("error", run.steps[seg.step], detail=f"{seg.file}: {exc}")
                    continue
                if result.salvaged_to:
                    seg = dataclasses.replace(seg, file=str(
                        Path(result.salvaged_to).relative_to(Path(run.path).parent)))
            kept.append(seg)
        with self._lock:
            self.run = dataclasses.replace(self.run, segments=tuple(kept), state="running")
        self._log("resume", detail=f"resumed at step {index + 1} of {len(run.steps)}")
        self._restore(index)
        plateau = plateau_record(self.run.steps, index) if self.chamber is not None else None
        if plateau is not None:
            self._resettle_at = index
            turn_on = plateau.index > 0 and self.run.steps[plateau.index - 1].kind == "power_on"
            # a turn-on record is redone only with its switch-on (supplies found off)
            self._redo_step = None if turn_on else plateau.index

    def _last_resume_utc(self) -> str:
        return max((e.utc for e in self.run.journal if e.kind in ("resume", "start")), default="")

    def _restore(self, index: int) -> None:
        steps = self.run.steps
        turn_on_next = (index < len(steps) and steps[index].kind == "record" and index > 0
                        and steps[index - 1].kind == "power_on")
        for unit, switch in zip(self.run.unit_ids, self.power, strict=True):
            states = [e.kind for e in self.run.journal if e.unit == unit
                      and e.kind in ("power_on", "power_off")]
            want = bool(states) and states[-1] == "power_on"
            try:
                now_on = switch.is_powered()
            except DeviceError as exc:
                raise SequenceError(f"{unit}: its supply ({switch.describe()}) does not "
                                    f"answer: {exc}") from exc
            if want and not now_on and turn_on_next:
                self._deferred_power_on = steps[index - 1]
                continue  # the resumed record switches it on once it listens
            if want != now_on:
                wall = switch.set_power(want)
                if want:
                    self._restored_at = self.clock()
                self._log("power_on" if want else "power_off", None, unit=unit, wall_s=wall,
                          detail=f"restored on resume: {switch.describe()}")
        target = self._setpoint()
        if target is not None and self.chamber is not None:
            with self._lock:
                self.chamber.set_temperature(target)
            self._log("setpoint", None, value=target, detail="restored on resume")
