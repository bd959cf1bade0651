"""``station record`` as a user runs it: several units, the JSON summary, SIGTERM, a live
reader, and every bad configuration refused before anything is recorded."""

from __future__ import annotations

import signal
import threading
from pathlib import Path

import h5py
import pytest

from station.cli import main
from station.model.durations import parse_duration
from station.model.profiles import PROFILE_DIR
from station.storage.hdf5 import read_run
from tests.test_recorder_helpers import (
    assert_summary_books,
    start_recorder,
    summaries,
    wait_for_samples,
)

#: A STIM300 on a pty with every frame fault, a CAN node with drops and bad CRCs, and a
#: Modbus TCP gyro whose server goes away for 3 s.
FAULTY_UNITS = (
    "sim+serial://STIM300?protocol=stim300&counter=datagram&rate=10&warp=10&seed=7&drop=0.03&corrupt=0.03"
    "&garbage=0.03",
    "sim+can://STIM300?rate=10&warp=10&seed=8&drop=0.03&corrupt=0.03",
    "sim+modbus+tcp://STIM300?rate=10&warp=10&seed=9&drop=0.03&disconnect_every_s=15"
    "&disconnect_for_s=3",
)
#: The run that reaches its duration, simulated s (3 s of wall time at warp 10; its
#: Modbus outage from 15 s to 18 s lies inside it; 0.97 ** 300 = 1e-4: each unit drops
#: frames).
DONE_S = 30.0


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[int, str, str, Path]]:
    """Two recorder processes at once: one to its duration, one stopped by SIGTERM after a
    live ``station watch``; (exit code, stdout, stderr or watch output, file) of each."""
    args = [a for url in FAULTY_UNITS for a in ("--unit", url)]
    done_dir, term_dir = tmp_path_factory.mktemp("done"), tmp_path_factory.mktemp("term")
    done = start_recorder(*args, "--duration", f"{DONE_S:g}s", "--out", str(done_dir),
                          "--json-summary", "--quiet", "--operator", "tester", "--lot", "L7")
    term = start_recorder(*args, "--duration", "12h", "--out", str(term_dir), "--json-summary",
                          "--quiet")
    try:
        path = wait_for_samples(term_dir, 50)
        watch = _capture_main(["watch", str(path), "--once"])
        term.send_signal(signal.SIGTERM)
        t_out, _ = term.communicate(timeout=60)
        d_out, d_err = done.communicate(timeout=90)
    finally:
        for p in (done, term):
            if p.poll() is None:
                p.kill()
                p.communicate()
    return {"done": (done.returncode, d_out, d_err, next(done_dir.glob("*.h5"))),
            "term": (term.returncode, t_out, watch, path)}


def _capture_main(argv: list[str]) -> str:
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(argv) == 0
    return buf.getvalue()


@pytest.mark.parametrize("which", ["done", "term"])
@pytest.mark.slow
def test_json_summary_accounts_for_every_sample_the_simulators_sent(two_runs, which) -> None:
    code, out, err, path = two_runs[which]
    assert code == 0, err
    objs = summaries(out)  # exactly the keys of the issue, one object per unit
    assert [o["unit"] for o in objs] == list(FAULTY_UNITS)
    # every unit drops 3% of its frames: over a 30 s run (300 frames) each one shows gaps;
    # the SIGTERM run stops after about 50-120 frames, where one unit may by chance have
    # none (0.97**114 = 3%), so there the faults are counted over the three units
    assert sum(o["gaps"] for o in objs) > 0
    for o in objs:
        assert o["file"] == str(path)
        assert o["samples_recorded"] > 50
        assert which == "term" or o["gaps"] > 0, o
        assert_summary_books(o)
        # 10 Hz: a counter period is 25.6 s, far beyond any timing doubt: every count exact
        assert o["samples_recorded"] + o["samples_missing_declared"] == o["samples_sent"], o
        assert o["samples_missing_low"] == o["samples_missing_high"], o
    assert objs[0]["crc_errors"] > 0  # corrupted STIM300 datagrams are counted


def test_a_run_that_reached_its_duration_is_complete_and_closed(two_runs) -> None:
    _, out, err, path = two_runs["done"]
    # the Modbus outages are events in the file, not pymodbus's frame dumps on stderr
    assert ">>>>>" not in err and "Connection to" not in err, err
    with h5py.File(path, "r") as f:  # closed properly: no SWMR needed
        assert f.attrs["stop_reason"].decode() == "duration"
        assert f.attrs["operator"] == "tester" and f.attrs["lot"] == "L7"
    run = read_run(path)
    assert not run.interrupted and run.metadata.operator == "tester"
    for unit, obj in zip(run.units, summaries(out), strict=True):
        assert unit.record.n_samples == obj["samples_recorded"]
        # recorded + declared missing samples span the unit's run, in simulated seconds:
        # its duration, and on a loaded host the time it took to end on a sample index after
        span_s = (unit.record.n_samples + unit.missing_samples) / unit.record.sample_rate_hz
        ended_s = max(e.time_s for e in unit.events if e.kind == "end")
        assert ended_s >= DONE_S and span_s == pytest.approx(ended_s, rel=0.1)


