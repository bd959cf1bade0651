"""``record``: a run of one or more gyros into an HDF5 run file, as the CLI and the TUI ask
for it (:class:`RecordRequest`).

The CLI records in its own process (:func:`record`); the TUI starts the same recorder as a
detached process (:func:`start_recording`, :mod:`station.services.recorder_process`) and
checks each unit before (:func:`check_unit`). Both build a :class:`RecordRequest`, and the
recorder's configuration comes from it in one place (:func:`run_config`).
"""

from __future__ import annotations

import json
import os
import signal
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path
from types import FrameType
from typing import Any, Literal, Protocol

from devices.protocols import DeviceDescription
from devices.url_text import is_simulated, with_keys
from station.errors import Problem, RunConfigurationError, StationError, UsageError
from station.model.bench import load_bench
from station.model.documents import RunStop, Subscriber
from station.model.durations import parse_duration
from station.model.profiles import load_profile
from station.model.runs import RunMetadata
from station.recording.recorder import Recorder, RunConfig
from station.recording.unit_process import cpu_cores

#: The simulated unit a set-up adds when the profile names no simulation: a VG951 FOG at
#: 10 Hz.
DEFAULT_SIM_URL = "sim+serial://VG951?protocol=stim300&rate=10"
#: Stop reasons of a run that ended early on a fault: disk space, a failed write, the
#: output folder or file removed, a unit's device (or its process) lost.
EARLY_STOPS = ("disk full", "write error", "output lost", "device lost")
#: Exit status of ``station record`` when the run stopped early on such a fault (the
#: file, where it still exists, holds every sample up to its last flush); 2 stays for
#: input the command refused before recording.
EXIT_RUN_FAULT = 3


@dataclass(frozen=True)
class RecordRequest:
    """What to record: the arguments of ``station record`` and of the TUI's set-up screen.

    Attributes
    ----------
    units : tuple of str
        Device URLs, one per unit (empty: the profile's ``transport.url``).
    duration : str or None
        Run length as typed (``12h``, ``1h30m``, ``90s``); None: the profile's.
    out : Path
        A folder (a new ``run-<UTC>-<id>.h5`` goes in it) or a ``.h5`` path.
    profile : str or None
        Product profile (name or TOML path); required for real hardware.
    operator, lot : str
        Run metadata.
    bench : str or None
        Bench file (latitude, axis directions): kept in the run file; simulated units
        add the Earth rate.
    flush_interval_s : float
        Longest time between file flushes, s (in (0, 1]).
    reserve_mb : float or None
        Stop cleanly when less than this can still be written, MB (None: 8 MB + 10 s).
    """

    units: tuple[str, ...] = ()
    duration: str | None = None
    out: Path = Path("runs")
    profile: str | None = None
    operator: str = ""
    lot: str = ""
    bench: str | None = None
    flush_interval_s: float = 0.5
    reserve_mb: float | None = None


def run_config(request: RecordRequest) -> RunConfig:
    """The recorder's configuration for ``request`` (profile and bench loaded, duration
    parsed).

    Raises
    ------
    UsageError
        No duration anywhere, a bad duration or flush interval.
    ProfileError, BenchError
        A profile or bench file that cannot be used.
    """
    profile = load_profile(request.profile) if request.profile is not None else None
    urls = list(request.units)
    if not urls and profile is not None and profile.transport.get("url"):
        urls = [str(profile.transport["url"])]
    if request.duration is not None:
        duration_s = parse_duration(request.duration)
    elif profile is not None:
        duration_s = profile.duration_s
    else:
        raise UsageError("give --duration (e.g. 12h) or a --profile that has one")
    if not 0 < request.flush_interval_s <= 1.0:
        raise UsageError("--flush-interval must be in (0, 1] s")
    if request.reserve_mb is not None and not 0 <= request.reserve_mb < float("inf"):
        raise UsageError(f"--reserve-mb {request.reserve_mb:g}: give 0 MB or more")
    reserve = None if request.reserve_mb is None else int(request.reserve_mb * 1e6)
    bench_json = ""
    if request.bench is not None:
        bench = load_bench(request.bench)
        urls, bench_json = [bench.sim_url(u) for u in urls], bench.as_json()
    return RunConfig(tuple(urls), duration_s, request.out, profile=profile,
                     metadata=RunMetadata(operator=request.operator, lot=request.lot,
                                          bench=bench_json),
                     flush_interval_s=request.flush_interval_s, reserve_bytes=reserve)


