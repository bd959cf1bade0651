"""``station results``: the results database: list and filter gradings, export CSV, yield, trends.

* ``station results [--model M] [--lot L] [--since DATE] [--until DATE] [--verdict V]
  [--serial SN] [--latest] [--review]`` lists gradings as a table (``--review``: only those
  flagged for review, with the reasons); ``--csv OUT`` exports them;
* ``station results --yield [--model M]``: per lot, the units passing (latest grading each);
* ``station results --trend FIGURE [--axis A] [--png OUT]``: a figure over test dates as a
  table, and as a PNG (value, confidence interval, limit, coloured by verdict).
"""

from __future__ import annotations

import argparse
from datetime import datetime
from pathlib import Path

from station.results import (
    GradingRow,
    LotYield,
    ResultsDatabase,
    TrendPoint,
    default_database_path,
    export_csv,
)
from station.results_backends import database_exists, database_location


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``results`` sub-command."""
    p = sub.add_parser("results", help="browse the results database: list, CSV, yield, trends",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--db", type=database_location, default=None, metavar="FILE|URL",
                   help="results database: an SQLite file or a postgresql:// URL (default: "
                        "$STATION_RESULTS_DB or ~/.local/share/gyro-station)")
    p.add_argument("--model", default=None)
    p.add_argument("--lot", default=None)
    p.add_argument("--serial", default=None)
    p.add_argument("--since", default=None, metavar="DATE", help="test date from (ISO 8601, UTC)")
    p.add_argument("--until", default=None, metavar="DATE", help="test date up to, inclusive (ISO 8601)")
    p.add_argument("--verdict", choices=("pass", "fail", "indeterminate"), default=None)
    p.add_argument("--review", action="store_true",
                   help="only gradings flagged for review (read-off and fit of a graded figure disagree)")
    p.add_argument("--latest", action="store_true", help="only the newest grading of each unit")
    p.add_argument("--csv", type=Path, default=None, metavar="OUT", help="export the listed gradings as CSV")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--yield", dest="show_yield", action="store_true", help="yield per lot")
    what.add_argument("--trend", default=None, metavar="FIGURE",
                      help="trend of a figure (a profile figure name such as arw)")
    p.add_argument("--axis", default=None, help="with --trend: only this axis")
    p.add_argument("--png", type=Path, default=None, metavar="OUT", help="with --trend: write a PNG plot")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Open the database and print what was asked."""
    db_path = args.db or default_database_path()
    if not database_exists(db_path):
        print(f"no results database at {db_path} yet (station grade stores into it)")
        return 0
    with ResultsDatabase(db_path) as db:
        if args.show_yield:
            print(format_yield(db.yield_by_lot(model=args.model)))
            return 0
        if args.trend:
            points = db.trend(args.trend, model=args.model, axis=args.axis, lot=args.lot)
            print(format_trend(args.trend, points))
            if args.png is not None:
                print(f"trend plot: {plot_trend(args.trend, points, args.png)}")
            return 0
        rows = db.gradings(model=args.model, lot=args.lot, since=args.since, until=args.until,
                           verdict=args.verdict, serial=args.serial, latest=args.latest, review=args.review)
    print(format_gradings(rows))
    if args.csv is not None:
        print(f"{len(rows)} gradings written to {export_csv(rows, args.csv)}")
    return 0


def _table(header: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(header)]
    lines = ["  ".join(h.ljust(w) for h, w in zip(header, widths, strict=True))]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)) for r in rows]
    return "\n".join(lines)


def format_gradings(rows: list[GradingRow]) -> str:
    """The gradings as a terminal table."""
    body = [[str(r.id), r.test_date, r.model, r.serial_number, r.lot or "-", r.grade, r.verdict,
             "REVIEW" if r.needs_review else "-", r.profile, Path(r.run_path).name] for r in rows]
    header = ["id", "test date (UTC)", "model", "serial", "lot", "grade", "verdict", "review", "profile", "run"]
    reasons = [f"review {r.id}: {line}" for r in rows for line in r.review.splitlines()]
    return "\n".join([_table(header, body) + f"\n{len(rows)} gradings", *reasons])


def format_yield(rows: list[LotYield]) -> str:
    """Yield per lot as a terminal table (latest grading of each unit)."""
    body = [[y.lot or "-", y.model, str(y.total), str(y.passed), str(y.failed), str(y.indeterminate),
             f"{100 * y.yield_fraction:.1f} %"] for y in rows]
    return _table(["lot", "model", "units", "pass", "fail", "indeterminate", "yield"], body)


def _num(v: float | None) -> str:
    return "-" if v is None else f"{v:.4g}"


def format_trend(figure: str, points: list[TrendPoint]) -> str:
    """A figure over test dates as a terminal table."""
    unit = points[0].unit if points else ""
    body = [[p.test_date, p.serial_number, p.axis, _num(p.value), f"[{_num(p.ci_low)}, {_num(p.ci_high)}]",
             _num(p.limit), p.verdict or "info"] for p in points]
    header = ["test date (UTC)", "serial", "axis", f"{figure} [{unit}]", "interval", "limit", "verdict"]
    return _table(header, body) + f"\n{len(points)} points"


def _date(text: str) -> datetime | None:
    try:
        return datetime.fromisoformat(text.replace("Z", "+00:00"))
    except ValueError:
        return None


def plot_trend(figure: str, points: list[TrendPoint], path: Path) -> Path:
    """PNG of a figure over test dates: value with its interval, limit, verdict as colour."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from station.report.common import VERDICT_COLORS

    dates = [_date(p.test_date) for p in points]
    xs: list = dates if all(dates) else list(range(len(points)))
    fig, ax = plt.subplots(figsize=(9, 4.5), layout="constrained")
    for x, p in zip(xs, points, strict=True):
        if p.value is None:
            continue
        low = p.value - (p.ci_low if p.ci_low is not None else p.value)
        high = (p.ci_high if p.ci_high is not None else p.value) - p.value
        edge = {"pass": "#2e7d32", "fail": "#c62828", "indeterminate": "#b8860b"}.get(p.verdict or "", "0.3")
        ax.errorbar([x], [p.value], yerr=[[low], [high]], fmt="o", ms=5, color=edge,
                    mfc=VERDICT_COLORS.get(p.verdict, "white"), capsize=2)
    limits = [(x, p.limit) for x, p in zip(xs, points, strict=True) if p.limit is not None]
    if limits:
        ax.step([x for x, _ in limits], [v for _, v in limits], "--", color="0.3", where="post", label="limit")
        ax.legend()
    unit = points[0].unit if points else ""
    ax.set_ylabel(f"{figure} [{unit}]")
    ax.set_xlabel("test date (UTC)" if xs is dates else "grading")
    ax.set_title(f"{figure}: value and confidence interval per unit and axis ({len(points)} points)")
    ax.grid(True, alpha=0.3)
    fig.autofmt_xdate()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
