"""A unit's start: its process imports nothing at the start that the fork server did not
import already (and nothing of scipy, matplotlib, numba, h5py), and its first-sample
timeout counts from the moment it reads its device."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from station.errors import RunConfigurationError
from station.recording.recorder import Recorder, RunConfig

HEAVY = ("scipy", "matplotlib", "numba", "h5py")

#: One unit of each kind the recorder's benchmark starts sixteen of, at 2 kHz.
URLS = ("sim+serial://STIM300?protocol=stim300&rate=2000&warp=1&seed=1",
        "sim+serial://DSP-1750?protocol=kvh1750&rate=2000&warp=1&seed=2",
        "sim+serial://MTI-630?protocol=xbus&rate=2000&warp=1&seed=3",
        "sim+can://STIM300?layout=shared&rate=2000&warp=1&seed=4")


def test_a_unit_imports_nothing_the_fork_server_did_not_preload() -> None:
    """What a unit's process does (open its device, read it, end it), after importing the
    preload list alone: no module comes on top, none of the heavy libraries is loaded."""
    code = f"""
import importlib, sys
from station.recording.unit_process import PRELOAD
for name in PRELOAD:
    importlib.import_module(name)
before = set(sys.modules)
from devices.urls import open_device
from station.recording.unit_worker import ReadSettings, UnitWorker
for url in {URLS!r}:
    opened = open_device(url)
    opened.source.open()
    worker = UnitWorker("u", opened, ReadSettings(0.2), lambda doc: None)
    worker.start()
    worker.join()
    opened.close()
print("new:", *sorted(m for m in set(sys.modules) - before if not m.startswith("_")))
print("heavy:", *(m for m in {HEAVY!r} if m in sys.modules))
"""
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    lines = dict(line.split(":", 1) for line in run.stdout.strip().splitlines()[-2:])
    assert lines["new"].split() == []
    assert lines["heavy"].split() == []


def test_a_silent_unit_is_refused_its_timeout_after_it_reads(tmp_path: Path) -> None:
    """A unit whose every frame is dropped: refused with the first-sample timeout, which
    ran from its ``started`` report (not from the start of its process)."""
    url = "sim+serial://STIM300?protocol=stim300&rate=500&warp=1&seed=5&drop=1"
    recorder = Recorder(RunConfig((url, URLS[0]), 1.0, tmp_path, answer_timeout_s=0.5))
    with pytest.raises(RunConfigurationError, match=r"unit1 .*no sample within 0\.5 s") as err:
        recorder.check_units()
    refused = time.monotonic()
    assert "unit2" not in str(err.value)
    started_at = recorder.workers[0].started_at
    assert started_at is not None and refused - started_at >= 0.5
