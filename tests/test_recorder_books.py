"""The books of every unit at speed: sent lies within recorded + [missing_low, missing_high].

Five units whose counters wrap within a second or less (STIM300 8-bit and KVH 7-bit on
ptys at 500 Hz, raw CAN at 500 Hz, Modbus TCP, CANopen in a process of its own) record
together at warp 1 and at warp 4 (rates and fault times scaled by the warp: the same
load on the host, the clock four times faster), on this loaded machine, while their
simulators drop, corrupt and garble frames, go away for 0.6-1 s (over a counter period)
and stall. For
every unit the simulator's own count of samples sent must lie within what was recorded
plus the fewest and the most samples its gaps may have lost; every gap's bounds are
exactly zero wide where its count is certain and at most one counter period wide where
the timing could not decide the wrap count.
"""

from __future__ import annotations

import math

import pytest

from devices.stream import StreamRateSource
from station.recording.recorder import Recorder, RunConfig
from station.recording.unit_worker import leading_gap_bounds, trailing_gap_count
from station.storage.hdf5 import gap_bounds, open_run_file, read_unit
from tests.devices.helpers import multicast_unavailable
from tests.test_recorder_helpers import assert_books

CANOPEN_BUS = "virtual" if multicast_unavailable() else "udp_multicast"
#: name -> device URL at warp 1 (the rates are divided by the warp: the same load on the
#: host at every warp, the counters wrapping as often in wall time).
UNITS = {
    "stim300": "sim+serial://STIM300?protocol=stim300&rate=500&drop=0.01&corrupt=0.005"
               "&garbage=0.005&disconnect_every_s=1&disconnect_for_s=0.7",
    "kvh1750": "sim+serial://DSP-1750?protocol=kvh1750&rate=500&drop=0.01"
               "&stall_every_s=1&stall_for_s=0.6",
    "can": "sim+can://STIM300?rate=500&drop=0.01&corrupt=0.01&disconnect_every_s=1"
           "&disconnect_for_s=0.6",
    "modbus": "sim+modbus+tcp://STIM300?rate=50&drop=0.02&disconnect_every_s=0.6"
              "&disconnect_for_s=0.9",
    "canopen": f"sim+canopen://STIM300/5?interface={CANOPEN_BUS}&rate=100&drop=0.01"
               "&disconnect_every_s=0.6&disconnect_for_s=0.9",
}
#: (The first fault 1 s after the start, the next as soon as a unit is back: in 3.5 s
#: two whole outages or stalls of the STIM300, KVH and CAN units and one whole and one
#: reaching the end of the Modbus and CANopen ones, no fewer than a 5 s run with its
#: faults from 2 s on held, in 30 % less wall time.)
DURATION_S = 3.5


def _at_warp(url: str, warp: int, seed: int) -> str:
    """``url`` at ``warp``, its rate and its fault times scaled to keep wall time."""
    base, query = url.split("?")
    keys = dict(kv.split("=") for kv in query.split("&"))
    keys["rate"] = f"{float(keys['rate']) / warp:g}"
    for key in ("disconnect_every_s", "disconnect_for_s", "stall_every_s", "stall_for_s"):
        if key in keys:
            keys[key] = f"{float(keys[key]) * warp:g}"
    return f"{base}?{'&'.join(f'{k}={v}' for k, v in keys.items())}&warp={warp}&seed={seed}"


