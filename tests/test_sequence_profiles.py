"""Test sequences in profiles: steps unrolled, limits that the steps can measure, and
errors that name the file, the line and the key."""

from __future__ import annotations

import pytest

from station.errors import ProfileError, UsageError
from station.model.profiles import load_profile, parse_profile
from station.model.sequences import expand_steps
from station.services.sequence import SequenceRequest, check_request

BASE = """name = "T"
version = "1"
model = "T"
[test]
duration_s = 600.0
axes = ["x"]
[grading]
grades = ["A", "B"]
[figures.bias]
unit = "deg/h"
limits = { A = 1.0 }
"""


def test_repeat_blocks_unroll_with_their_cycle() -> None:
    steps = expand_steps(["set_chamber 25C", "wait_stable", "power_on", "record 20min",
                          "power_off", "cool_down 1h", "repeat 3", "set_chamber -10",
                          "record 5min"])
    assert len(steps) == 6 * 3 + 2  # the block since the start repeats whole
    assert [s.index for s in steps] == list(range(len(steps)))
    assert [s.cycle for s in steps if s.kind == "record"] == [1, 2, 3, 1]
    assert steps[3].duration_s == 1200.0 and steps[-2].temperature_c == -10.0


@pytest.mark.parametrize(("steps", "message"), [
    ('["power_on", "recrd 20min"]', r"steps\[1\]: unknown step 'recrd 20min'"),
    ('["repeat 3"]', "repeat with no step before it"),
    ('["record 1h", "repeat 0"]', "whole number of times >= 1"),
    ('["set_chamber warm", "record 1h"]', "needs a temperature in degC"),
    ('["power_on", "wait"]', "wait needs a duration"),
    ('["power_on"]', "no record step"),
])
def test_bad_steps_name_the_line(steps: str, message: str) -> None:
    text = BASE + f"[sequence.s]\nsteps = {steps}\n"
    with pytest.raises(ProfileError, match=message) as err:
        parse_profile(text, path="p.toml")
    assert err.value.line == 13 and err.value.key == "sequence.s.steps"


@pytest.mark.parametrize(("extra", "message"), [
    ('steps = ["power_on", "record 1h", "power_off", "repeat 3"]\n'
     "[sequence.s.figures.turn_on_repeatability]\nlimits = { A = 1.0 }\n",
     "record 3 turn-on.*at least 5"),
    ('steps = ["set_chamber 25", "record 1h"]\n'
     "[sequence.s.figures.temperature_coefficient]\nlimits = { A = 0.1 }\n",
     "1 chamber temperature.*at least 2"),
    ('steps = ["power_on", "record 1h", "repeat 5"]\n'
     '[sequence.s.figures.warmup_time]\nunit = "s"\n', "needs the band"),
    ('steps = ["power_on", "record 10min", "repeat 5"]\nbias_after_s = 900\n'
     "warmup_band_deg_h = 1\n[sequence.s.figures.warmup_time]\nlimits = { A = 100 }\n",
     "ends before bias_after_s"),
    ('steps = ["record 1h"]\n[sequence.s.figures.warmup_time]\nunit = "days"\n',
     "'days' is not a unit of warm-up time"),
    ('steps = ["record 1h"]\n[sequence.s.figures.drift]\nunit = "s"\n', "unknown sequence figure"),
    ('steps = ["record 1h"]\nstable_band = 1\n', "unknown key"),
])
def test_limits_the_steps_cannot_measure_are_refused(extra: str, message: str) -> None:
    with pytest.raises(ProfileError, match=message):
        parse_profile(BASE + "[sequence.s]\n" + extra, path="p.toml")


def test_shipped_sequences_and_what_a_run_needs() -> None:
    p = load_profile("VG951")
    turn_on, temperature = p.sequence("turn_on"), p.sequence("temperature")
    assert turn_on.turn_on_records == 6 and turn_on.uses_power and not turn_on.uses_chamber
    assert temperature.uses_chamber and {s.temperature_c for s in temperature.steps
                                         if s.kind == "set_chamber"} == {25, -40, -10, 40, 70}
    with pytest.raises(ProfileError, match="no sequence 'soak'.*turn_on, temperature"):
        p.sequence("soak")
    url = "sim+serial://VG951?protocol=xbus&warp=10"
    with pytest.raises(UsageError, match="give --power URL"):
        check_request(SequenceRequest("turn_on", "VG951", (url,)), turn_on)
    with pytest.raises(UsageError, match="give --chamber URL"):
        check_request(SequenceRequest("temperature", "VG951", (url,), power=("sim",)),
                      temperature)
    with pytest.raises(UsageError, match="2 --power for 1 --unit"):
        check_request(SequenceRequest("turn_on", "VG951", (url,), power=("a", "b")), turn_on)
    with pytest.raises(UsageError, match="simulated units only"):
        check_request(SequenceRequest("turn_on", "VG951", ("serial:///dev/ttyUSB0",),
                                      power=("sim",)), turn_on)
    with pytest.raises(UsageError, match="one warp"):
        check_request(SequenceRequest("turn_on", "VG951", (url, url.replace("=10", "=20")),
                                      power=("sim",)), turn_on)