def recorder_arguments(request: RecordRequest) -> list[str]:
    """The ``station record`` arguments of ``request`` (how a detached recorder gets it)."""
    args = ["--out", str(request.out), "--quiet"]
    if request.duration is not None:
        args += ["--duration", request.duration]
    if request.profile:
        args += ["--profile", request.profile]
    for url in request.units:
        args += ["--unit", url]
    for option, value in (("--operator", request.operator), ("--lot", request.lot),
                          ("--bench", request.bench)):
        if value:
            args += [option, value]
    return args


def simulated_unit_url(base: str, seed: int, warp: float) -> str:
    """``base`` (a ``sim+`` URL) with its ``seed`` (the serial number SIM-<seed>) and
    ``warp`` set; a base that is not simulated gives :data:`DEFAULT_SIM_URL`'s unit."""
    if not is_simulated(base):
        base = DEFAULT_SIM_URL
    return with_keys(base, {"seed": str(seed), "warp": f"{warp:g}"})


# -- checking units --------------------------------------------------------------------

def check_units(request: RecordRequest) -> RecorderStatus:
    """Open every unit of ``request`` (each in a process of its own, as the recorder does),
    check it against the profile, wait for its first sample and release it; nothing is
    written. ``checked`` with each unit's description, or ``refused``/``error`` with the
    problems found."""
    try:
        units = Recorder(run_config(request)).check_units()
    except RunConfigurationError as exc:
        return RecorderStatus("refused", problems=exc.problems)
    except StationError as exc:
        return RecorderStatus("error", problems=(Problem(str(exc)),))
    return RecorderStatus("checked", units=units)


# -- recording in this process ---------------------------------------------------------

@dataclass(frozen=True)
class UnitSummary:
    """What one unit's part of the file holds at the end (``--json-summary``)."""

    unit: str
    samples_recorded: int
    samples_missing_declared: int
    samples_missing_low: int
    samples_missing_high: int
    samples_sent: int | None
    gaps: int
    crc_errors: int
    reconnects: int
    file: str


@dataclass(frozen=True)
class UnitCpu:
    """CPU time of one unit's process (its reader, and its simulator), s."""

    unit_id: str
    cpu_s: float
    reader_cpu_s: float


