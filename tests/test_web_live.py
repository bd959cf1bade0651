"""``station serve`` read by many clients at once: a run file a real recorder (``station
record``, a simulated unit) is writing, read by eight threads through the application,
each answer whole (no request sees a half-read file as missing or damaged)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from starlette.testclient import TestClient

from station.web import ServeConfig, create_app

READERS = 8
READS_EACH = 3


@pytest.mark.slow
def test_eight_readers_of_a_live_run_all_get_whole_answers(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    runs.mkdir()
    recorder = subprocess.Popen(
        [sys.executable, "-m", "station", "record", "--profile", "VG951", "--unit",
         "sim+serial://VG951?rate=10&warp=50", "--duration", "1h", "--flush-interval", "0.1",
         "--quiet", "--out", str(runs / "live.h5")],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env={**os.environ})
    try:
        client = TestClient(create_app(ServeConfig(tmp_path / "results.sqlite", (runs,))),
                            raise_server_exceptions=False)
        deadline = time.monotonic() + 60.0
        while time.monotonic() < deadline:  # until the recorder has flushed some samples
            doc = client.get("/api/runs").json()
            if doc["runs"] and doc["runs"][0]["units"][0]["samples_recorded"] > 500:
                break
            assert recorder.poll() is None, recorder.stderr.read() if recorder.stderr else ""
            time.sleep(0.2)
        answers: list[tuple[int, int, int]] = []
        samples: list[int] = []

        def read() -> None:
            for i in range(READS_EACH):
                path = "/runs" if i == READS_EACH - 1 else "/api/runs"
                answer = client.get(path)
                if path == "/api/runs" and answer.status_code == 200:
                    doc = answer.json()
                    answers.append((200, len(doc["runs"]), len(doc["damaged"])))
                    samples.append(doc["runs"][0]["units"][0]["samples_recorded"]
                                   if doc["runs"] else -1)
                else:
                    answers.append((answer.status_code, 1, 0))

        threads = [threading.Thread(target=read) for _ in range(READERS)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert recorder.poll() is None  # the file was live all along
    finally:
        recorder.send_signal(signal.SIGTERM)
        recorder.wait(timeout=30)
    assert len(answers) == READERS * READS_EACH
    assert set(answers) == {(200, 1, 0)}  # every answer whole: one run, none damaged
    assert min(samples) > 500 and max(samples) >= min(samples)
