"""``station demo``: the whole job on two simulated IMUs, start to finish, in under a minute.

Records half an hour of two simulated IMUs (tactical-grade gyros of the VG951 noise model
of Lv 2015 table 3, beside three accelerometers each, with gravity on z), time-warped into
about 20 s, over their real transports (two Xsens Xbus streams, each on its own
pseudo-terminal) into an HDF5 run file as ``station record`` does; grades both units
against the demo's profile into a results database as ``station grade`` does, writes their
PDF spec sheet as ``station report`` and the first unit's Kalibr IMU file as ``station
export`` do; then prints a short table per unit: each figure, its value and 95 % interval, the
limit and verdict, and the truth the simulator drew from. Every file goes into ``--out``
(default: a new folder, printed) and is kept there. ``--verbose`` adds the grading's
notes; ``--json`` prints everything as one JSON object (``docs/json.md``).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

from analysis.models.noise import flicker_rate_noise, white_angle_noise, white_rate_noise
from analysis.units.conversions import (
    UnitFamily,
    arw_deg_rt_h_to_deg_rt_s,
    q_urad_to_deg,
    rate_deg_h_to_deg_s,
)
from station.commands import COMMAND_HELP, demo_sequence
from station.commands.arguments import add_output_options, output_family, print_json
from station.errors import UsageError
from station.model.records import RateRecord
from station.model.wording import plural
from station.recording.progress import ProgressLine

#: The demo gyro: a tactical FOG (the VG951 of Lv 2015 table 3) with a 3.6 deg/h bias.
DEMO_TRUE = {"Q": 7.555e-2, "N": 7.636e-3, "B": 1.246e-1}
DEMO_BIAS_DEG_H = 3.6
#: The widest line the demo prints (a terminal's 80 columns).
WIDTH = 80
#: What each file in the demo's folder is, by its key in the document's ``files``.
FILE_ROLES = {"run": "the run (station analyze, grade, report, export)",
              "profile": "the profile it was graded with",
              "database": "the gradings (station results --db, serve --db)",
              "pdf": "the spec sheet, one page per unit and half",
              "kalibr": "Kalibr's IMU noise file of unit1"}


def simulate_demo_record(duration_s: float, sample_rate_hz: float, seed: int) -> RateRecord:
    """A simulated three-axis static record of the demo gyro (deg/s), without devices."""
    n = int(duration_s * sample_rate_hz)
    rng = np.random.default_rng(seed)
    rate = (
        DEMO_BIAS_DEG_H / 3600.0
        + white_angle_noise(q_urad_to_deg(DEMO_TRUE["Q"]), n, sample_rate_hz, rng, n_axes=3)
        + white_rate_noise(
            arw_deg_rt_h_to_deg_rt_s(DEMO_TRUE["N"]), n, sample_rate_hz, rng, n_axes=3
        )
        + flicker_rate_noise(rate_deg_h_to_deg_s(DEMO_TRUE["B"]), n, sample_rate_hz, rng, n_axes=3)
    )
    return RateRecord(rate, sample_rate_hz, ("gyro_x", "gyro_y", "gyro_z"), "simulated demo gyro")


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``demo`` sub-command."""
    p = sub.add_parser("demo", help=COMMAND_HELP["demo"], description=__doc__)
    p.add_argument("--duration", type=float, default=0.5, metavar="HOURS",
                   help="simulated run length in hours (default 0.5; recorded in about 20 s)")
    p.add_argument(
        "--rate", type=float, default=10.0, metavar="HZ", help="sample rate (default 10 Hz)"
    )
    p.add_argument("--seed", type=int, default=1,
                   help="seed of the first simulated unit, its serial SIM-SEED (default 1: "
                        "the same units every time)")
    p.add_argument("--out", type=Path, default=None, metavar="DIR",
                   help="folder for every file the demo writes (default: a new folder, "
                        "printed); nothing written is removed")
    p.add_argument("--verbose", action="store_true",
                   help="print each unit's notes (the analysis', the fit's, each figure's) "
                        "after its table")
    demo_sequence.add_arguments(p)
    add_output_options(p, json_help='print {"folder", "files", "units": [{"unit", "grade", '
                       '"figures", "notes", ...}], "true", ...} as one JSON object '
                       "(docs/json.md)")
    p.set_defaults(handler=run)


def demo_folder(out: Path | None) -> Path:
    """``out`` (created), or a new folder in the temporary directory; never removed."""
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        return out
    return Path(tempfile.mkdtemp(prefix="station-demo-"))


def run(args: argparse.Namespace) -> int:
    """Run the demo (or ``--sequence``) into its folder and show what it did."""
    if args.sequence and args.json:
        raise UsageError("--json is not available with --sequence (its figures are "
                         "printed as a table; station grade RUN --json gives them)")
    if args.duration <= 0 or args.rate <= 0:
        raise UsageError("--duration and --rate must be positive")
    folder = demo_folder(args.out)
    if args.sequence:
        if args.out is None:
            print(f"station demo: writing into {folder}", file=sys.stderr)
        return demo_sequence.run(argparse.Namespace(**{**vars(args), "out": folder}))
    t0 = time.monotonic()
    duration_s = args.duration * 3600.0
    err = sys.stderr
    print("\n".join(wrap(f"station demo: recording two simulated IMUs (VG951 gyros, "
                         f"accelerometers), {args.duration:g} h at {args.rate:g} Hz over two "
                         f"Xbus serial links, time-warped, into")), file=err)
    print(f"  {folder}", file=err, flush=True)
    family = output_family(args)
    from station.commands.demo_job import DemoJob, run_demo_job  # (the grading: not for --help)

    doc = run_demo_job(DemoJob(duration_s, args.rate, args.seed, folder, family,
                               [DemoProgress(err, plain_interval_s=10.0)],
                               lambda text: print("\n".join(wrap(f"{text} ...")), file=err,
                                                  flush=True)))
    doc["wall_s"] = round(time.monotonic() - t0, 1)
    cpu = doc["cpu_s"]
    assert isinstance(cpu, dict)
    cpu["station"] = round(time.process_time(), 2)  # this process, from its start
    if args.json:
        print_json(doc, family, indent=1, allow_nan=False)
        return 0
    print("\n".join(demo_lines(doc, family, verbose=args.verbose)))
    return 0


