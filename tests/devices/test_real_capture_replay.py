"""What real units sent (``../shared/real-captures/``), recorded by the station as a unit:
``station record --unit 'replay://FILE?protocol=P&...'`` (the recorder the command runs).

Every file replays with no gap the station invents and with the samples the device says
are good marked valid (``status`` 0), the device's own word kept beside it
(``device_status``), and its values as the publisher decoded them:

* Xsens MTi-G-710, float32 (``xsens-mtig710/1``) and FP12.20 (``/2``): 100 messages, 96 of
  them inertial, 4 GNSS PVT messages of their own (with their own PacketCounter: no sample
  of the inertial stream is missing around them); StatusWord / StatusByte as sent; the
  publisher's decode is ``output.golden`` (rates rad/s, accelerations m/s^2).
* KVH DSP-1750, format A (``kvh1750``): "early" (status 0x70: the gyros not valid yet,
  sequence 31), "basic" (0x77: all valid, sequence 104), and "bad_crc" (a damaged CRC): two
  samples, one CRC error; between 31 and 104 the unit's own counter says 72 samples are
  not in the file (the unit test kept three messages of a stream): that gap is the
  device's, exactly as its counter states it, and the only one.
* STIM300 datagram 0xAF (``stim300``): one datagram of a unit at rest (its counter 225).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from station.model.profiles import load_profile
from station.recording.recorder import Recorder, RunConfig
from station.storage.hdf5 import (
    REASON_END_OF_REPLAY,
    UnitData,
    open_run_file,
    read_run,
    read_unit,
    unit_counts,
)

CAPTURES = Path(__file__).resolve().parents[3] / "shared" / "real-captures"
pytestmark = pytest.mark.skipif(not CAPTURES.exists(),
                                reason="../shared/real-captures is not beside this checkout")
G = 9.80665


def _record(tmp_path: Path, url: str, rate_hz: float) -> tuple[UnitData, object, object]:
    """Record one replayed unit as ``station record --profile ADIS16405 --unit URL`` does
    (a replay is recorded at its own rate, ``rate_hz``, whatever the profile's 100 Hz);
    returns its data, counts and the run."""
    profile = load_profile("ADIS16405")
    out = tmp_path / "run.h5"
    stop = Recorder(RunConfig((url,), 3600.0, out, profile=profile)).run()
    assert stop.reason == REASON_END_OF_REPLAY
    with open_run_file(out) as f:
        unit = read_unit(f, "unit1")
        assert math.isclose(float(unit.attrs["sample_rate_hz"]), rate_hz)
        return unit, unit_counts(f, "unit1"), read_run(out)


def _golden(path: Path) -> list[dict[str, list[str]]]:
    """The publisher's decode: one dict per message, item name -> its lines."""
    out = []
    for block in path.read_text().strip().split("\n\n"):
        item: dict[str, list[str]] = {}
        key = ""
        for line in block.splitlines():
            if line.startswith(" "):
                item[key].append(line.strip())
            else:
                key = line.rstrip(":").split("(")[0]
                item[key] = []
        out.append(item)
    return out


def _xyz(lines: list[str]) -> list[float]:
    return [float(v.split(":")[1]) for v in lines]


@pytest.mark.slow
@pytest.mark.parametrize(("folder", "status_item"), [("1", "StatusWord"), ("2", "StatusByte")])
def test_xsens_mtig710_replays_with_no_gap_and_valid_samples(tmp_path: Path, folder: str,
                                                              status_item: str) -> None:
    dump = CAPTURES / "xsens-mtig710" / folder / "output.bin"
    unit, counts, run = _record(tmp_path, f"replay://{dump}?protocol=xbus&rate=100", 100.0)
    inertial = [m for m in _golden(dump.with_name("output.golden")) if "RateOfTurn" in m]
    assert len(inertial) == 96
    assert counts.samples_recorded == 96, counts
    assert counts.gaps == counts.samples_missing_declared == counts.samples_missing_high == 0
    assert counts.crc_errors == 0 and counts.bad_samples == 0
    assert not run.interrupted
    # the device says every inertial sample is good; its word is kept as it sent it
    assert unit.valid.all(), np.unique(unit.status)
    assert unit.device_status is not None
    assert unit.device_status.tolist() == [int(m[status_item][0], 2) for m in inertial]
    # the values as the publisher decoded them (rad/s -> deg/s; m/s^2)
    rates = np.degrees([_xyz(m["RateOfTurn"]) for m in inertial])
    np.testing.assert_allclose(unit.rate_deg_s, rates, rtol=1e-6, atol=1e-9)
    assert unit.accel_m_s2 is not None
    np.testing.assert_allclose(unit.accel_m_s2, [_xyz(m["Acceleration"]) for m in inertial],
                               rtol=1e-6, atol=1e-9)
    # the time base is the device's: SampleTimeFine (10 kHz ticks) since the first sample
    fine = np.array([int(m["SampleTimeFine"][0]) for m in inertial])
    np.testing.assert_allclose(unit.receive_time_s - unit.receive_time_s[0],
                               (fine - fine[0]) * 1e-4, atol=1e-9)
    assert run.units[0].record.n_samples == 96 and run.units[0].record.missing_samples == 0


@pytest.mark.slow
def test_kvh1750_replays_its_messages_with_the_device_validity(tmp_path: Path) -> None:
    dump = CAPTURES / "kvh1750" / "trecvt_utest_messages.bin"
    unit, counts, _ = _record(
        tmp_path, f"replay://{dump}?protocol=kvh1750&output=delta&rate=1000", 1000.0)
    assert counts.samples_recorded == 2 and counts.crc_errors == 1  # "bad_crc" is rejected
    assert (unit.counter[1] - unit.counter[0]) == 104 - 31
    # the only gap is the one the unit's own counter states (31 -> 104: 72 not in the file)
    assert counts.gaps == 1 and counts.samples_missing_declared == 72
    assert counts.samples_missing_low == counts.samples_missing_high == 72
    # "early": status 0x70, gyros not valid yet; "basic": 0x77, all valid (ICD 56-0298)
    assert unit.status[0] != 0 and unit.status[1] == 0
    assert unit.device_status is not None and unit.device_status.tolist() == [0x70, 0x77]
    assert unit.temperature_c is not None and unit.temperature_c.tolist() == [29.0, 29.0]
    assert unit.accel_m_s2 is not None
    # "basic": az 0x3f7ecbd4 = 0.99530 g (a unit at rest, 1 g on z)
    assert unit.accel_m_s2[1][2] == pytest.approx(0.9952976703643799 * G, rel=1e-6)


@pytest.mark.slow
def test_stim300_0xaf_datagram_replays_as_a_valid_sample(tmp_path: Path) -> None:
    dump = CAPTURES / "stim300" / "stim300_geirhovland_0xAF_reconstructed.bin"
    unit, counts, _ = _record(
        tmp_path, f"replay://{dump}?protocol=stim300&datagram=0xAF&rate=125", 125.0)
    assert counts.samples_recorded == 1 and counts.crc_errors == 0
    assert counts.gaps == counts.samples_missing_declared == 0
    # the run file counts samples: the unit's counter (225) counts its 2000 Hz internal
    # samples, 16 a datagram at 125 Hz (tests/devices/test_stim300_datasheet.py reads 225)
    assert len(unit.counter) == 1 and unit.valid.all()
    assert unit.device_status is not None and unit.device_status[0] >= 0
    # the publisher's decode (README excerpt): rates deg/s, accelerations g, temperature
    np.testing.assert_allclose(unit.rate_deg_s[0],
                               [0.017822265625, -0.0806884765625, 0.05242919921875], atol=1e-9)
    assert unit.accel_m_s2 is not None
    np.testing.assert_allclose(unit.accel_m_s2[0] / G, [-0.011890411376953125,
                                                        -0.016986846923828125,
                                                        1.0138282775878906], atol=1e-9)
    # the unit's temperature: the mean of the gyro triple (35.625, 35.75, 35.625 degC)
    assert unit.temperature_c is not None
    assert math.isclose(unit.temperature_c[0], (35.625 + 35.75 + 35.625) / 3)
