"""A temperature sequence killed (SIGKILL) at a chosen step and resumed by the same command:
what ``tests/test_sequence_resume.py`` checks once per step kind and
``benchmarks/bench_reliability.py`` repeats over kill moments.

The sequence is the issue's: the chamber at 25 degC, power on and record the turn-on, then
plateaus at 40, 10 and 25 degC. The simulated fixture lives in the killed process, so the
resumed one finds it as after a power cut: chamber back at ambient, every relay open.
"""

from __future__ import annotations

import contextlib
import json
import os
import random
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from analysis.models.power_cycle import PowerCycleModel
from devices.sim.powered import turn_on_draw
from station.errors import RecordFormatError
from station.model.sequence_runs import SequenceRun
from station.services.grade import GradeRequest, RunSource, grade
from station.services.sequence import (
    SequenceRequest,
    SimFixtureSettings,
    prepare_sequence,
    sequence_summary,
)
from station.storage.sequence_files import read_sequence

RATE_HZ = 5.0
WARP = 200.0
#: Each unit's bias temperature coefficient, deg/h per degC.
TEMPCO = 0.5
SELF_HEATING_C = 1.0
RECORD_S = 60.0
PLATEAUS_C = (25.0, 40.0, 10.0, 25.0)
PROFILE = f"""name = "SEQKILL"
version = "1"
model = "VG951"
[test]
sample_rate_hz = {RATE_HZ:g}
duration_s = 240.0
warmup_s = 5.0
axes = ["x"]
[grading]
confidence = 0.95
grades = ["A", "B"]
[figures.arw_fit]
unit = "deg/sqrt(h)"
limits = {{ A = 0.012, B = 0.025 }}
[sequence.plateaus]
steps = ["set_chamber 25", "wait_stable", "power_on", "record {RECORD_S:g}s",
         "set_chamber 40", "wait_stable", "record {RECORD_S:g}s",
         "set_chamber 10", "wait_stable", "record {RECORD_S:g}s",
         "set_chamber 25", "wait_stable", "record {RECORD_S:g}s", "power_off"]
bias_after_s = 20
stable_band_c = 0.5
stable_hold_s = 5
plateau_span_c = 1.0
[sequence.plateaus.figures.temperature_coefficient]
unit = "deg/h/degC"
limits = {{ A = 1.0 }}
[sequence.plateaus.figures.hysteresis]
unit = "deg/h"
[sequence.plateaus.figures.turn_on_repeatability]
unit = "deg/h"
"""
#: The step kinds of the sequence, where a kill can land.
STEP_KINDS = ("set_chamber", "wait_stable", "power_on", "record", "power_off")


#: The simulated units' turn-on behaviour (what :func:`unit_url` sets).
TURN_ON = PowerCycleModel(turn_on_s=3.0, turn_on_jitter_s=0.5, turn_on_bias_deg_h=10.0,
                          warmup_deg_h=5.0, warmup_tau_s=8.0, tempco_deg_h_per_c=TEMPCO)


def turn_on_bias_deg_h(seed: int, switch_on: int) -> float:
    """The turn-on bias (deg/h) the unit of ``seed`` draws at its ``switch_on``-th switch-on
    (the truth a resumed sequence's figures are compared with)."""
    return turn_on_draw(TURN_ON, seed, switch_on, 1).bias_deg_h[0]


def unit_url(seed: int) -> str:
    """A simulated VG951 with a turn-on bias, a warm-up transient and a temperature
    coefficient."""
    m = TURN_ON
    return (f"sim+serial://VG951?protocol=xbus&model=VG951&rate={RATE_HZ:g}&warp={WARP:g}"
            f"&seed={seed}&tempco={TEMPCO:g}&turn_on_s={m.turn_on_s:g}"
            f"&turn_on_jitter_s={m.turn_on_jitter_s:g}"
            f"&turn_on_bias_deg_h={m.turn_on_bias_deg_h:g}&warmup_deg_h={m.warmup_deg_h:g}"
            f"&warmup_tau_s={m.warmup_tau_s:g}")


def command(profile: Path, out: Path, seed: int) -> list[str]:
    """The command that runs (and, again, resumes) the sequence: ``station record
    --sequence plateaus --power sim --chamber sim`` as this module's :func:`main` runs it,
    with a quick chamber and die (the command line's simulated fixture has the slow
    default physics)."""
    return [sys.executable, "-m", "tests.sequence_kill", str(profile), str(out), str(seed)]


