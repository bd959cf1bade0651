"""``station results``: the results database: list and filter gradings, export CSV, yield, trends.

* ``station results [--model M] [--lot L] [--since DATE] [--until DATE] [--verdict V]
  [--serial SN] [--latest] [--review]`` lists gradings as a table (``--review``: only those
  flagged for review, with the reasons); ``--csv OUT`` exports them;
* ``station results --yield [--model M]``: per lot, the units passing (latest grading each);
* ``station results --trend FIGURE [--axis A] [--png OUT]``: a figure over test dates as a
  table, and as a PNG (value, confidence interval, limit, coloured by verdict);
* ``station results --stats [--model M] [--lot L] [--since DATE] [--html OUT] [--pdf OUT]``:
  the producer's statistics over the latest grading of each unit, model by model (never
  pooled): yield per grade, per graded figure mean, std, Cp and Cpk against the acceptance
  limit, histograms against the limits and control charts (HTML, PDF), and the units
  flagged for review.

Every listing takes ``--json`` (one JSON document on stdout instead of a table);
``--stats --model M --json`` prints ``{"units", "yield": {grade: share}, "figures": {name:
{"mean", "std", "cp", "cpk", "limits", ...}}, "review": [...], "profile", "lots",
"lot_yield", ...}``; without ``--model``, ``{"units", "models": {model: that document}}``.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Literal, get_args

from analysis.units.conversions import DEG_FAMILY, UnitFamily
from station.commands import COMMAND_HELP
from station.commands.arguments import (
    add_database_argument,
    add_output_options,
    output_family,
    print_json,
)
from station.errors import UsageError
from station.model.kinds import Verdict
from station.model.wording import plural
from station.output.results_backends import redacted

if TYPE_CHECKING:
    from station.output.production_stats import ProductionStats, StatsByModel
    from station.output.results import GradingRow, LotYield, TrendPoint


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``results`` sub-command."""
    p = sub.add_parser("results", help=COMMAND_HELP["results"],
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_database_argument(p)
    p.add_argument("--model", default=None, help="only this gyro model (as graded, e.g. CRG20)")
    p.add_argument("--lot", default=None, help="only this production lot")
    p.add_argument("--serial", default=None, help="only this unit's serial number")
    p.add_argument("--since", default=None, metavar="DATE", help="test date from (ISO 8601, UTC)")
    p.add_argument(
        "--until", default=None, metavar="DATE", help="test date up to, inclusive (ISO 8601)"
    )
    p.add_argument(
        "--verdict", choices=get_args(Verdict), default=None, help="only gradings with this verdict"
    )
    p.add_argument(
        "--review",
        action="store_true",
        help="only gradings flagged for review (read-off and fit of a graded figure disagree)",
    )
    p.add_argument("--latest", action="store_true", help="only the newest grading of each unit")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--yield", dest="show_yield", action="store_true", help="yield per lot")
    what.add_argument(
        "--trend",
        default=None,
        metavar="FIGURE",
        help="trend of a figure (a profile figure name such as arw)",
    )
    what.add_argument(
        "--stats",
        action="store_true",
        help="production statistics, a block per model: yield per grade, Cp/Cpk, control "
        "charts, review",
    )
    p.add_argument("--axis", default=None, help="with --trend: only this axis")
    p.add_argument(
        "--html",
        type=Path,
        default=None,
        metavar="OUT",
        help="with --stats: write the statistics and their plots as one HTML page",
    )
    p.add_argument(
        "--pdf",
        type=Path,
        default=None,
        metavar="OUT",
        help="with --stats: write the statistics and their plots as a PDF",
    )
    add_output_options(
        p,
        png_help="with --trend: write a PNG plot",
        csv_help="export the listed gradings as CSV",
        json_help="print one JSON document instead of a table",
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Open the database and print what was asked."""
    from station.services.results import ResultsRequest, query_results

    if (args.html is not None or args.pdf is not None) and not args.stats:
        raise UsageError("--html and --pdf go with --stats")
    if args.stats:
        return run_stats(args)

    show: Literal["gradings", "yield", "trend"] = (
        "yield" if args.show_yield else "trend" if args.trend else "gradings"
    )
    answer = query_results(
        ResultsRequest(
            args.db,
            show,
            model=args.model,
            lot=args.lot,
            serial=args.serial,
            since=args.since,
            until=args.until,
            verdict=args.verdict,
            review=args.review,
            latest=args.latest,
            figure=args.trend,
            axis=args.axis,
            csv=args.csv,
        )
    )
    if args.json:
        document: dict[str, object] = {
            "database": redacted(answer.database),
            "exists": answer.exists,
        }
        if show == "yield":
            document["yield"] = [{**asdict(y), "yield": y.yield_fraction} for y in answer.yields]
        elif show == "trend":
            document |= {"figure": args.trend, "points": [asdict(p) for p in answer.trend]}
        else:
            document["gradings"] = [asdict(r) for r in answer.gradings]
        _print_json(document, output_family(args))
    elif not answer.exists:
        print(
            f"no results database at {redacted(answer.database)} yet (station grade stores into it)"
        )
    elif show == "yield":
        print(format_yield(list(answer.yields)))
    elif show == "trend":
        print(format_trend(args.trend, list(answer.trend), output_family(args)))
        if args.png is not None:
            from station.output.plots import plot_trend  # matplotlib: only for a plot

            print(f"trend plot: {plot_trend(args.trend, list(answer.trend), args.png)}")
    else:
        print(format_gradings(list(answer.gradings)))
        if answer.csv is not None:
            print(f"{plural(len(answer.gradings), 'grading')} written to {answer.csv}")
    return 0


def _print_json(document: dict[str, object], family: UnitFamily = DEG_FAMILY) -> None:
    print_json(document, family, indent=1, allow_nan=False)


def run_stats(args: argparse.Namespace) -> int:
    """``--stats``: compute, print (table or JSON), and draw when asked."""
    from station.services.production import StatsRequest, production_stats

    answer = production_stats(
        StatsRequest(
            args.db, model=args.model, lot=args.lot, since=args.since, html=args.html, pdf=args.pdf
        )
    )
    if answer.stats is None:
        if args.json:
            empty: dict[str, object] = ({"yield": {}, "figures": {}} if args.model
                                        else {"models": {}})
            _print_json(
                {"database": redacted(answer.database), "exists": False, "units": 0, **empty}
            )
        else:
            print(
                f"no results database at {redacted(answer.database)} yet "
                "(station grade stores into it)"
            )
        return 0
    if args.json:
        _print_json(answer.stats.as_json(), output_family(args))
    else:
        print(format_stats_by_model(answer.stats, output_family(args)))
    for path in (answer.html, answer.pdf):
        if path is not None:
            print(f"statistics: {path}", file=sys.stderr if args.json else sys.stdout)
    return 0


def _ci(ci: tuple[float, float] | None) -> str:
    return "-" if ci is None else f"[{ci[0]:.3g}, {ci[1]:.3g}]"


def format_stats_by_model(stats: StatsByModel, family: UnitFamily = DEG_FAMILY) -> str:
    """The statistics as terminal tables, a block per model (:func:`format_stats`); with
    ``--model``, that model's block alone."""
    if stats.model is not None:
        return format_stats(stats.models[stats.model], family)
    lines = [f"{plural(stats.units, 'unit')} of {plural(len(stats.models), 'model')} "
             f"(latest grading each): {', '.join(stats.models) or '-'}; each model apart"]
    for model, block in stats.models.items():
        lines += ["", f"== model {model} ==", format_stats(block, family)]
    return "\n".join(lines)


def format_stats(stats: ProductionStats, family: UnitFamily = DEG_FAMILY) -> str:
    """The statistics as terminal tables: yield per grade, capability per figure (in
    ``family``), review."""
    from station.evaluation.capability import CAPABILITY_NOTE  # scipy.stats: not for --help

    lines = [f"{stats.units} units (latest grading each), profile {stats.profile or '-'}"]
    if not stats.units:
        return lines[0]
    lines.append(
        _table(
            ["grade", "units", "share"],
            [[g, str(n), f"{100 * n / stats.units:.1f} %"] for g, n in stats.grades.items()],
        )
    )
    body = [
        [
            name,
            family.label(f.unit),
            str(c.n),
            _num(family.value(c.mean, f.unit)),
            _num(family.value(c.std, f.unit)),
            " ".join(f"{g}={family.value(v, f.unit):.4g}" for g, v in f.limits.items()) or "-",
            _num(c.cpk),
            _ci(c.cpk_ci),
            _num(c.fitted.cpk if c.fitted else None),
            _ci(c.fitted.cpk_ci if c.fitted else None),
            c.fitted.distribution if c.fitted else "-",
            str(len(f.chart.out_of_control)),
        ]
        for name, f in stats.figures.items()
        for c in (f.capability,)
    ]
    header = ["figure", "unit", "n", "mean", "std", "limits", "Ppk (upper)", "95 % CI",
              "Ppk fitted", "95 % CI", "fit", "out of control"]
    lines.append(_table(header, body))
    lines.append(CAPABILITY_NOTE)
    lines.append(f"{plural(len(stats.review), 'unit')} flagged for review")
    lines += [
        f"  {u.serial_number} ({u.lot or '-'}, {u.test_date}): {reason}"
        for u in stats.review
        for reason in u.reasons
    ]
    return "\n".join(lines)


def _table(header: list[str], rows: list[list[str]]) -> str:
    widths = [
        max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(header)
    ]
    lines = ["  ".join(h.ljust(w) for h, w in zip(header, widths, strict=True))]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)) for r in rows]
    return "\n".join(lines)


