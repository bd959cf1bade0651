"""The argument groups the commands share (station/commands/arguments.py), defined once:
every command that reads a record takes the same record source, output options and
database location."""

from __future__ import annotations

import argparse

import pytest

from station.cli import build_parser


def _sub(command: str, *actions: str) -> argparse.ArgumentParser:
    parser = build_parser(command)
    for name in (command, *actions):
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        parser = sub.choices[name]
    return parser


def _group(parser: argparse.ArgumentParser, title: str) -> list[tuple[str, ...]]:
    group = next(g for g in parser._action_groups if g.title == title)
    return [tuple(a.option_strings) or (a.dest,) for a in group._group_actions]


RECORD_READERS = ("analyze", "davar", "export", "reconcile")


def test_every_record_reading_command_has_the_same_record_source_group() -> None:
    groups = {c: _group(_sub(c), "record source") for c in RECORD_READERS}
    first = groups["analyze"]
    assert ("file",) in first and ("--rate",) in first and ("--warmup-s",) in first
    assert all(g == first for g in groups.values()), groups


def test_record_source_options_parse_the_same_everywhere() -> None:
    argv = ["r.csv", "--rate", "10", "--units", "rad/s", "--axis", "x", "--unit", "unit2",
            "--start-s", "5", "--stop-s", "60", "--profile", "VG951", "--warmup-s", "1"]
    extra = {"davar": ["--window-s", "10"], "export": ["--format", "json"],
             "reconcile": ["--model", "VG951"], "analyze": []}
    for command in RECORD_READERS:
        args = build_parser(command).parse_args([command, *argv, *extra[command]])
        assert (args.file, args.rate, args.units, args.axis, args.unit, args.start_s,
                args.stop_s, args.profile, args.warmup_s) == (
            "r.csv", 10.0, "rad/s", "x", "unit2", 5.0, 60.0, "VG951", 1.0), command


@pytest.mark.parametrize(
    ("command", "expected"),
    [
        ("analyze", {"--png", "--csv", "--output-units", "--json"}),
        ("davar", {"--png", "--output-units", "--json"}),
        ("export", {"--output-units", "--json", "--quiet"}),
        ("reconcile", {"--png", "--output-units", "--json"}),
        ("simulate", {"--json", "--quiet"}),
        ("grade", {"--output-units", "--json"}),
        ("report", {"--output-units", "--json"}),
        ("results", {"--png", "--csv", "--output-units", "--json"}),
        ("watch", {"--output-units", "--json"}),
    ],
)
def test_output_options_are_one_group(command: str, expected: set[str]) -> None:
    assert {o for (o, *_) in _group(_sub(command), "output")} == expected


@pytest.mark.parametrize("command", ["grade", "report", "fleet", "results", "tui"])
def test_database_location_is_one_group(command: str) -> None:
    options = {o for (o, *_) in _group(_sub(command), "results database")}
    assert "--db" in options
    assert ("--db-retry" in options) == (command != "results")


def test_fog_indicators_shared_by_simulate_and_model_fog() -> None:
    fog = _sub("model", "fog")
    simulate = _sub("simulate")
    names = ["--arw", "--bias-stability", "--average-s", "--correlation-s"]
    for parser in (fog, simulate):
        options = {o for a in parser._actions for o in a.option_strings}
        assert set(names) <= options
    required = {a.option_strings[0]: a.required for a in fog._actions if a.option_strings}
    assert required["--arw"] and required["--bias-stability"]
    assert not any(a.required for a in simulate._actions if set(a.option_strings) & set(names))
