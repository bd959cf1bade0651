"""``station fleet`` on a real dask.distributed cluster of two worker processes on 127.0.0.1:
the same JSON numbers as ``station grade`` one file at a time, failures listed with their
reason while the other tasks finish, every unit stored (SQLite and PostgreSQL), reports
written by the driver, the progress bar only on a terminal."""

from __future__ import annotations

import io
import json
import os
import signal
import threading
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import pytest
from distributed import KilledWorker

from station.cli import main
from station.commands.fleet import ProgressBar
from station.output.results import ResultsDatabase
from station.services.fleet import (
    LOCAL,
    FleetProgress,
    FleetRequest,
    cluster_client,
    fleet,
    lost_task_text,
    run_files,
)
from tests.fleet_runs import write_run
from tests.test_gmwm_report import gm_unit  # noqa: F401 - the GMWM record, a module fixture
from tests.test_gmwm_views import keyed  # noqa: F401 - with a profile that asks for it
from tests.test_grading import profile_text, write_profile

GOOD = 2  # runs of two units each
#: Length of the good runs, s: 2,000 samples at 10 Hz, the profile's 1,000 after its 10 s
#: warm-up twice over (the fleet's numbers are compared with station grade's, not with
#: truths; a longer run only took longer to grade)
RUN_S = 200.0


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A folder of runs: three good ones, a corrupt file, and a run too short to grade."""
    root = tmp_path_factory.mktemp("fleet")
    profile = write_profile(root, profile_text(warmup_s=10.0))
    folder = root / "runs"
    for k in range(GOOD):
        write_run(
            folder / f"run{k}.h5",
            units=2,
            duration_s=RUN_S,
            seed=k + 1,
            profile=profile,
            lot=f"L{k % 2}",
            start_utc=f"2026-05-0{k + 1}T08:00:00Z",
        )
    (folder / "corrupt.h5").write_bytes(b"this is no HDF5 file" * 50)
    write_run(folder / "short.h5", units=1, duration_s=60.0, seed=9, profile=profile)
    return folder, profile


@pytest.fixture(scope="module")
def scheduler() -> Iterator[str]:
    """The local cluster ``station fleet`` starts by default (two worker processes here),
    reached by its scheduler's address: one cluster for the module's tests."""
    with cluster_client(LOCAL, 2) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        yield client.scheduler.address


def _worker_settings() -> dict[str, object]:
    import os

    import dask

    settings: dict[str, object] = {
        k: os.environ.get(k) for k in ("MALLOC_TRIM_THRESHOLD_", "OMP_NUM_THREADS")
    }
    settings["profiler"] = dask.config.get("distributed.worker.profile.enabled")
    return settings


@pytest.mark.slow
def test_local_workers_keep_mallocs_own_threshold_and_no_profiler(scheduler) -> None:
    """The local workers start without Dask's MALLOC_TRIM_THRESHOLD_ (it makes every large
    array a fresh mmap: 8 % more CPU per unit graded) and without its sampling profiler,
    and keep one thread each."""
    from distributed import Client

    with Client(scheduler) as client:
        settings = list(client.run(_worker_settings).values())
    expected = {"MALLOC_TRIM_THRESHOLD_": None, "OMP_NUM_THREADS": "1", "profiler": False}
    assert settings == [expected] * 2


def _fleet(capsys, *args: str) -> tuple[int, dict]:
    code = main(["fleet", *args, "--json"])
    return code, json.loads(capsys.readouterr().out)


def _without_time(doc: dict) -> dict:
    return {k: v for k, v in doc.items() if k != "graded_utc"}


@pytest.mark.slow
def test_fleet_grade_is_station_grade_file_by_file(runs, scheduler, tmp_path: Path, capsys) -> None:
    folder, _ = runs
    db = tmp_path / "fleet.sqlite"
    code, out = _fleet(capsys, "grade", str(folder), "--scheduler", scheduler, "--db", str(db))
    assert code == 1  # some tasks failed; the others finished
    assert out["tasks"] == 2 * GOOD + 2  # a task per unit, and the corrupt file's listing
    failed = {(f["file"], f["unit"]): f["error"] for f in out["failed"]}
    assert set(failed) == {(str(folder / "corrupt.h5"), ""), (str(folder / "short.h5"), "unit1")}
    assert "not an HDF5 file" in failed[(str(folder / "corrupt.h5"), "")]
    assert "fewer than 1000" in failed[(str(folder / "short.h5"), "unit1")]
    assert [r["run"]["path"] for r in out["runs"]] == [
        str(folder / f"run{k}.h5") for k in range(GOOD)
    ]
    for doc in out["runs"]:
        assert main(["grade", doc["run"]["path"], "--json", "--no-store"]) == 0
        alone = json.loads(capsys.readouterr().out)
        assert _without_time(doc) == _without_time(alone)  # every number, note and verdict
    with ResultsDatabase(db) as results:
        rows = results.gradings()
    assert sorted(r.serial_number for r in rows) == sorted(
        f"SN-{k + 1}-{i + 1}" for k in range(GOOD) for i in range(2)
    )
    assert {r.lot for r in rows} == {"L0", "L1"}


def test_fleet_stores_into_postgresql(
    runs, scheduler, postgres_url: str, capsys, monkeypatch
) -> None:
    folder, profile = runs
    files = [str(folder / "run0.h5"), str(folder / "run1.h5")]
    monkeypatch.setenv("STATION_RESULTS_DB", postgres_url)  # the line's database, no --db
    code, out = _fleet(capsys, "grade", *files, "--profile", str(profile), "--scheduler", scheduler)
    assert code == 0 and out["tasks"] == 4 and out["failed"] == []
    with ResultsDatabase(postgres_url) as results:
        rows = results.gradings()
        assert len(rows) == 4 and {r.run_path for r in rows} == {
            str(Path(f).resolve()) for f in files
        }
        assert all(len(results.figures(r.id)) == 4 for r in rows)


def test_fleet_report_writes_files_from_the_driver(runs, scheduler, tmp_path: Path, capsys) -> None:
    folder, _ = runs
    db, out_dir = tmp_path / "r.sqlite", tmp_path / "reports"
    code, out = _fleet(
        capsys,
        "report",
        str(folder / "run1.h5"),
        "--scheduler",
        scheduler,
        "--db",
        str(db),
        "--format",
        "json",
        "--format",
        "csv",
        "--out",
        str(out_dir),
    )
    assert code == 0 and len(out["reports"]) == 2 and out["tasks"] == 3  # two units, one report
    report = json.loads((out_dir / "run1_TEST.json").read_text())
    assert [u["serial_number"] for u in report["units"]] == ["SN-2-1", "SN-2-2"]
    with ResultsDatabase(db) as results:
        rows = results.gradings()
        assert len(rows) == 2
        assert sorted(r["format"] for r in results.reports(rows[0].id)) == ["csv", "json"]


def test_fleet_report_lists_the_gmwm_terms(keyed, scheduler, tmp_path: Path) -> None:  # noqa: F811
    """Where the profile asks for the GMWM, the fleet's report carries it as ``station
    report`` does: in ``--json`` (``"gmwm"`` per axis), the sheets, and the text lines."""
    from station.commands.fleet import format_fleet

    record, profile, doc = keyed
    g = doc["units"][0]["axes"]["x"]["gmwm"]
    result = fleet(FleetRequest("report", (str(record),), profile=str(profile),
                                scheduler=scheduler, store=False, formats=("json",),
                                out=tmp_path))
    carried = result.as_json()["runs"][0]["units"][0]["axes"]["x"]["gmwm"]  # type: ignore[index]
    assert carried["model"] == g["model"] and carried["params"] == pytest.approx(g["params"])
    sheet = json.loads((tmp_path / "gm_TEST.json").read_text())
    assert sheet["units"][0]["axes"]["x"]["gmwm"]["params"] == pytest.approx(g["params"])
    text = format_fleet(result, None)
    assert f"GMWM x: model {g['model']}" in text and "p-value" in text
    line = next(ln for ln in text.splitlines() if "Gauss-Markov correlation time" in ln)
    assert f"{g['params']['gm_tau_s']:.4g} s [" in line
    assert "white noise" in text and "(Allan: " in text and "ARW read-off" in text


def test_fleet_analyze_is_station_analyze_unit_by_unit(runs, scheduler, capsys) -> None:
    folder, _ = runs
    run = str(folder / "run1.h5")
    code, out = _fleet(capsys, "analyze", run, "--scheduler", scheduler)
    assert code == 0 and out["tasks"] == 2 and len(out["runs"]) == 2
    assert main(["analyze", run, "--unit", "unit2", "--json"]) == 0
    alone = json.loads(capsys.readouterr().out)
    assert out["runs"][1] == alone


def test_bad_input_is_refused_before_any_cluster(runs, tmp_path: Path, capsys) -> None:
    folder, _ = runs
    assert main(["fleet", "grade", str(tmp_path / "nothing-here")]) == 2
    assert main(["fleet", "grade", str(folder), "--workers", "0"]) == 2
    assert main(["fleet", "grade", str(folder), "--profile", "no-such-profile"]) == 2
    assert (
        main(["fleet", "grade", str(folder), "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"])
        == 2
    )
    err = capsys.readouterr().err
    assert "no such file or directory" in err and "at least 1" in err and "local cluster" in err
    assert run_files([folder, folder / "run0.h5"]).count(str(folder / "run0.h5")) == 1


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_only_on_a_terminal() -> None:
    p = FleetProgress(done=16, total=64, elapsed_s=30.0, failed=1)
    assert p.eta_s == pytest.approx(90.0)
    line = ProgressBar.line(p, width=8)
    assert line == "[##......] 16/64 tasks, 1 failed, 0:00:30 elapsed, ETA 0:01:30"
    tty, pipe = _Terminal(), io.StringIO()
    for stream in (tty, pipe):
        bar = ProgressBar(stream, refresh_s=0.0)
        bar(p)
        bar(FleetProgress(64, 64, 120.0))
        bar.close()
    assert "\r" in tty.getvalue() and "64/64 tasks" in tty.getvalue()
    assert pipe.getvalue() == ""


def _exit_worker(tries: str) -> None:
    import os

    with open(tries, "a") as log:
        log.write(f"{os.getpid()}\n")
    os._exit(9)  # what the kernel's OOM killer does to a worker, from inside


@pytest.mark.slow
def test_a_killed_worker_loses_no_unit_and_a_task_that_kills_twice_is_listed(
    runs, scheduler, tmp_path: Path
) -> None:
    """A worker killed while it grades (the OOM killer, an operator) costs its tasks one
    retry on a fresh worker and nothing else: every run graded as without the kill. A task
    whose worker dies on every try is reported as such, once it has had a second worker.
    On the module's cluster: its nannies start fresh workers for the tests after this one."""
    from distributed import Client

    folder, _ = runs
    files = tuple(str(folder / f"run{k}.h5") for k in range(GOOD))
    with Client(scheduler) as client:
        request = FleetRequest("grade", files, scheduler=scheduler, store=False)
        unharmed = fleet(request)
        killed: list[str] = []

        def kill_a_busy_worker(progress: FleetProgress) -> None:
            if killed or progress.done == 0:
                return
            busy = sorted(w for w, keys in client.processing().items() if keys)
            if busy:
                os.kill(client.run(os.getpid, workers=busy[:1])[busy[0]], signal.SIGKILL)
                killed.append(busy[0])

        result = fleet(request, progress=kill_a_busy_worker)
        assert killed, "no worker was busy when the first task came back"
        assert result.failed == () and result.tasks == unharmed.tasks == 2 * GOOD
        assert [_without_time(r.as_json()) for r in result.runs] == [
            _without_time(r.as_json()) for r in unharmed.runs
        ]

        tries = tmp_path / "tries.txt"
        deaths = client.submit(_exit_worker, str(tries), pure=False)
        with pytest.raises(KilledWorker) as lost:
            deaths.result(timeout=120)
        assert len(set(tries.read_text().split())) == 2  # two workers, then no more
        assert "died on each of 2 tries" in lost_task_text(lost.value)
        client.wait_for_workers(2, timeout=60)  # the nannies start fresh workers


