"""Run files being recorded, read as ``station watch`` reads them: each unit's samples, gaps
and newest rates (:func:`status_json`); every run file under some folders, a damaged one
listed with the reason (:func:`runs_in_progress`); the Allan deviation of what a unit has
recorded so far (:func:`live_allan`)."""

from __future__ import annotations

import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from analysis.allan.variance import allan_variance
from station.errors import StationError
from station.storage.hdf5 import (
    open_run_file,
    read_unit,
    run_state,
    text_value,
    unit_counts,
    unit_ids,
)

#: The most samples of a unit the live Allan curve reads (the newest ones), so that a
#: refresh stays fast on a long run.
LIVE_ALLAN_MAX_SAMPLES = 200_000
#: Held while a run file is read. HDF5 opens a file once per process and shares it among
#: the handles of every thread: a second reader's SWMR refresh of one dataset while the
#: first reads the committed count and then the rows left the first with a count ahead of
#: the rows it could see (an IndexError, 112 of 120 requests with 8 threads); one reader at
#: a time sees the file as one writer's flush left it.
RUN_FILE_READ = threading.Lock()


def status_json(path: Path) -> dict[str, object]:
    """The run's state and one object per unit (rates in deg/s), from its committed data;
    the newest rates and their mean are those of the valid samples (``status`` 0)."""
    # here: the recorder's module imports the device libraries, which ``station watch
    # --help`` does not need
    from station.services.recorder_process import run_file_state

    with RUN_FILE_READ, open_run_file(path) as f:
        state = run_state(f)
        meta = {k: text_value(f.attrs.get(k, "")) for k in ("lot", "operator", "start_utc")}
        planned = float(f.attrs.get("duration_requested_s", 0.0) or 0.0) or None
        units: list[dict[str, object]] = []
        for uid in unit_ids(f):
            c = unit_counts(f, uid)
            rate_hz = float(f["units"][uid].attrs["sample_rate_hz"])
            tail = read_unit(f, uid, start=max(0, c.samples_recorded - max(1, round(rate_hz))))
            valid = tail.valid  # the samples the device says are good (status 0)
            rates = tail.rate_deg_s[valid]
            accel = None if tail.accel_m_s2 is None else tail.accel_m_s2[valid]
            has = bool(len(rates))
            attrs = f["units"][uid].attrs
            units.append({
                "unit": uid, "model": text_value(attrs.get("model", "")),
                "serial_number": text_value(attrs.get("serial_number", "")),
                **_progress(c.last_time_s + 1.0 / rate_hz if c.samples_recorded else 0.0,
                            planned, float(attrs.get("time_warp", 1.0)),
                            state["state"]),
                "samples_recorded": c.samples_recorded, "sample_rate_hz": rate_hz,
                "t_s": round(c.last_time_s, 3), "gaps": c.gaps,
                "samples_missing_declared": c.samples_missing_declared,
                "crc_errors": c.crc_errors, "reconnects": c.reconnects,
                "newest_deg_s": rates[-1].tolist() if has else None,
                "mean_1s_deg_s": np.mean(rates, axis=0).tolist() if has else None,
                "newest_accel_m_s2": accel[-1].tolist() if has and accel is not None else None,
            })
    writer = run_file_state(path)
    age = writer.flush_age_s() if state["state"] == "recording" else None
    gone = writer.recorder_gone()
    if gone:  # nothing more will come: no time left to wait for
        for u in units:
            u["time_left_s"] = None
    return {"run": str(path), "state": state["state"], "stop_utc": state.get("stop_utc"),
            "stop_reason": state.get("stop_reason"),
            "last_flush_utc": state.get("last_flush_utc"),
            "last_flush_age_s": None if age is None else round(age, 3),
            "recorder_gone": gone, "advice": writer.gone_advice() if gone else None,
            "lot": meta["lot"] or None, "operator": meta["operator"] or None,
            "start_utc": meta["start_utc"] or None, "duration_requested_s": planned,
            "units": units}


