"""The job ``station demo`` does, through the services a line uses: record two simulated IMUs
(:func:`station.services.record.record`), grade them against the demo's profile into a
results database and write their spec sheet (:func:`station.services.report.report`),
export each unit's noise for Kalibr (:func:`station.services.export.export_noise`), and
gather what came out beside the simulator's truths into one document (:func:`run_demo_job`),
which ``--json`` prints and the text view renders.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import quote

from analysis.units.conversions import DEG_FAMILY, UnitFamily
from station.errors import StationError
from station.evaluation.decision import GradingError
from station.evaluation.grading import FigureResult, UnitGrade
from station.model.documents import Subscriber
from station.model.profiles import PROFILE_DIR, UNITS, figure_kind

#: Wall-clock time the recording of one simulated hour takes, s (the time warp follows).
DEMO_WALL_S_PER_H = 40.0
#: The shortest recording, wall s (a demo shorter than 90 simulated s slows its warp to it).
DEMO_MIN_WALL_S = 1.0
#: The longest recording, wall s (a longer demo is warped faster).
DEMO_MAX_WALL_S = 20.0
#: What the demo writes into its folder (the spec sheet and the Kalibr files are named as
#: ``station report`` and ``station export`` name them).
RUN_FILE, PROFILE_FILE, DATABASE_FILE = "demo-run.h5", "demo-profile.toml", "results.db"


@dataclass(frozen=True)
class DemoFigure:
    """A figure of the demo's profile: its key, the short label of the demo's table, its
    unit and its upper limit per grade (none: reported, not graded)."""

    name: str
    label: str
    unit: str
    limits: tuple[tuple[str, float], ...] = ()


#: The demo profile's figures, on axis x and accel_x of each unit. The gyro limits are the
#: VG951 profile's (about 1.5x and 3x the fitted N and B of Lv 2015 table 3); the
#: accelerometer's velocity random walk is limited at 1.5x and 3x the simulated 0.1
#: m/s/sqrt(h); its bias instability is reported only: half an hour does not resolve it.
DEMO_FIGURES = (
    DemoFigure("arw_fit", "ARW fit", "deg/sqrt(h)", (("A", 0.012), ("B", 0.025))),
    DemoFigure("bias_instability_fit", "bias instab. fit", "deg/h", (("A", 0.2), ("B", 0.4))),
    DemoFigure("accel_vrw", "accel VRW", "m/s/sqrt(h)", (("A", 0.15), ("B", 0.3))),
    DemoFigure("accel_bias_instability", "accel bias instab.", "ug"),
)


def demo_model() -> str:
    """The noise model the simulated units draw from: the VG951 model file, else the preset."""
    path = PROFILE_DIR / "models" / "VG951.toml"
    return str(path) if path.is_file() else "VG951"


def demo_urls(duration_s: float, rate_hz: float, seed: int) -> tuple[str, str]:
    """Device URLs of the two simulated units (serials SIM-``seed`` and SIM-``seed + 1``),
    warped to record ``duration_s`` (s) in about 1..20 s of wall time (half an hour in 20 s:
    warp 90; a short demo at the same warp, not slowed to fill a fixed wall time)."""
    wall_s = min(max(duration_s / 3600.0 * DEMO_WALL_S_PER_H, DEMO_MIN_WALL_S), DEMO_MAX_WALL_S)
    warp = max(1.0, duration_s / wall_s)
    query = f"model={quote(demo_model())}&rate={rate_hz:g}&warp={warp:g}"
    return (f"sim+serial://VG951?protocol=xbus&{query}&seed={seed}",
            f"sim+serial://VG951?protocol=xbus&{query}&seed={seed + 1}")


def demo_profile_text(duration_s: float, rate_hz: float) -> str:
    """The demo's product profile (TOML): the VG951 on a ``duration_s`` (s) static test at
    ``rate_hz`` (Hz), no warm-up (a simulated unit has none), graded on axis x of its
    gyros and of its accelerometers with :data:`DEMO_FIGURES`."""
    lines = [
        "# Written by `station demo`: two simulated VG951 IMUs (the gyros of Lv 2015 table 3,",
        "# the generic accelerometer of devices/sim/signal.py) on a short static test.",
        'name = "VG951-IMU-demo"', 'version = "1"', 'model = "VG951"',
        'description = "Demo: simulated VG951 IMU, static test, time-warped"', "",
        "[test]", f"sample_rate_hz = {rate_hz!r}", f"duration_s = {duration_s!r}",
        "warmup_s = 0.0", 'axes = ["x"]', 'fit_method = "logwls"', "",
        "[grading]", 'rule = "guard-banded"', "confidence = 0.95", 'grades = ["A", "B"]',
    ]
    for f in DEMO_FIGURES:
        lines += ["", f"[figures.{f.name}]", f'unit = "{f.unit}"']
        if f.limits:
            lines.append("limits = { " + ", ".join(f"{g} = {v!r}" for g, v in f.limits) + " }")
    return "\n".join(lines) + "\n"


def demo_truths() -> dict[str, float]:
    """What the simulated units draw from, per profile figure, in the figure's canonical
    unit (deg/h, deg/sqrt(h), urad, deg/h^1.5, deg/h^2; ug, m/s/sqrt(h), m/s/h^1.5): the
    gyro terms of :func:`demo_model` (a term it lacks is 0) and its accelerometer
    (:func:`devices.sim.signal.accel_model`)."""
    from analysis.models.terms import (
        AngleRandomWalk,
        Bias,
        BiasInstability,
        Quantization,
        RateRamp,
        RateRandomWalk,
    )
    from devices.sim.signal import accel_model, noise_model

    terms = {type(t): t for t in noise_model(demo_model()).terms}

    def term(kind: type, key: str) -> float:
        return float(getattr(terms[kind], key)) if kind in terms else 0.0

    accel = accel_model(demo_model())
    n, b = term(AngleRandomWalk, "N_deg_rt_h"), term(BiasInstability, "B_deg_h")
    return {"bias": abs(term(Bias, "value_deg_h")), "arw": n, "arw_fit": n,
            "bias_instability": b, "bias_instability_fit": b,
            "quantization": term(Quantization, "Q_urad"),
            "rrw": term(RateRandomWalk, "K_deg_h_1_5"), "rate_ramp": term(RateRamp, "R_deg_h2"),
            "accel_bias": 0.0, "accel_vrw": accel.vrw_m_s_rt_h,
            "accel_vrw_fit": accel.vrw_m_s_rt_h,
            "accel_bias_instability": accel.bias_instability_ug,
            "accel_bias_instability_fit": accel.bias_instability_ug,
            "accel_random_walk": accel.accel_rw_m_s_h1_5}


def _truth_in(name: str, unit: str, truths: dict[str, float]) -> float | None:
    """The truth of figure ``name`` in ``unit`` (None: the simulation has none)."""
    kind = figure_kind(name)
    if name not in truths or kind is None:
        return None
    return truths[name] / UNITS[kind.dimension][unit]


def _finite(v: float | None) -> float | None:
    return None if v is None or not math.isfinite(v) else float(v)


def figure_row(axis: str, f: FigureResult, grade: str, truths: dict[str, float]
               ) -> dict[str, object]:
    """One row of a unit's table: the figure with its interval, the limit and verdict of
    ``grade`` (the axis' deciding grade; none for a figure without limits) and the truth
    (all in the figure's unit)."""
    labels = {d.name: d.label for d in DEMO_FIGURES}
    graded = f.spec.graded
    return {"axis": axis, "figure": f.name, "label": labels.get(f.name, f.spec.label),
            "unit": f.spec.unit, "value": _finite(f.value), "ci_low": _finite(f.ci_low),
            "ci_high": _finite(f.ci_high), "grade": grade if graded else None,
            "limit": f.spec.limits.get(grade) if graded else None,
            "verdict": f.verdicts.get(grade, "pass") if graded else None,
            "truth": _truth_in(f.name, f.spec.unit, truths)}


def unit_notes(u: UnitGrade) -> list[str]:
    """Everything the grading said about a unit, one line each: its notes, why it needs a
    review, each axis' analysis and fit notes, each figure's note."""
    notes = list(u.notes) + [f"REVIEW {r}" for r in u.review]
    for a in u.axes:
        notes += [f"{a.axis}: {n}" for n in a.analysis.figures.notes]
        notes += [f"{a.axis} fit: {n}" for n in a.analysis.fit.notes]
        notes += [f"{a.axis} {f.name}: {f.note}" for f in a.figures if f.note]
    return notes


@dataclass(frozen=True)
class DemoJob:
    """What to do: the run length (s), the sample rate (Hz), the first seed, the folder, the
    unit family of the spec sheet, who hears the recording's documents, and who hears
    each step after the recording begin (one line)."""

    duration_s: float
    rate_hz: float
    seed: int
    folder: Path
    family: UnitFamily = DEG_FAMILY
    subscribers: Sequence[Subscriber] = ()
    notify: Callable[[str], None] = lambda text: None


class DemoRecordingError(StationError):
    """The demo's recording stopped on a fault (the message says what the file kept)."""


def run_demo_job(job: DemoJob) -> dict[str, object]:
    """Record, grade, store, write the sheet and the Kalibr files into ``job.folder``.

    Returns the demo's document: ``folder``, ``files`` (run, profile, database, pdf,
    kalibr: the first unit's), ``model``, ``profile``, ``true`` (the simulated truths),
    ``warnings`` (the grading's), ``cpu_s`` (``units``: the CPU time of the units'
    processes, readers and simulators, s), and per unit its recording counts, grade, ``figures``
    (rows of :func:`figure_row`) and ``notes``.

    Raises
    ------
    DemoRecordingError
        The recording stopped on a fault.
    GradingError
        A unit that recorded too few samples to grade (a machine too busy for the
        simulated units).
    StationError
        A grading the database did not take, a sheet or file that could not be written.
    """
    from station.services.export import ExportRequest, default_output, export_noise
    from station.services.grade import GradeRequest, RunSource
    from station.services.record import RecordRequest, record
    from station.services.records import RecordSource
    from station.services.report import ReportRequest, report

    folder = job.folder
    folder.mkdir(parents=True, exist_ok=True)
    profile_ref = str((folder / PROFILE_FILE).resolve())  # the run keeps it: grade it anywhere
    run_path, profile_path, db_path = (folder / RUN_FILE, folder / PROFILE_FILE,
                                       folder / DATABASE_FILE)
    profile_path.write_text(demo_profile_text(job.duration_s, job.rate_hz), encoding="utf-8")
    run_path.unlink(missing_ok=True)  # an earlier demo's run in the same folder
    outcome = record(RecordRequest(units=demo_urls(job.duration_s, job.rate_hz, job.seed),
                                   duration=f"{job.duration_s:g}s", out=run_path,
                                   profile=profile_ref, operator="station demo",
                                   lot="DEMO"), job.subscribers)
    if outcome.fault_message():
        raise DemoRecordingError(outcome.fault_message())
    job.notify("grading both units into the results database, writing the PDF sheet")
    try:
        sheets = report(ReportRequest(GradeRequest(RunSource(run_path), db=db_path),
                                      formats=("pdf",), out_dir=folder, units=job.family))
    except GradingError as exc:
        lost = ", ".join(f"{t.unit_id} {s.samples_missing_declared} of {s.samples_sent}"
                         for t, s in zip(outcome.stop.totals, outcome.units, strict=True))
        raise GradingError(f"{exc} (samples the simulated units could not send on time: "
                           f"{lost}; a machine this busy starves them: run the demo again, "
                           f"or longer with --duration; the run is kept in {run_path})"
                           ) from exc
    files: dict[str, str] = {"run": str(run_path), "profile": str(profile_path),
                             "database": str(db_path)}
    files |= {fmt: str(path) for fmt, path in sheets.files}
    # Kalibr takes one IMU: the first unit's (its analysis of all six axes is the demo's
    # longest step; station export RUN --unit unit2 --format kalibr writes the other's)
    first = sheets.graded.units[0].unit.unit_id
    job.notify(f"analyzing all six axes of {first} for its Kalibr file")
    kalibr = export_noise(ExportRequest(
        RecordSource(run_path, unit=first, profile=profile_ref), "kalibr",
        out=folder / default_output(str(run_path), "kalibr", first).name))
    files["kalibr"] = str(kalibr.out)
    truths = demo_truths()
    recorded = {t.unit_id: s for t, s in zip(outcome.stop.totals, outcome.units, strict=True)}
    units = []
    for u in sheets.graded.units:
        uid, s = u.unit.unit_id, recorded[u.unit.unit_id]
        units.append({
            "unit": uid, "serial_number": u.unit.serial_number, "grade": u.grade,
            "review": bool(u.review), "samples_recorded": s.samples_recorded,
            "samples_missing_declared": s.samples_missing_declared, "gaps": s.gaps,
            "samples_sent": s.samples_sent,
            "figures": [figure_row(a.axis, f, a.deciding_grade, truths)
                        for a in u.axes for f in a.figures],
            "notes": unit_notes(u) + ([f"Kalibr: {n}" for n in kalibr.notes]
                                      if uid == first else [])})
    accel = {k: truths[k] for k in ("accel_vrw", "accel_bias_instability", "accel_random_walk")}
    return {"folder": str(folder), "model": demo_model(),
            "profile": sheets.graded.profile.name, "files": files, "units": units,
            "true": {"Q_urad": truths["quantization"], "N_deg_rt_h": truths["arw"],
                     "B_deg_h": truths["bias_instability"], "bias_deg_h": truths["bias"],
                     "accel": {"vrw_m_s_rt_h": accel["accel_vrw"],
                               "bias_instability_ug": accel["accel_bias_instability"],
                               "accel_rw_m_s_h1_5": accel["accel_random_walk"]}},
            "warnings": list(sheets.warnings),
            "cpu_s": {"units": round(sum(c.cpu_s for c in outcome.cpu), 2)}}