@dataclass(frozen=True)
class RecordOutcome:
    """How a run ended: the stop document, each unit's summary and errors, the CPU used,
    and whether the file could be written and closed.

    Attributes
    ----------
    write_failure : str
        Why writing failed ("" if it did not): the run stopped, what was committed is
        intact.
    uncommitted : dict
        Per unit, samples received or declared missing after the failure, not written.
    close_failed : bool
        HDF5 could not close the file (``station recover`` closes it).
    last_flush_utc : str
        When the last completed flush took its cut ("" if none did): every sample
        received before it is in the file.
    """

    path: Path
    stop: RunStop
    units: tuple[UnitSummary, ...]
    unit_errors: tuple[tuple[str, str], ...]
    cpu: tuple[UnitCpu, ...]
    wall_s: float
    engine_cpu_s: float
    write_failure: str = ""
    uncommitted: tuple[tuple[str, int], ...] = ()
    close_failed: bool = False
    last_flush_utc: str = ""

    @property
    def stopped_early(self) -> bool:
        """A fault stopped the run before its end (disk, output folder, a device)."""
        return self.stop.reason.startswith(EARLY_STOPS)

    @property
    def exit_status(self) -> int:
        """:data:`EXIT_RUN_FAULT` when a fault stopped the run, a unit ended on an error
        or the file is not whole, else 0."""
        faulty = self.write_failure or self.unit_errors or self.stopped_early
        return EXIT_RUN_FAULT if faulty or self.close_failed else 0

    def fault_message(self) -> str:
        """One line for the operator when a fault stopped the run ("" otherwise): what
        happened, what the file kept (samples per unit up to its last flush), and what
        to do."""
        if not (self.exit_status or self.close_failed):
            return ""
        what = self.write_failure or self.stop.reason
        errors = "; ".join(f"{unit_id} ended on an error: {error}"
                           for unit_id, error in self.unit_errors)
        if errors and errors not in what:
            what = f"{what}; {errors}" if self.write_failure else errors
        kept = ", ".join(f"{t.unit_id} {u.samples_recorded} samples"
                         for t, u in zip(self.stop.totals, self.units, strict=True))
        flushed = f" ({self.last_flush_utc})" if self.last_flush_utc else ""
        lost = ", ".join(f"{unit_id} {n}" for unit_id, n in self.uncommitted)
        after = (f" (samples received or declared missing after that, not written: {lost})"
                 if lost else "")
        if not self.path.exists():
            return (f"the run stopped: {what}. {self.path} was removed with it, and what it "
                    f"held up to its last flush{flushed} ({kept}) is lost: find what removed "
                    f"it and record again into a folder that is kept")
        full = self.stop.reason.startswith("disk full")
        todo = (("free some space, then " if full else "")
                + f"run `station recover {self.path}` to close the file" if self.close_failed
                else ("free some space before the next run; " if full else "")
                + "the file is closed: grade or analyze it as it is")
        return (f"the run stopped: {what}. {self.path} keeps every sample up to its last "
                f"flush{flushed}: {kept}{after}; {todo}")

    def cpu_lines(self) -> list[str]:
        """CPU time per unit and of the recorder's own process (documents, HDF5), as
        shares of one core over the run's wall time."""
        wall = max(self.wall_s, 1e-9)
        lines = [f"CPU over {wall:.1f} s of wall time ({cpu_cores()} cores here):"]
        for c in self.cpu:
            sim = max(0.0, c.cpu_s - c.reader_cpu_s)
            lines.append(f"  {c.unit_id}: {c.cpu_s:.2f} s = {c.cpu_s / wall:.0%} of a core "
                         f"(reading {c.reader_cpu_s:.2f} s, simulator and the rest "
                         f"{sim:.2f} s)")
        lines.append(f"  recorder process (documents, HDF5 writer): {self.engine_cpu_s:.2f} "
                     f"s = {self.engine_cpu_s / wall:.0%} of a core")
        return lines


class Stoppable(Protocol):
    """What Ctrl-C stops cleanly: a recorder, a test sequence."""

    def request_stop(self, reason: str) -> None: ...


@contextmanager
def stop_on_signals(recorder: Stoppable) -> Iterator[None]:
    """Turn Ctrl-C and SIGTERM into a clean stop of ``recorder`` while inside."""
    reasons = {signal.SIGINT: "interrupted (Ctrl-C)", signal.SIGTERM: "terminated (SIGTERM)"}

    def handler(signum: int, frame: FrameType | None) -> None:
        recorder.request_stop(reasons[signal.Signals(signum)])

    old = {s: signal.signal(s, handler) for s in reasons}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def _outcome(recorder: Recorder, stop: RunStop) -> RecordOutcome:
    writer = recorder.writer
    assert writer is not None
    units = []
    for t in stop.totals:
        c = writer.committed[t.unit_id]
        units.append(UnitSummary(t.url, c.samples, c.missing, c.missing_low, c.missing_high,
                                 t.samples_sent, c.gaps, c.crc_errors, c.reconnects,
                                 str(recorder.path)))
    failure = "" if writer.failed is None else str(writer.failed)
    return RecordOutcome(
        recorder.path, stop, tuple(units),
        tuple((w.unit_id, w.error) for w in recorder.workers if w.error),
        tuple(UnitCpu(t.unit_id, t.cpu_s, t.reader_cpu_s) for t in stop.totals),
        recorder.wall_s, recorder.engine_cpu_s, failure,
        tuple((t.unit_id, writer.uncommitted(t.unit_id)) for t in stop.totals)
        if failure else (), writer.close_failed, writer.last_flush_utc)


