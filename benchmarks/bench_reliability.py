"""Reliability: kill -9, a full disk, the fault matrix and damaged files, N times each.

Cases (each repeated ``--trials`` times, on this machine as it is loaded):

* ``kill -9``: a real recorder (one simulated Xsens over a pty, real time) killed with
  SIGKILL at a moment drawn uniformly from 0.5 s before its run file appears to 3 s
  after. Data lost: from the newest committed sample to the kill. A file left must open,
  hold the simulated signal, and ``station recover`` must close it.
* ``disk full (file size limit)``: the recorder's file size limit (RLIMIT_FSIZE) set
  to its file's size plus 20-500 kB while it runs, with no reserve (``--reserve-mb 0``)
  so that a write fails.
* ``disk full (small file system)``: where this process may mount one, a 24 MB tmpfs
  that another writer fills while the recorder runs (default reserve).
* ``output folder removed``: the recorder's output folder removed 0.2-2 s after its run
  file appears: the run must stop with exit status 3 and one line that says so.
* ``device lost``: the unit's process (its reader and simulated device) killed with
  SIGKILL 0.2-2 s after the file appears: exit status 3, one line, the file closed with
  the reason ``device lost`` and the simulated signal in it.
* ``recorder gone (watch)``: a recorder killed 0.2-2 s after its file appears; data lost
  as for ``kill -9``, and ``station watch --json --once`` must say ``recorder_gone`` once
  the flush interval plus 2 s have passed (the figure: seconds from the kill until it does).
* ``fault matrix warp 1`` / ``warp 4``: five units over five transports with drops,
  corruption, outages and stalls (``tests/test_recorder_books.py``).
* ``fault matrix overload``: six units over every protocol while two processes spin
  and every unit's process is frozen for 0.3-0.7 s again and again from its start
  (``tests/test_recorder_overload.py``).
* ``damaged files``: copies of a run file cut short and with single bits flipped, read by
  every reader (``tests/damage_helpers.py``).
* ``damaged chunks``: one byte flipped in a chunk (drawn per trial) of each dataset of a
  unit of a closed run file (6000 samples a unit, 12 chunks), and a ``station simulate``
  run (60 s at 100 Hz) cut to half its length; each recovered. Printed per damage:
  samples kept of the samples committed, summed over the trials.
* ``sequence kill -9 + resume``: the issue 29 temperature sequence (25 degC, power on,
  record; 40, 10, 25 degC plateaus; ``tests/sequence_kill.py``) killed with SIGKILL in a
  step drawn over every step kind (set_chamber, wait_stable, power_on, record, power_off;
  which of them and how far into it drawn too) and resumed by the same command. Per
  trial: the step, the switch-ons counted (1 asked for), the turn-on repeatability (none
  uninterrupted), the temperature points (4), the coefficient and whether its interval
  covers the truth, the samples declared missing. "bad errors" counts trials whose
  figures differ from what the sequence measured: switch-ons other than the profile's one
  plus each a resume made (a unit switched on again draws a new turn-on bias: a
  switch-on of its own), a summary counting other cycles than the grade, points other
  than 4, an interval that misses the truth.
* ``sequence kill -9 in every step kind``: the same, one kill in each step kind per
  trial (which of its steps and how far into it drawn).
* ``raw CAN frames across outages``: a raw CAN unit with a frame per axis (4-bit counter,
  500 Hz, warp 5) dropping and corrupting 2 % of its frames, silent for 4 s (2000 samples,
  whole counter wraps) every 1 s, read until 1800 samples came
  (``tests/devices/test_can_devices.py``). Books balanced: the samples declared missing are
  exactly those the simulated node lost; errors: a sample the node lost returned as a
  sample (frames of two samples a wrap apart joined).
* ``STIM300 outages (counter at 2000 Hz)`` / ``KVH DSP-1750 outages (sequence 0..127)``:
  a simulated STIM300 at 500 Hz built from its data sheet (TS1524 7.5.2.2.18: the 8-bit
  counter counts the 2000 Hz internal samples, so it steps by 4 and wraps every 0.128 s)
  at warp 5 and a simulated DSP-1750 at 1000 Hz (sequence 0..127, one per message: a wrap
  every 0.128 s too) at warp 2, cut off for 7 s every 0.5 s, read until 1500 samples came. Each
  gap's declared interval is checked against the samples the simulator really lost (each
  received sample found in the simulated signal, not by its counter:
  ``tests/devices/helpers.py`` ``gap_truths``). Books balanced: trials in which every
  interval held what was sent; printed per case: gaps held of gaps, and the median width
  (samples) of the intervals of the gaps longer than a counter wrap.
* ``results database outage``: 12 gradings stored through the station's store queue into
  a real PostgreSQL server (``tests/postgres_server.py``) stopped after a random 0-6 of
  them for a random 0.5-4 s; then the 12 stored again (a fleet run again). Data lost: the
  longest a store waited for the server, s; books balanced: exactly one row per grading
  (none lost, none twice); errors: a grading listed as not stored (the outage is shorter
  than the 30 s retry bound).

Printed per case: trials, data lost (max, s), books balanced, errors that were not
one clear line (a traceback, several lines, a crash, a hang, a file that does not open,
a fault stop without exit status 3), and how long after a kill ``station watch`` said
the recorder is gone (max, s).

Run::

    python -m benchmarks.bench_reliability --trials 20
"""