class DemoProgress(ProgressLine):
    """The recording's progress in one line of at most 80 columns: the simulated time
    recorded, and each unit's samples and gaps (off a terminal, a line only when it
    changed)."""

    _printed = ""

    def draw(self) -> None:
        """Print the line, unless off a terminal it is the one printed last."""
        text = self.line()
        if self.tty or text != self._printed:
            self._printed = text
            super().draw()
        else:
            self._last_draw = time.monotonic()

    def line(self) -> str:
        """The current line."""
        done = min((t.last_time_s for t in self.tallies.values()), default=0.0)
        units = "; ".join(f"{uid} {plural(t.samples, 'sample')}, {plural(t.gaps, 'gap')}"
                          + ("" if t.connected else " DISCONNECTED")
                          for uid, t in self.tallies.items())
        text = f"  {max(done, 0.0) / 60:.1f} of {self.duration_s / 60:g} min: {units}"
        return text if len(text) <= WIDTH else text[:WIDTH - 3] + "..."


def wrap(text: str, first: str = "", rest: str = "  ") -> list[str]:
    """``text`` in lines of at most :data:`WIDTH` columns (a word longer stays whole), the
    first after ``first``, the others after ``rest``."""
    return textwrap.wrap(text, WIDTH, initial_indent=first, subsequent_indent=rest,
                         break_on_hyphens=False, break_long_words=False)


def _num(v: float | None) -> str:
    """Three significant digits, a number up to 99,999 without an exponent."""
    return "-" if v is None else f"{v:.0f}" if 1e3 <= abs(v) < 1e5 else f"{v:.3g}"


def figure_table(figures: list[dict[str, object]], family: UnitFamily) -> list[str]:
    """A unit's table: figure [unit], value, 95 % interval, limit (grade), verdict, truth,
    columns as wide as their cells and the figure column cut to keep it in 80 columns."""
    rows = [("figure", "value", "95 % interval", "limit", "verdict", "truth")]
    for f in figures:
        unit = str(f["unit"])

        def v(key: str, f: dict[str, object] = f, unit: str = unit) -> str:
            value = f[key]
            return _num(family.value(value if isinstance(value, float | int) else None, unit))

        interval = "-" if f["ci_low"] is None else f"{v('ci_low')}-{v('ci_high')}"
        limit = "-" if f["limit"] is None else f"{f['grade']} {v('limit')}"
        rows.append((f"{f['label']} [{family.label(unit)}]", v("value"), interval, limit,
                     str(f["verdict"] or "info"), v("truth")))
    widths = [max(len(r[i]) for r in rows) for i in range(6)]
    widths[0] = max(6, min(widths[0], WIDTH - 2 - sum(widths[1:]) - 5))
    lines = []
    for r in rows:
        cells = [r[0][:widths[0]].ljust(widths[0]), r[1].rjust(widths[1]),
                 r[2].rjust(widths[2]), r[3].rjust(widths[3]), r[4].ljust(widths[4]),
                 r[5].rjust(widths[5])]
        lines.append(("  " + " ".join(cells)).rstrip())
    return lines


def demo_lines(doc: dict[str, object], family: UnitFamily, *, verbose: bool) -> list[str]:
    """What the demo prints from its document: per unit its grade, recording counts and
    table (``verbose``: its notes), then the files it wrote and where to go next."""
    lines: list[str] = []
    units = doc["units"]
    assert isinstance(units, list)
    for u in units:
        review = ", REVIEW" if u["review"] else ""
        lines += wrap(f"{u['unit']} {u['serial_number']}: grade {u['grade']}{review}; "
                      f"{u['samples_recorded']} samples, {u['samples_missing_declared']} "
                      f"missing in {plural(u['gaps'], 'gap')}")
        lines += figure_table(u["figures"], family)
        if verbose:
            lines += [line for n in u["notes"] for line in wrap(n, "  - ", "    ")]
        lines.append("")
    warnings = doc["warnings"]
    assert isinstance(warnings, list)
    lines += [line for w in warnings for line in wrap(f"warning: {w}")]
    folder, files = Path(str(doc["folder"])), doc["files"]
    assert isinstance(files, dict)
    lines.append(f"wrote into {folder}:")
    names = {k: Path(p).name for k, p in files.items()}
    width = max(len(n) for n in names.values())
    for key, name in names.items():
        lines.append(f"  {name:<{width}}  {FILE_ROLES.get(key, '')}"[:WIDTH].rstrip())
    notes = sum(len(u["notes"]) for u in units)
    lines += wrap(f"next: station results --db {files['database']}")
    cpu = doc["cpu_s"]
    assert isinstance(cpu, dict)
    lines.append(f"done in {doc['wall_s']:.0f} s (CPU: {cpu['station']:.0f} s here, "
                 f"{cpu['units']:.0f} s in the units' processes)")
    lines.append(("" if verbose else f"--verbose prints the {notes} notes, ")
                 + "--json all of it")
    return lines