def format_gradings(rows: list[GradingRow]) -> str:
    """The gradings as a terminal table."""
    body = [
        [
            str(r.id),
            r.test_date,
            r.model,
            r.serial_number,
            r.lot or "-",
            r.grade,
            r.verdict,
            "REVIEW" if r.needs_review else "-",
            r.profile,
            Path(r.run_path).name,
        ]
        for r in rows
    ]
    header = [
        "id",
        "test date (UTC)",
        "model",
        "serial",
        "lot",
        "grade",
        "verdict",
        "review",
        "profile",
        "run",
    ]
    reasons = [f"review {r.id}: {line}" for r in rows for line in r.review.splitlines()]
    return "\n".join([_table(header, body) + "\n" + plural(len(rows), "grading"), *reasons])


def format_yield(rows: list[LotYield]) -> str:
    """Yield per lot as a terminal table (latest grading of each unit)."""
    body = [
        [
            y.lot or "-",
            y.model,
            str(y.total),
            str(y.passed),
            str(y.failed),
            str(y.indeterminate),
            f"{100 * y.yield_fraction:.1f} %",
        ]
        for y in rows
    ]
    return _table(["lot", "model", "units", "pass", "fail", "indeterminate", "yield"], body)


def _num(v: float | None) -> str:
    return "-" if v is None else f"{v:.4g}"


def format_trend(figure: str, points: list[TrendPoint], family: UnitFamily = DEG_FAMILY) -> str:
    """A figure over test dates as a terminal table (in ``family``)."""
    unit = points[0].unit if points else ""
    v = family.value
    body = [
        [
            p.test_date,
            p.serial_number,
            p.axis or "unit",  # a test sequence's figure: the unit's
            _num(v(p.value, p.unit)),
            f"[{_num(v(p.ci_low, p.unit))}, {_num(v(p.ci_high, p.unit))}]",
            _num(v(p.limit, p.unit)),
            p.verdict or "info",
        ]
        for p in points
    ]
    header = [
        "test date (UTC)",
        "serial",
        "axis",
        f"{figure} [{family.label(unit)}]",
        "interval",
        "limit",
        "verdict",
    ]
    return _table(header, body) + f"\n{len(points)} points"