from __future__ import annotations

import argparse
import os
import random
import resource
import shutil
import signal
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

from benchmarks.reliability_case import Case, one_line
from benchmarks.reliability_sequences import sequence_every_kind_trial, sequence_trial
from devices.codecs.can_frame import PER_AXIS_LAYOUT
from devices.urls import open_device
from station.cli import main as station_main
from station.commands.watch import status_json
from station.model.documents import UnitTotals
from station.recording.recorder import Recorder, RunConfig
from station.services.record import EXIT_RUN_FAULT
from station.storage.hdf5 import read_run
from station.storage.hdf5_recover import recover_run
from tests.damage_helpers import damaged_copies, flip_in_chunks, sweep
from tests.devices.helpers import check_accounting, collect, device_index, gap_truths
from tests.test_damaged_runs import _write_run
from tests.test_recorder_books import UNITS, _at_warp
from tests.test_recorder_helpers import (
    check_unit_against_signal,
    child_pids,
    data_lost_s,
    start_recorder,
    summaries,
    wait_for_file,
)
from tests.test_recorder_overload import record_overloaded

URL = "sim+serial://STIM300?protocol=xbus&rate=500&seed={seed}"


def kill_trial(case: Case, tmp: Path, rng: random.Random) -> None:
    folder = tmp / f"kill{case.trials}"
    proc = start_recorder("--unit", URL.format(seed=case.trials + 1), "--duration", "1h",
                          "--out", str(folder), "--quiet")
    after = rng.uniform(-0.5, 3.0)
    t_start = time.monotonic()
    appeared = None
    while True:
        files = list(folder.glob("*.h5"))
        if files and appeared is None:
            appeared = time.monotonic()
        due = appeared + after if appeared is not None else None
        if due is not None and time.monotonic() >= due:
            break
        if appeared is None and after < 0 and time.monotonic() - t_start > 3.0 + after:
            break  # a kill before the file: at a moment of the start-up
        time.sleep(0.002)
    os.kill(proc.pid, signal.SIGKILL)
    killed_at = time.time()
    proc.communicate(timeout=30)
    case.trials += 1
    files = list(folder.glob("*.h5"))
    if not files:
        return  # killed before the file existed: nothing to lose but the start
    path = files[0]
    try:
        run = read_run(path)
        if run.units[0].record.n_samples:
            check_unit_against_signal(path, "unit1", URL.format(seed=case.trials))
        case.lost_s.append(data_lost_s(path, killed_at))
        recover_run(path)
        read_run(path)
    except Exception as exc:  # noqa: BLE001 - every failure is counted
        case.bad_errors.append(f"{path}: {type(exc).__name__}: {exc}"[:300])