def main() -> int:
    """``python -m tests.sequence_kill PROFILE OUT SEED``: run or resume the sequence
    through the record service, print the ``--json-summary`` lines."""
    profile, out, seed = sys.argv[1], Path(sys.argv[2]), int(sys.argv[3])
    request = SequenceRequest("plateaus", profile, (unit_url(seed),), power=("sim",),
                              chamber="sim", out=out, chamber_log_s=10.0,
                              fixture=SimFixtureSettings(chamber_tau_s=8.0, unit_tau_s=5.0,
                                                         self_heating_c=SELF_HEATING_C))
    with prepare_sequence(request) as prepared:
        run = prepared.execute()
    for obj in sequence_summary(run):
        print(json.dumps(obj))
    return 0 if run.done else 1


def _start(args: list[str]) -> subprocess.Popen[str]:
    return subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=Path(__file__).resolve().parents[1])


def _current(out: Path) -> tuple[SequenceRun | None, int]:
    """The sequence file in ``out`` and the index of the step it runs (-1: none yet)."""
    for path in out.glob("seq-*.h5"):
        try:
            run = read_sequence(path)
        except (RecordFormatError, OSError):
            return None, -1
        return run, run.next_step()
    return None, -1


@dataclass(frozen=True)
class KillOutcome:
    """A sequence killed in one step and resumed: ``step`` is the step the kill landed in
    (the one the resume found running), ``kind`` its kind."""

    kind: str
    step: int
    summary: list[dict[str, object]]
    run: SequenceRun
    figures: dict[str, object]
    plateaus: list[dict[str, object]]
    resume_stderr: str


class KillMissed(AssertionError):
    """The first run finished before the kill landed (an instantaneous last step)."""


#: Sequence seconds a ``wait_stable`` of this profile takes (the chamber's lag to within
#: its band from 15 degC away, and the hold): where in it a kill lands.
WAIT_STABLE_S = 32.0
#: Steps whose start the sequence file shows while they run (the recorder's segment is
#: saved as it starts): the others show only as the next step to run once the step
#: before is done.
SHOWN_RUNNING = ("record", "power_on")


def killed_and_resumed(profile: Path, out: Path, *, seed: int, kind: str, nth: int = 0,
                       share: float = 0.5, timeout_s: float = 120.0) -> KillOutcome:
    """Run the sequence, kill -9 it ``share`` of the way into the ``nth`` step of ``kind``
    (a record's duration, a wait_stable's usual length; an instantaneous step as soon as
    it is the next to run), resume it with the same command, and grade the result.

    Raises
    ------
    KillMissed
        The first run finished before the kill landed.
    AssertionError
        The first run ended otherwise before the kill, or the resume failed.
    """
    args = command(profile, out, seed)
    first = _start(args)
    deadline = time.monotonic() + timeout_s
    try:
        while True:
            if first.poll() is not None:
                raise KillMissed(f"the first run ended before the kill: {first.communicate()}")
            assert time.monotonic() < deadline, "the sequence did not reach its step in time"
            run, index = _current(out)
            steps = run.steps if run is not None else ()
            targets = [s for s in steps if s.kind == kind]
            target = targets[min(nth, len(targets) - 1)] if targets else None
            if target is not None and index >= target.index and run is not None and (
                    kind not in SHOWN_RUNNING or any(e.kind == "step_start" and
                                                     e.step == target.index
                                                     for e in run.journal)):
                break
            time.sleep(0.02)  # each look reads the sequence file: 3 ms of a loaded core
        seconds = target.duration_s if kind == "record" else (
            WAIT_STABLE_S if kind == "wait_stable" else 0.0)
        time.sleep((seconds or 0.0) * share / WARP)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(first.pid, signal.SIGKILL)
        first.communicate()
    killed, _ = _current(out)
    if killed is None or killed.done:
        raise KillMissed(f"the kill in {kind} #{nth + 1} landed after the last step")
    second = _start(args)
    stdout, stderr = second.communicate(timeout=timeout_s)
    assert second.returncode == 0, stderr
    summary = [json.loads(line) for line in stdout.splitlines()]
    run = read_sequence(str(summary[0]["file"]))
    doc = grade(GradeRequest(RunSource(run.path), store=False)).graded.as_json()
    unit = doc["units"][0]  # type: ignore[index]
    # none: killed after the last step's end was saved, before the sequence's was
    landed = next((e.step for e in run.journal if e.kind == "interrupted"), len(run.steps) - 1)
    return KillOutcome(run.steps[landed].kind, landed, summary, run, unit["sequence_figures"],
                       unit["sequence_plateaus"], stderr)


def random_kind(rng: random.Random, kind: str | None = None) -> tuple[str, int, float]:
    """A kill moment drawn over the step kinds (or in steps of ``kind``): (kind, which of
    them, share of it)."""
    kind = rng.choice(STEP_KINDS) if kind is None else kind
    count = {"set_chamber": 4, "wait_stable": 4, "power_on": 1, "record": 4, "power_off": 1}
    return kind, rng.randrange(count[kind]), rng.random()


if __name__ == "__main__":
    sys.exit(main())
