"""Capture on the bench, replay in CI: a run recorded with ``capture=FILE`` units, replayed
through ``replay://FILE`` units, gives the same run file.

Two simulated units (a STIM300 on a pty, a raw-CAN node on python-can's virtual bus) are
recorded with dropped frames and, for the STIM300, a 1 s disconnect; their transports
write capture files meanwhile. The replay runs as fast as the adapters read, on the
recorded time base: every sample, counter and gap (the long one counted with the
elapsed time across the outage) comes back identical, and the run ends when the
captures do, which the file records as a complete run.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from station.model.profiles import load_profile
from station.recording.recorder import Recorder, RunConfig
from station.storage.hdf5 import REASON_END_OF_REPLAY, open_run_file, read_run, read_unit

UNITS = (
    "sim+serial://STIM300?protocol=stim300&counter=datagram&rate=100&warp=2&seed=3&drop=0.01"
    "&disconnect_every_s=3&disconnect_for_s=2",
    "sim+can://VG951?rate=100&warp=2&seed=4&drop=0.02",
)


@pytest.fixture(scope="module")
def recorded_and_replayed(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    tmp = tmp_path_factory.mktemp("replay")
    captures = [tmp / f"unit{i + 1}.jsonl" for i in range(len(UNITS))]
    live = Recorder(RunConfig(tuple(f"{url}&capture={cap}" for url, cap in zip(
        UNITS, captures, strict=True)), 8.0, tmp / "live.h5"))
    live.run()
    replay = Recorder(RunConfig(tuple(f"replay://{cap}" for cap in captures), 3600.0,
                                tmp / "replay.h5", profile=load_profile("ADIS16405")))
    stop = replay.run()
    assert stop.reason == REASON_END_OF_REPLAY
    return live.path, replay.path


@pytest.mark.slow
def test_replayed_run_has_the_same_samples_and_gaps(recorded_and_replayed) -> None:
    live_path, replay_path = recorded_and_replayed
    live, replay = read_run(live_path), read_run(replay_path)
    assert not replay.interrupted  # a capture replayed to its end is a complete run
    for unit_id, a, b in zip(("unit1", "unit2"), live.units, replay.units, strict=True):
        with open_run_file(live_path) as f:
            rec_a = read_unit(f, unit_id)
        with open_run_file(replay_path) as f:
            rec_b = read_unit(f, unit_id)
        # a simulated node is opened held: it sent no frame before the run started, so
        # the capture holds none in front of the live run's first sample
        early = rec_b.counter < rec_a.counter[0]
        assert not early.any(), unit_id
        assert len(rec_b.counter[~early]) == len(rec_a.counter) > 300, unit_id
        np.testing.assert_array_equal(rec_b.counter[~early], rec_a.counter)
        np.testing.assert_array_equal(rec_b.rate_deg_s[~early], rec_a.rate_deg_s)
        # (a gap whose best count is 0 only bounds wraps the timing of the reads could
        # hide: the replay reads at its own pace, so those bounds may differ)
        # a live simulated unit is known to start at counter 0, so the live run declares
        # what was sent before its first sample arrived; a capture starts with the first
        # bytes the transport saw, so its replay cannot know that gap
        before = [e.missing_samples for e in a.events
                  if e.kind == "gap" and "before the first sample" in e.detail]
        assert sum(before) == int(rec_a.counter[0]), unit_id
        # likewise the live run counts what its simulator sent after the last sample that
        # arrived (the simulator's own count); a capture ends with the last bytes it saw
        after = [e.missing_samples for e in a.events
                 if e.kind == "gap" and "ended on its own count" in e.detail]
        gaps_a = [(e.missing_samples, e.detail) for e in a.events if e.kind == "gap"
                  and e.missing_samples and "before the first sample" not in e.detail
                  and "ended on its own count" not in e.detail]
        gaps_b = [(e.missing_samples, e.detail) for e in b.events
                  if e.kind == "gap" and e.missing_samples]
        assert gaps_b == gaps_a and gaps_a, unit_id
        assert b.missing_samples == a.missing_samples - sum(before) - sum(after)
    long_gaps = [e for e in live.units[0].events if e.kind == "gap" and e.missing_samples > 128]
    assert long_gaps and all("counter+elapsed" in e.detail for e in long_gaps)


def test_replayed_units_keep_the_recorded_time_base(recorded_and_replayed) -> None:
    live_path, replay_path = recorded_and_replayed
    with open_run_file(replay_path) as f:
        rec = read_unit(f, "unit1")
    # receive times are recorded seconds (the live run lasted 8 simulated s = 4 wall s
    # at warp 2), not the few wall milliseconds the replay took
    span = float(rec.receive_time_s[-1] - rec.receive_time_s[0])
    assert 6.0 < span < 9.0, span