def _books_from_summary(case: Case, stdout: str, stderr: str) -> None:
    """Books of a disk-full stop: recorded + declared + what could not be written."""
    unwritten = {}
    if "not written:" in stderr:
        part = stderr.split("not written:")[1].split(")")[0]
        for item in part.split(","):
            uid, count = item.split()
            unwritten[uid] = int(count)
    for i, obj in enumerate(summaries(stdout)):
        extra = unwritten.get(f"unit{i + 1}", 0)
        case.books_checked += 1
        case.balanced += (obj["samples_recorded"] + obj["samples_missing_low"] + extra
                          <= obj["samples_sent"] <=
                          obj["samples_recorded"] + obj["samples_missing_high"] + extra)


def _disk_full_outcome(case: Case, proc: subprocess.Popen, folder: Path, url: str) -> None:
    stdout, stderr = proc.communicate(timeout=120)
    case.trials += 1
    message = "\n".join(line for line in stderr.splitlines() if not line.startswith("recording"))
    if proc.returncode != EXIT_RUN_FAULT or not one_line(message):
        case.bad_errors.append(f"rc {proc.returncode}: {message[:300]}")
        return
    path = next(folder.glob("*.h5"))
    try:
        if read_run(path).units[0].record.n_samples:  # (the disk may fill before a flush)
            check_unit_against_signal(path, "unit1", url)  # every committed row real data
        _books_from_summary(case, stdout, stderr)
        recover_run(path)
        read_run(path)
    except Exception as exc:  # noqa: BLE001
        case.bad_errors.append(f"{path}: {type(exc).__name__}: {exc}"[:300])


def fsize_trial(case: Case, tmp: Path, rng: random.Random) -> None:
    folder = tmp / f"fsize{case.trials}"
    url = URL.format(seed=100 + case.trials)
    proc = start_recorder("--unit", url, "--duration", "1h", "--out", str(folder),
                          "--quiet", "--json-summary", "--reserve-mb", "0")
    while not list(folder.glob("*.h5")):
        time.sleep(0.01)
    time.sleep(rng.uniform(0.2, 2.0))
    path = next(folder.glob("*.h5"))
    limit = path.stat().st_size + rng.randrange(20_000, 500_000)
    resource.prlimit(proc.pid, resource.RLIMIT_FSIZE, (limit, limit))
    _disk_full_outcome(case, proc, folder, url)


def tmpfs_trial(case: Case, tmp: Path, rng: random.Random) -> None:
    mount = tmp / f"fs{case.trials}"
    mount.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=24m", "tmpfs", str(mount)],
                      capture_output=True, check=False).returncode:
        raise PermissionError("cannot mount a small file system here")
    try:
        url = URL.format(seed=200 + case.trials)
        proc = start_recorder("--unit", url, "--duration", "30s", "--out", str(mount),
                              "--quiet", "--json-summary")
        while not list(mount.glob("*.h5")) and proc.poll() is None:
            time.sleep(0.01)
        time.sleep(rng.uniform(0.2, 3.0))
        with open(mount / "filler", "wb") as fh:  # another program fills the disk
            try:
                while True:
                    fh.write(b"\0" * (1 << 20))
            except OSError:
                pass
        _disk_full_outcome(case, proc, mount, url)
    finally:
        subprocess.run(["umount", "-l", str(mount)], check=False)


def _stopped_by_fault(case: Case, proc: subprocess.Popen, expect: str) -> str:
    """Count a fault stop that is not exit status 3 with one line naming ``expect``."""
    _, stderr = proc.communicate(timeout=120)
    case.trials += 1
    message = "\n".join(line for line in stderr.splitlines() if not line.startswith("recording"))
    if proc.returncode != EXIT_RUN_FAULT or not one_line(message) or expect not in message:
        case.bad_errors.append(f"rc {proc.returncode}: {message[:300]}")
    return message


