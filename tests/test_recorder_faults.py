"""Disconnects and damaged frames: recorded + declared missing == sent, for every unit.

Five simulated units over their real transports (STIM300 and KVH DSP-1750 on ptys, a
raw-CAN node on python-can's virtual bus, a Modbus TCP server on 127.0.0.1, a CANopen
node in another process on python-can's udp_multicast bus) record
together, time-warped, while their simulators drop, corrupt and garble frames and go
away for 1 s to 1 min (the pty closes, the CAN node falls silent, the Modbus server shuts
down). The 60 s and 56 s outages are longer than the 8-bit and 7-bit counters can count
alone: their gaps must be counted with the elapsed time and say so.
"""

from __future__ import annotations

import numpy as np
import pytest

from station.recording.recorder import Recorder, RunConfig
from station.storage.hdf5 import open_run_file, read_run, read_unit
from tests.devices.helpers import multicast_unavailable

WARP = 16
CANOPEN_BUS = "virtual" if multicast_unavailable() else "udp_multicast"
#: name -> (device URL, sample rate Hz, the outage it suffers, simulated s). Rates are low
#: so that half a counter period (25.6 s at 5 Hz on the 8-bit STIM300 counter, 25.6 s at
#: 2.5 Hz on the 7-bit KVH one) is over 1.5 s of wall time: a loaded machine's stalls must
#: not alias into counter wraps. (Every unit sends as many samples per wall second as at
#: warp 8 with twice the rate, and its drop/corrupt/garbage odds are doubled beside the
#: halved rate: as many faults per run, in half the wall time.) The STIM300's 60 s and
#: the KVH's 56 s outages hold 300 and 140 samples: over a period of their counters. (The
#: STIM300 framing with a counter of datagrams, ``counter=datagram``: a data sheet unit
#: offers 125 Hz and up, its counter wrapping every 0.128 s.)
UNITS = {
    "stim300": (f"sim+serial://STIM300?protocol=stim300&counter=datagram&rate=5&warp={WARP}"
                "&seed=1"
                "&disconnect_every_s=10&disconnect_for_s=60&drop=0.02&corrupt=0.02"
                "&garbage=0.02", 5.0, 60.0),
    "kvh1750": (f"sim+serial://DSP-1750?protocol=kvh1750&rate=2.5&warp={WARP}&seed=2"
                "&disconnect_every_s=12&disconnect_for_s=56&drop=0.04", 2.5, 56.0),
    "can": (f"sim+can://STIM300?rate=10&warp={WARP}&seed=3&disconnect_every_s=15"
            "&disconnect_for_s=1&drop=0.02&corrupt=0.02", 10.0, 1.0),
    "modbus": (f"sim+modbus+tcp://STIM300?rate=5&warp={WARP}&seed=4&disconnect_every_s=30"
               "&disconnect_for_s=5&drop=0.04", 5.0, 5.0),
    # a CANopen node in a process of its own, on python-can's udp_multicast bus (on a
    # host without multicast, in this process on the virtual bus)
    "canopen": (f"sim+canopen://STIM300/5?interface={CANOPEN_BUS}&rate=5&warp={WARP}"
                "&seed=5&disconnect_every_s=20&disconnect_for_s=10&drop=0.02", 5.0, 10.0),
}
DURATION_S = 80.0


@pytest.fixture(scope="module")
def faulty_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Recorder, object]:
    out = tmp_path_factory.mktemp("faults") / "run.h5"
    config = RunConfig(tuple(url for url, _, _ in UNITS.values()), DURATION_S, out,
                       backoff_max_s=0.2)
    recorder = Recorder(config)
    stop = recorder.run()
    for name, t in zip(UNITS, stop.totals, strict=True):  # shown with pytest -s
        print(f"{name}: recorded {t.samples_recorded} + declared missing "
              f"{t.samples_missing_declared} (gaps {t.gaps}) = sent {t.samples_sent}; "
              f"CRC errors {t.crc_errors}, reconnects {t.reconnects}")
    return recorder, stop


@pytest.mark.slow
def test_every_unit_accounts_for_every_sample_it_sent(faulty_run) -> None:
    recorder, stop = faulty_run
    assert stop.reason == "duration"
    run = read_run(recorder.path)
    for name, totals, unit in zip(UNITS, stop.totals, run.units, strict=True):
        assert totals.samples_sent is not None and totals.samples_sent > 0
        # the file says the same as the recorder's own count
        assert unit.record.n_samples == totals.samples_recorded, name
        assert unit.missing_samples == totals.samples_missing_declared, name
        assert (totals.samples_recorded + totals.samples_missing_declared
                == totals.samples_sent), (name, totals)
        assert totals.samples_missing_declared > 0, name  # the faults did happen


@pytest.mark.parametrize("name", ["stim300", "kvh1750"])
def test_long_outages_on_wrapping_counters_are_counted_with_elapsed_time(faulty_run,
                                                                          name: str) -> None:
    recorder, _ = faulty_run
    _, rate_hz, outage_s = UNITS[name]
    unit = read_run(recorder.path).units[list(UNITS).index(name)]
    kinds = [e.kind for e in unit.events]
    assert "disconnect" in kinds and "reconnect" in kinds
    # a gap of a whole counter period or more can only be counted with the elapsed time
    # (shorter ones, e.g. a pty that overflowed while a loaded host stalled the reader,
    # may rightly be counted by the counter alone)
    period = {"stim300": 256, "kvh1750": 128}[name]
    long_gaps = [e for e in unit.events if e.kind == "gap" and e.missing_samples >= period]
    assert long_gaps, unit.events
    assert all("counter+elapsed" in e.detail for e in long_gaps), long_gaps
    # the outage itself is inside the gap; a wrong wrap count would be 128 or 256 off
    expected = outage_s * rate_hz
    assert any(expected <= e.missing_samples < expected + 64 for e in long_gaps), long_gaps


def test_other_units_keep_recording_while_one_is_disconnected(faulty_run) -> None:
    recorder, _ = faulty_run
    with open_run_file(recorder.path) as f:
        stim, can = read_unit(f, "unit1"), read_unit(f, "unit3")
    # the STIM300 is away from 10 s to 70 s (its own time base) ...
    t_stim = stim.receive_time_s
    assert not np.any((t_stim > 15.0) & (t_stim < 65.0))
    # ... while the CAN unit (10 Hz, 1 s outages every 15 s) records through it
    t_can = can.receive_time_s
    during = int(np.count_nonzero((t_can > 15.0) & (t_can < 65.0)))
    assert during > 0.8 * UNITS["can"][1] * 50.0, during
