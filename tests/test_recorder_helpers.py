"""Helpers of the recorder tests: run ``station`` in a real process, wait for its file, and
check a recorded unit against the simulated signal it came from."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from urllib.parse import parse_qsl, urlsplit

import h5py
import numpy as np

from devices.sim.signal import SignalSource
from station.model.documents import utc_seconds
from station.storage.hdf5 import open_run_file, read_unit, run_state

#: Keys of one ``--json-summary`` object, exactly (issue 6, and the bounds of issue 21).
SUMMARY_KEYS = {"unit", "samples_recorded", "samples_missing_declared", "samples_missing_low",
                "samples_missing_high", "samples_sent", "gaps", "crc_errors", "reconnects",
                "file"}
#: Rate resolution per protocol: (absolute deg/s, relative); STIM300 sends value / 2^14
#: deg/s, Xbus float32 rad/s.
RESOLUTION = {"stim300": (2.0 ** -14, 0.0), "xbus": (1e-12, 2.0 ** -22)}


def station_cmd(*args: str) -> list[str]:
    """The command line of ``station ARGS`` in this interpreter."""
    return [sys.executable, "-m", "station.cli", *args]


def run_station(*args: str, timeout_s: float = 120.0,
                preexec_fn: Callable[[], None] | None = None) -> subprocess.CompletedProcess:
    """Run ``station ARGS`` to completion."""
    return subprocess.run(station_cmd(*args), capture_output=True, text=True, timeout=timeout_s,
                          preexec_fn=preexec_fn, check=False)


def recorder_cmd(*args: str) -> list[str]:
    """``station record ARGS`` through the recorder's own entry point (fewer imports)."""
    return [sys.executable, "-m", "station.commands.record", *args]


def start_recorder(*args: str, preexec_fn: Callable[[], None] | None = None
                   ) -> subprocess.Popen:
    """Start a recorder process, ``station record ARGS`` (the caller must end it)."""
    return subprocess.Popen(recorder_cmd(*args), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=preexec_fn)


def summaries(stdout: str) -> list[dict]:
    """The ``--json-summary`` objects of a ``station record`` output."""
    out = [json.loads(line) for line in stdout.splitlines() if line.strip()]
    for obj in out:
        assert set(obj) == SUMMARY_KEYS, obj
    return out


def assert_books(recorded: int, low: int, declared: int, high: int, sent: int | None,
                 what: object = "") -> None:
    """The books of one unit: what its simulator sent lies within what was recorded plus
    the fewest and the most samples its gaps may have lost, and the best count too."""
    assert sent is not None, what
    assert low <= declared <= high, what
    assert recorded + low <= sent <= recorded + high, what


def assert_summary_books(obj: dict) -> None:
    """:func:`assert_books` of one ``--json-summary`` object."""
    assert_books(obj["samples_recorded"], obj["samples_missing_low"],
                 obj["samples_missing_declared"], obj["samples_missing_high"],
                 obj["samples_sent"], obj)


def child_pids(pid: int) -> list[int]:
    """The processes whose parent is ``pid`` (Linux /proc): a recorder's forkserver, whose
    children are the recorder's unit processes."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue  # ended meanwhile
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                found.append(int(entry.name))
    return found


def wait_for_samples(folder: Path, min_samples: int, timeout_s: float = 60.0) -> Path:
    """The run file in ``folder`` once every unit has ``min_samples`` committed samples."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        files = list(folder.glob("*.h5"))
        if files:
            try:
                with h5py.File(files[0], "r", swmr=True) as f:
                    units = f["units"]
                    if len(units) and all(int(units[u]["committed"][0]) >= min_samples
                                          for u in units):
                        return files[0]
            except (OSError, KeyError):
                pass  # not created or not in SWMR mode yet
        time.sleep(0.05)
    raise TimeoutError(f"no run file with {min_samples} samples in {folder}")


def wait_for_file(folder: Path, timeout_s: float = 120.0) -> Path:
    """The run file in ``folder``, as soon as it exists."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        files = list(folder.glob("*.h5"))
        if files:
            return files[0]
        time.sleep(0.005)
    raise TimeoutError(f"no run file in {folder} after {timeout_s:g} s")


def data_lost_s(path: Path, killed_at_s: float) -> float:
    """Seconds of data a killed recorder lost: from its newest committed sample (or, with
    none, the start of its run) to the kill (``time.time()``), the largest over its
    units."""
    def stamp(text: str) -> float:
        seconds = utc_seconds(text)
        assert seconds is not None, text
        return seconds

    lost = 0.0
    with open_run_file(path) as f:
        for uid in f["units"]:
            unit = read_unit(f, uid)
            start = stamp(unit.attrs["start_utc"])
            warp = float(unit.attrs.get("time_warp", 1.0))
            last = float(unit.receive_time_s[-1]) / warp if len(unit.counter) else 0.0
            lost = max(lost, killed_at_s - (start + last))
    return lost


def last_flush_age_s(path: Path, at_utc_s: float) -> float:
    """Seconds between the file's last flush and ``at_utc_s`` (a ``time.time()``)."""
    with open_run_file(path) as f:
        stamp = run_state(f)["last_flush_utc"]
    flushed = utc_seconds(stamp)
    assert flushed is not None, stamp
    return at_utc_s - flushed


def check_unit_against_signal(path: Path, unit_id: str, url: str) -> int:
    """Assert that a simulated serial unit's committed samples are the simulated signal at
    their counters (to the protocol's resolution) and that counters and gaps agree; returns
    the number of samples checked."""
    query = dict(parse_qsl(urlsplit(url).query))
    atol, rtol = RESOLUTION[query["protocol"]]
    with open_run_file(path) as f:
        unit = read_unit(f, unit_id)
    counter = unit.counter
    assert len(counter) > 0
    steps = np.diff(counter)
    assert np.all(steps >= 1)
    gaps = unit.events[unit.events["kind"] == b"gap"]
    # every counter jump is a declared gap; so are the samples before the first one (a
    # simulated device starts at counter 0)
    assert int(gaps["missing_samples"].sum()) == int((steps - 1).sum()) + int(counter[0])
    assert np.all(np.diff(unit.receive_time_s) >= 0)
    truth = SignalSource(urlsplit(url).netloc, float(query["rate"]), n_axes=3,
                         seed=int(query["seed"])).read(int(counter[-1]) + 1).rate_deg_s
    error = np.abs(unit.rate_deg_s - truth[counter]) - rtol * np.abs(truth[counter])
    bad = np.flatnonzero(error.max(axis=1) > atol)
    assert len(bad) == 0, (f"{len(bad)} samples differ from the signal, first at counter "
                           f"{counter[bad[0]]}; gaps: {gaps[:5]}")
    return len(counter)