def _recording(case: Case, tmp: Path, rng: random.Random, name: str) -> tuple:
    folder = tmp / f"{name}{case.trials}" / "out"
    url = URL.format(seed=300 + case.trials)
    proc = start_recorder("--unit", url, "--duration", "1h", "--out", str(folder), "--quiet")
    path = wait_for_file(folder)
    time.sleep(rng.uniform(0.2, 2.0))
    return proc, folder, path, url


def folder_removed_trial(case: Case, tmp: Path, rng: random.Random) -> None:
    proc, folder, _, _ = _recording(case, tmp, rng, "removed")
    shutil.rmtree(folder)
    _stopped_by_fault(case, proc, f"the output folder {folder} was removed")


def device_lost_trial(case: Case, tmp: Path, rng: random.Random) -> None:
    proc, _, path, url = _recording(case, tmp, rng, "device")
    for server in child_pids(proc.pid):
        for unit in child_pids(server):
            os.kill(unit, signal.SIGKILL)
    _stopped_by_fault(case, proc, "unit1 ended on an error")
    try:
        run = read_run(path)
        if not run.stop_reason.startswith("device lost"):
            case.bad_errors.append(f"{path}: stop reason {run.stop_reason}")
        if run.units[0].record.n_samples:
            check_unit_against_signal(path, "unit1", url)
    except Exception as exc:  # noqa: BLE001
        case.bad_errors.append(f"{path}: {type(exc).__name__}: {exc}"[:300])


def gone_trial(case: Case, tmp: Path, rng: random.Random) -> None:
    proc, _, path, _ = _recording(case, tmp, rng, "gone")
    os.kill(proc.pid, signal.SIGKILL)
    killed = time.monotonic()
    killed_at = time.time()
    proc.communicate(timeout=30)
    case.trials += 1
    case.lost_s.append(data_lost_s(path, killed_at))
    while time.monotonic() - killed < 30.0:
        if status_json(path)["recorder_gone"]:
            case.told_after_s.append(time.monotonic() - killed)
            return
        time.sleep(0.1)
    case.bad_errors.append(f"{path}: watch never said the recorder is gone")


def matrix_trial(case: Case, tmp: Path, warp: int) -> None:
    urls = tuple(_at_warp(url, warp, case.trials * 10 + i + 1)
                 for i, url in enumerate(UNITS.values()))
    recorder = Recorder(RunConfig(urls, 8.0 * warp, tmp / f"m{warp}-{case.trials}.h5",
                                  backoff_max_s=0.1))
    stop = recorder.run()
    case.trials += 1
    _tally_books(case, stop.totals)


def _tally_books(case: Case, totals: tuple[UnitTotals, ...]) -> None:
    for t in totals:
        case.books_checked += 1
        sent = t.samples_sent or 0
        case.balanced += (t.samples_recorded + t.samples_missing_low <= sent
                          <= t.samples_recorded + t.samples_missing_high)


def overload_trial(case: Case, tmp: Path) -> None:
    stop = record_overloaded(tmp / f"o-{case.trials}.h5", seed=case.trials * 10 + 1,
                             duration_s=5.0)
    case.trials += 1
    _tally_books(case, stop.totals)


def damaged_trial(case: Case, tmp: Path, rng: random.Random) -> None:
    folder = tmp / f"damaged{case.trials}"
    folder.mkdir()
    original = folder / "run.h5"
    _write_run(original, close=rng.random() < 0.5)
    copies = damaged_copies(original, folder / "copies", flips=20, seed=rng.randrange(10**6),
                            cuts=(0.0, rng.uniform(0.01, 0.99), 0.999))
    outcomes = sweep(original, copies, timeout_s=300.0)
    case.trials += len(copies)
    case.bad_errors += [f"{o.reader} {o.path}: {o.kind} {o.message}" for o in outcomes
                        if not o.ok or o.seconds > 5.0]