def test_sigterm_stops_cleanly_and_records_why(two_runs) -> None:
    _, out, watch, path = two_runs["term"]
    run = read_run(path)
    assert run.stop_reason == "terminated (SIGTERM)" and run.interrupted
    assert [u.record.n_samples for u in run.units] == [
        o["samples_recorded"] for o in summaries(out)]
    # the live reader saw the run in progress, each unit with its samples
    assert "recording, last flush" in watch
    assert "unit1:" in watch and "unit2:" in watch


def _write_profile(folder: Path, axes: str) -> Path:
    text = (PROFILE_DIR / "VG951.toml").read_text(encoding="utf-8")
    path = folder / "four-axes.toml"
    path.write_text(text.replace('axes = ["x"]', f"axes = {axes}"), encoding="utf-8")
    return path


@pytest.mark.parametrize("case", ["unknown profile", "bad url", "unreachable", "rate",
                                  "axes", "hardware without profile", "disk", "duration"])
def test_bad_configuration_is_refused_before_the_run_starts(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], case: str) -> None:
    out = tmp_path / "runs"
    sim = "sim+serial://VG951?protocol=stim300&rate=10&warp=10"
    argv, expected = {
        "unknown profile": (["--profile", "NO-SUCH-GYRO", "--unit", sim], "NO-SUCH-GYRO"),
        "bad url": (["--unit", "carrier-pigeon://gyro"], "bad device URL"),
        "unreachable": (["--profile", "VG951", "--unit",
                         f"serial://{tmp_path}/ttyNOPE?protocol=stim300&rate=125"],
                        "device not reachable"),
        "rate": (["--profile", "VG951", "--unit", sim.replace("rate=10", "rate=100")],
                 "reports 100 Hz, profile VG951 expects 10 Hz"),
        "axes": (["--profile", str(_write_profile(tmp_path, '["x", "w"]')), "--unit", sim],
                 "needs x, w"),
        "hardware without profile": (["--unit", f"serial://{tmp_path}/ttyX?protocol=stim300"],
                                     "needs --profile PROFILE"),
        "disk": (["--unit", sim.replace("rate=10", "rate=2000"), "--duration", "100000d"],
                 "GB can be written there"),
        "duration": (["--unit", sim, "--duration", "12 hours"], "duration '12 hours'"),
    }[case]
    if "--duration" not in argv:
        argv += ["--duration", "1h"]
    threads = threading.active_count()
    assert main(["record", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert expected in err
    assert not list(out.glob("*.h5")) if out.exists() else True  # nothing recorded
    assert threading.active_count() == threads  # every simulator was stopped


@pytest.mark.parametrize(("text", "seconds"), [("12h", 43200.0), ("1h30m", 5400.0),
                                               ("90", 90.0), ("2.5min", 150.0),
                                               ("1d2h", 93600.0), ("250ms", 0.25)])
def test_durations(text: str, seconds: float) -> None:
    assert parse_duration(text) == pytest.approx(seconds)


def test_progress_line_shows_counts_and_allan_deviation_at_1_s_and_100_s() -> None:
    import io

    import numpy as np

    from devices.protocols import DeviceDescription
    from station.model.documents import Descriptor, EventBatch, LogEntry, RunStart, data_keys
    from station.recording.progress import ProgressLine

    rate_hz, n = 50.0, 50 * 400
    stream = io.StringIO()
    line = ProgressLine(stream, plain_interval_s=1e9)
    d = DeviceDescription("TEST", "S1", "stim300", "serial", ("x", "y", "z"), rate_hz, True,
                          256, False, False)
    line(RunStart("u", "t", ("unit1",), 800.0, "f.h5"))
    line(Descriptor("unit1", "sim+serial://TEST", d, data_keys(d), "t", "sim", 2.0))
    sigma = 0.01  # deg/s white noise: ADEV(tau) = sigma / sqrt(rate * tau)
    rate = np.random.default_rng(3).normal(0.0, sigma, (n, 3))
    counter = np.arange(n)
    line(EventBatch("unit1", 0, rate, counter, counter / rate_hz, np.zeros(n, np.uint32),
                    log=(LogEntry("gap", 1.0, 1, 5, 10, "counter"),
                         LogEntry("crc_error", 2.0, 3))))
    text = line.line()
    assert "unit1: 20.0k smp @50 Hz, crc 3, gaps 1 (5 miss), reconn 0" in text
    assert "00:03:20 left" in text  # (800 s - 400 s) / warp 2
    averager = line.averagers["unit1"]
    expected_deg_h = [sigma / np.sqrt(rate_hz * tau) * 3600 for tau in (1, 100)]
    measured = [averager.adev_deg_h(1), averager.adev_deg_h(100)]
    assert measured[0] == pytest.approx(expected_deg_h[0], rel=0.1)
    assert measured[1] == pytest.approx(expected_deg_h[1], rel=0.6)  # 4 clusters of 100 s
    assert f"adev 1s {measured[0]:.3g} 100s {measured[1]:.3g} deg/h" in text