@pytest.mark.slow
def test_postgresql_stopped_mid_fleet_then_run_again_stores_one_row_per_run(
    scheduler, postgres_server, postgres_url: str, tmp_path: Path, capsys
) -> None:
    """Issue 29: the server stopped once two runs are stored. The fleet goes on, tries the
    other stores with back-off, and lists each run not stored (exit 1); run again with the
    server back, it stores those and nothing twice: one grading per run. A server back
    within --db-retry loses nothing."""
    profile = write_profile(tmp_path, profile_text(warmup_s=10.0))
    files = [str(write_run(tmp_path / f"r{k}.h5", units=1, seed=20 + k, profile=profile,
                           duration_s=RUN_S, start_utc=f"2026-05-0{k + 1}T08:00:00Z"))
             for k in range(6)]
    stopped: list[int] = []

    def stop_after_two(p: FleetProgress) -> None:
        if p.done == 2 and not stopped:
            stopped.append(p.done)
            postgres_server.stop()

    request = FleetRequest("grade", tuple(files), scheduler=scheduler, db=postgres_url,
                           db_retry_s=1.0)
    try:
        result = fleet(request, stop_after_two)
    finally:
        postgres_server.start()
    assert stopped and result.failed == () and len(result.runs) == 6 and not result.complete
    doc = result.as_json()
    assert len(doc["not_stored"]) == 4 and result.stored == 2
    assert {n["file"] for n in doc["not_stored"]} < set(files)  # those graded after the stop
    assert all(n["units"] == ["unit1"] and postgres_url.rsplit("/", 1)[1] in n["error"]
               for n in doc["not_stored"])
    code, out = _fleet(capsys, "grade", *files, "--scheduler", scheduler, "--db", postgres_url)
    assert code == 0 and out["not_stored"] == [] and out["failed"] == []
    with ResultsDatabase(postgres_url) as results:
        rows = results.gradings()
    assert sorted(r.run_path for r in rows) == sorted(str(Path(f).resolve()) for f in files)
    assert {r.revision for r in rows} == {1}

    back = postgres_server.create_database()  # a short outage: the fleet waits it out
    timer: list[threading.Timer] = []

    def stop_briefly(p: FleetProgress) -> None:
        if p.done == 2 and not timer:
            postgres_server.stop()
            timer.append(threading.Timer(1.0, postgres_server.start))
            timer[0].start()

    try:
        result = fleet(replace(request, db=back, db_retry_s=60.0), stop_briefly)
    finally:
        timer[0].join() if timer else None
    assert result.complete and result.stored == 6