def _count_kept(case: Case, damage: str, damaged: Path, out: Path) -> None:
    try:
        result = recover_run(damaged, out=out)
        read_run(result.salvaged_to or damaged)
    except Exception as exc:  # noqa: BLE001 - every failure is counted
        case.bad_errors.append(f"{damage} {damaged}: {type(exc).__name__}: {exc}"[:300])
        return
    tally = case.kept.setdefault(damage, [0, 0])
    tally[0] += sum(result.kept.values())
    tally[1] += sum(result.kept.values()) + sum(result.lost.values())


def chunk_trial(case: Case, tmp: Path, rng: random.Random) -> None:
    folder = tmp / f"chunks{case.trials}"
    folder.mkdir()
    original = folder / "run.h5"
    _write_run(original, close=True)
    for dataset in ("rate", "counter", "receive_time", "status", "temperature", "events"):
        chunk = rng.randrange(1 if dataset == "events" else 12)
        damaged = flip_in_chunks(original, folder / f"{dataset}.h5",
                                 [(f"units/unit1/{dataset}", chunk)])
        _count_kept(case, f"one byte in a {dataset} chunk", damaged, folder / f"{dataset}.rec.h5")
    sim = folder / "sim.h5"
    station_main(["simulate", "--model", "VG951", "--duration", "60s", "--rate", "100",
                  "--seed", str(case.trials + 1), "--quiet", "--out", str(sim)])
    (cut,) = damaged_copies(sim, folder / "cut", flips=0, seed=0, cuts=(0.5,))
    _count_kept(case, "simulated run cut to half", cut, folder / "sim.rec.h5")
    case.trials += 1


_GRADED: list[object] = []


def outage_trial(case: Case, tmp: Path, rng: random.Random) -> None:
    import threading

    from station.evaluation.grading import grade_run
    from station.model.profiles import load_profile
    from station.output.results import ResultsDatabase
    from station.output.results_queue import StoreQueue
    from station.storage.runs import open_run
    from tests.postgres_server import running_server
    from tests.test_grading import make_record, profile_text, write_profile
    from tests.test_results_db import _variant

    if not _GRADED:
        record = make_record(tmp / "unit.csv", n=6_000, seed=11)
        profile = write_profile(tmp, profile_text(warmup_s=10.0))
        _GRADED.append(grade_run(open_run(record), load_profile(profile)))
    graded = _GRADED[0]
    runs = [_variant(graded, f"SN-{k}", "L1", f"2026-05-{k + 1:02d}T08:00:00Z", "A")  # type: ignore[arg-type]
            for k in range(12)]
    stop_after, outage_s = rng.randint(0, 6), rng.uniform(0.5, 4.0)
    with running_server() as server:
        url = server.create_database()
        waited = 0.0
        for rerun in (False, True):
            with StoreQueue(url) as queue:
                queue.open()
                for k, run in enumerate(runs):
                    if k == stop_after and not rerun:
                        server.stop()
                        threading.Timer(outage_s, server.start).start()
                    t0 = time.monotonic()
                    queue.put(f"run{k}", run)
                    waited = max(waited, time.monotonic() - t0)
                t0 = time.monotonic()
                lost = queue.finish()
                waited = max(waited, time.monotonic() - t0)
            case.bad_errors += [f"{n.file}: {n.error}" for n in lost]
        with ResultsDatabase(url) as db:
            rows = db.gradings()
    case.trials += 1
    case.lost_s.append(waited)
    case.books_checked += 1
    case.balanced += len(rows) == len(runs) and {r.revision for r in rows} == {1}


def can_wraps_trial(case: Case, tmp: Path, rng: random.Random) -> None:
    seed = rng.randrange(1 << 16)
    url = (f"sim+can://STIM300?layout=per_axis&rate=500&warp=5&history=100000&seed={seed}"
           "&drop=0.02&corrupt=0.02&disconnect_every_s=1.0&disconnect_for_s=4")
    case.trials += 1
    with open_device(url) as dev:
        dev.source.open()
        got = collect(dev.source, 1800, deadline_s=30)
        core = dev.simulator.core
        offset = device_index(got, core, PER_AXIS_LAYOUT.counter_modulus, atol=1e-6)
        try:
            declared, lost = check_accounting(got, core, offset)
        except AssertionError as exc:
            said = str(exc) or "a sample the node lost returned as a sample"
            case.bad_errors.append(f"seed {seed}: {said}")
            return
    case.books_checked += 1
    case.balanced += declared == lost