def record(request: RecordRequest, subscribers: Sequence[Subscriber] = (), *,
           status: Path | None = None,
           on_start: Callable[[Path, int], None] | None = None) -> RecordOutcome:
    """Prepare (refusing a bad configuration), record until the duration, Ctrl-C or
    SIGTERM (a clean stop; call from the main thread), and say how it ended.

    ``subscribers`` see every document (a progress line); ``on_start(path, n_units)``
    hears when recording starts; ``status`` names a JSON file the recorder keeps its
    :class:`RecorderStatus` in (how a detached recorder tells its starter that it
    records, or why it did not start).

    Raises
    ------
    RunConfigurationError
        Every problem found before anything was written.
    StationError
        A request that cannot be used (profile, bench, duration).
    """
    try:
        recorder = Recorder(run_config(request), subscribers)
        with stop_on_signals(recorder):
            recorder.prepare()
            write_status(status, RecorderStatus("recording", str(recorder.path)))
            if on_start is not None:
                on_start(recorder.path, len(recorder.workers))
            stop = recorder.run()
    except RunConfigurationError as exc:
        write_status(status, RecorderStatus("refused", problems=exc.problems))
        raise
    except StationError as exc:
        write_status(status, RecorderStatus("error", problems=(Problem(str(exc)),)))
        raise
    return _outcome(recorder, stop)


# -- what a detached recorder tells its starter ----------------------------------------

@dataclass(frozen=True)
class RecorderStatus:
    """A recorder's state as it writes it for whoever started it: ``recording`` (into
    ``file``), ``checked`` (``units``: each unit's description, nothing recorded),
    ``refused`` (``problems``: each unit's or setting's) or ``error``."""

    state: Literal["recording", "checked", "refused", "error"]
    file: str = ""
    problems: tuple[Problem, ...] = ()
    units: tuple[DeviceDescription, ...] = ()

    def as_json(self) -> dict[str, Any]:
        """The status document."""
        return {"state": self.state, "file": self.file,
                "problems": [asdict(p) for p in self.problems],
                "units": [asdict(u) for u in self.units]}

    @classmethod
    def from_json(cls, doc: dict[str, Any]) -> RecorderStatus:
        """The status a document holds.

        Raises
        ------
        ValueError
            Not a status document.
        """
        state = doc.get("state")
        if state not in ("recording", "checked", "refused", "error"):
            raise ValueError(f"not a recorder status: state {state!r}")
        units = tuple(DeviceDescription(**{**u, "axes": tuple(u["axes"]),
                                           "accel_axes": tuple(u.get("accel_axes", ())),
                                           "settings": tuple(map(tuple, u["settings"]))})
                      for u in doc.get("units", []))
        return cls(state, str(doc.get("file", "")),
                   tuple(Problem(**p) for p in doc.get("problems", [])), units)


def write_status(path: Path | None, status: RecorderStatus) -> None:
    """Replace the status document at ``path`` (atomically; nothing when None)."""
    if path is None:
        return
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(status.as_json()), encoding="utf-8")
    os.replace(tmp, path)


def read_status(path: Path) -> RecorderStatus | None:
    """The status document at ``path``, None while there is none (or it does not read)."""
    try:
        return RecorderStatus.from_json(json.loads(path.read_text(encoding="utf-8")))
    except (OSError, ValueError, TypeError, KeyError):
        return None