@pytest.fixture(scope="module", params=[1, 4], ids=["warp1", "warp4"])
def books(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> dict:
    warp = request.param
    urls = tuple(_at_warp(url, warp, i + 1) for i, url in enumerate(UNITS.values()))
    recorder = Recorder(RunConfig(urls, DURATION_S * warp,
                                  tmp_path_factory.mktemp("books") / "r.h5", backoff_max_s=0.1))
    stop = recorder.run()
    out = {}
    with open_run_file(recorder.path) as f:
        for name, t in zip(UNITS, stop.totals, strict=True):
            unit = read_unit(f, t.unit_id)
            gaps = unit.events[unit.events["kind"] == b"gap"]
            low, high = gap_bounds(gaps)
            out[name] = (t, gaps, low, high, int(unit.attrs["counter_modulus"]))
            print(f"warp {warp} {name}: recorded {t.samples_recorded} + missing "
                  f"{t.samples_missing_declared} [{t.samples_missing_low}, "
                  f"{t.samples_missing_high}] in {len(gaps)} gaps, sent {t.samples_sent}; "
                  f"{int((high > low).sum())} gaps uncertain")
    return out


@pytest.mark.parametrize("name", UNITS)
@pytest.mark.slow
def test_sent_lies_within_the_books_of_every_unit(books: dict, name: str) -> None:
    t, gaps, low, high, _ = books[name]
    assert t.samples_missing_declared > 0  # the faults happened
    assert_books(t.samples_recorded, t.samples_missing_low, t.samples_missing_declared,
                 t.samples_missing_high, t.samples_sent, t)
    # the file's event log says the same as the totals
    assert (int(low.sum()), int(high.sum())) == (t.samples_missing_low, t.samples_missing_high)


@pytest.mark.parametrize("name", UNITS)
def test_each_gap_is_certain_or_at_most_one_wrap_wide(books: dict, name: str) -> None:
    t, gaps, low, high, modulus = books[name]
    assert (low <= gaps["missing_samples"]).all() and (gaps["missing_samples"] <= high).all()
    width = high - low
    # (the leading gap, before the first sample, may hold as many wraps as the time to
    # that sample: a starved start; see test_leading_gap_bounds)
    inside = gaps["after_counter"] >= 0
    # A counter that wraps within the station's timing allowance of a byte stream (25 ms of
    # host jitter and the simulator's latency on each side of a silence, times the warp: a
    # STIM300's counter counts at 2000 Hz and wraps every 0.128 s at any rate) leaves as
    # many wrap counts as that allowance holds (3 measured at warp 4, 0.28 s of allowance).
    keys = dict(kv.split("=", 1) for kv in t.url.split("?")[1].split("&"))
    warp, wrap_s = float(keys["warp"]), modulus / float(keys["rate"])
    allowance_s = 2 * (StreamRateSource.host_jitter_s + 0.002) * warp + wrap_s / 2
    wraps = math.ceil(allowance_s / wrap_s) + 1 if allowance_s > wrap_s else 1
    too_wide = width > wraps * modulus
    assert not (too_wide & inside).any(), gaps[inside & too_wide]
    if t.samples_missing_low == t.samples_missing_high:  # every count certain: exact
        assert t.samples_recorded + t.samples_missing_declared == t.samples_sent


def test_leading_gap_bounds() -> None:
    """The samples a simulated unit made before its first one received: the counter
    residue, and as many whole wraps as the time to that sample holds (0.3 s at 2 kHz:
    600 samples, two wraps of an 8-bit counter beyond a residue of 17), the best count
    the fewest that reach what it made before the hold."""
    assert leading_gap_bounds(17, 0, 0.3, 2000.0, 256) == (17, 17, 17 + 2 * 256)
    assert leading_gap_bounds(17, 0, 0.01, 2000.0, 256) == (17, 17, 17)  # certain
    assert leading_gap_bounds(17, 300, 0.01, 2000.0, 256) == (17, 17 + 256, 17 + 256)
    assert leading_gap_bounds(17, 0, 60.0, 2000.0, None) == (17, 17, 17)  # no wrap


def test_trailing_gap_count() -> None:
    """The samples a simulated unit sent after the last one received: from the unwrapped
    counter to its end, whole wraps included (a STIM300 at 1 kHz, 128 samples a wrap,
    whose host froze 0.33 s before the end: 333 samples, not their residue 77); an
    unwrapped counter already at the end leaves the residue; none received, all."""
    assert trailing_gap_count(3000, 2666, 128) == 333
    assert trailing_gap_count(3000, 2999, 128) == 0
    assert trailing_gap_count(3000, 3050, 128) == (2999 - 3050) % 128
    assert trailing_gap_count(3000, -1, 128) == 3000