def counter_outage_trial(case: Case, rng: random.Random, protocol: str, rate_hz: int,
                         warp: int) -> None:
    """One device cut off for 7 s at a time; every gap's interval against the truth."""
    seed = rng.randrange(1 << 16)
    url = (f"sim+serial://{'STIM300' if protocol == 'stim300' else 'DSP-1750'}?"
           f"protocol={protocol}&rate={rate_hz}&warp={warp}&history=400000&seed={seed}"
           "&disconnect_every_s=0.5&disconnect_for_s=7")
    case.trials += 1
    try:
        with open_device(url) as dev:
            dev.source.open()
            got = collect(dev.source, 1500, deadline_s=90)
            modulus = dev.source.describe().counter_modulus
            truths = gap_truths(got, dev.simulator.core, modulus)
    except AssertionError as exc:
        case.bad_errors.append(f"seed {seed}: {exc}")
        return
    held = sum(t.held for t in truths)
    case.held[0] += held
    case.held[1] += len(truths)
    case.widths += [t.width for t in truths if t.lost > modulus]
    case.books_checked += 1
    case.balanced += held == len(truths)
    case.bad_errors += [f"seed {seed}: {t.lost} lost, declared {t.declared}"
                        for t in truths if not t.held]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=10)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--only", default="", help="run the cases whose name contains this")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    cases = {"kill -9": kill_trial, "disk full (file size limit)": fsize_trial,
             "disk full (small file system)": tmpfs_trial,
             "output folder removed": folder_removed_trial,
             "device lost": device_lost_trial,
             "recorder gone (watch)": gone_trial,
             "fault matrix warp 1": lambda c, t, r: matrix_trial(c, t, 1),
             "fault matrix warp 4": lambda c, t, r: matrix_trial(c, t, 4),
             "fault matrix overload": lambda c, t, r: overload_trial(c, t),
             "damaged files": damaged_trial, "damaged chunks": chunk_trial,
             "sequence kill -9 + resume": sequence_trial,
             "sequence kill -9 in every step kind": sequence_every_kind_trial,
             "results database outage": outage_trial,
             "raw CAN frames across outages": can_wraps_trial,
             "STIM300 outages (counter at 2000 Hz)":
                 lambda c, t, r: counter_outage_trial(c, r, "stim300", 500, 5),
             "KVH DSP-1750 outages (sequence 0..127)":
                 lambda c, t, r: counter_outage_trial(c, r, "kvh1750", 1000, 2)}
    print(f"# bench_reliability: {args.trials} trials per case, seed {args.seed}, "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}")
    print(f"{'case':34s}{'trials':>7s}{'data lost max s':>16s}{'books balanced':>16s}"
          f"{'bad errors':>12s}{'gone told s':>14s}")
    bad: list[str] = []
    for name, trial in cases.items():
        if args.only not in name:
            continue
        case = Case(name)
        with tempfile.TemporaryDirectory() as tmp:
            try:
                for _ in range(args.trials):
                    trial(case, Path(tmp), rng)
            except PermissionError as exc:
                print(f"{name:34s}  skipped: {exc}")
                continue
        print(case.line(), flush=True)
        for damage, (kept, committed) in case.kept.items():
            print(f"  {damage:40s} samples kept {kept} of {committed}")
        if case.held[1]:
            width = f"{statistics.median(case.widths):g}" if case.widths else "-"
            print(f"  intervals held {case.held[0]} of {case.held[1]} gaps; median width "
                  f"{width} samples over the {len(case.widths)} gaps longer than a wrap")
        bad += [f"{name}: {e}" for e in case.bad_errors]
    for line in bad[:20]:
        print("  " + line)
    print(f"# load average at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