def _progress(t_s: float, planned_s: float | None, time_warp: float,
              state: str) -> dict[str, float | None]:
    """How far a unit is into its run, ``t_s`` recorded (s, its last sample's time and one
    sample period): ``progress`` (0 to 1, of the requested duration)
    and ``time_left_s`` (wall-clock seconds left, the run's time divided by its time warp;
    0 once the run has stopped; None without a requested duration)."""
    if planned_s is None:
        return {"progress": None, "time_left_s": None}
    done = min(1.0, max(0.0, t_s / planned_s))
    if state != "recording":
        return {"progress": round(done, 4), "time_left_s": 0.0}
    left = max(0.0, planned_s - t_s) / (time_warp if time_warp > 0 else 1.0)
    return {"progress": round(done, 4), "time_left_s": round(left, 1)}


def live_allan(path: Path, unit: str, *, max_samples: int = LIVE_ALLAN_MAX_SAMPLES
               ) -> dict[str, object]:
    """The overlapping Allan deviation of the samples ``unit`` has committed so far (the
    newest ``max_samples``), per axis: ``{"unit", "axes", "tau_s", "adev_deg_h"}``
    (``adev_deg_h``: one list per axis, deg/h; empty lists below 4 samples), of the valid
    samples (``status`` 0). Gaps, and the samples left out, are read
    as the recorder wrote them: the samples received, one after the other (a live view; the
    graded analysis declares the gaps)."""
    with RUN_FILE_READ, open_run_file(path) as f:
        rate_hz = float(f["units"][unit].attrs["sample_rate_hz"])
        n = unit_counts(f, unit).samples_recorded
        data = read_unit(f, unit, start=max(0, n - max_samples))
        rate = np.asarray(data.rate_deg_s, dtype=float).reshape(len(data.counter), -1)
        names = list(data.axes)
        valid = data.valid  # the samples the device says are good (status 0)
    rate = rate[valid & np.all(np.isfinite(rate), axis=1)]
    if len(rate) < 4:
        return {"unit": unit, "axes": names, "tau_s": [], "adev_deg_h": [[] for _ in names]}
    result = allan_variance(rate, rate_hz, taus="octave")
    adev = np.sqrt(np.asarray(result.avar, dtype=float)).reshape(len(result.tau_s), -1) * 3600.0
    return {"unit": unit, "axes": names, "tau_s": [float(t) for t in result.tau_s],
            "adev_deg_h": [[float(v) if np.isfinite(v) else None for v in adev[:, i]]
                           for i in range(adev.shape[1])]}


@dataclass(frozen=True)
class RunsInProgress:
    """The run files under some folders: those read (:func:`status_json` each, with the
    live Allan curve of every unit under ``"allan"``) and those that could not be read,
    with the reason."""

    runs: tuple[dict[str, object], ...]
    damaged: tuple[tuple[str, str], ...]

    def as_json(self) -> dict[str, object]:
        """``{"runs": [watch's --json object + "allan": [...]], "damaged": [{"run",
        "reason"}]}``."""
        return {"runs": list(self.runs),
                "damaged": [{"run": run, "reason": reason} for run, reason in self.damaged]}


def runs_in_progress(folders: tuple[Path, ...]) -> RunsInProgress:
    """Every ``*.h5`` run file under ``folders`` (newest first), read as ``station watch``
    reads it; a file that cannot be read is listed as damaged with the reason, the others
    are still read."""
    files = sorted({p for folder in folders for p in Path(folder).glob("*.h5")},
                   key=lambda p: (-p.stat().st_mtime, p.name))
    runs: list[dict[str, object]] = []
    damaged: list[tuple[str, str]] = []
    for path in files:
        try:
            doc = status_json(path)
            doc["allan"] = [live_allan(path, str(u["unit"]))
                            for u in doc["units"]]  # type: ignore[attr-defined]
        except (StationError, OSError, KeyError, ValueError) as exc:
            damaged.append((str(path), str(exc).strip().splitlines()[0] if str(exc).strip()
                            else type(exc).__name__))
            continue
        runs.append(doc)
    return RunsInProgress(tuple(runs), tuple(damaged))
