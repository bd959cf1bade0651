"""What a new user tripped over (issue 31): help examples that run as printed, profiles that
work from any folder, ready device URLs, a pointer to ``station fleet``, a quiet
``simulate``, a ``demo`` that keeps what it names (tests/test_demo.py)."""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import pytest

from station.cli import build_parser, main
from station.commands import COMMAND_HELP


def _examples(command: str) -> list[list[str]]:
    """The command lines of the ``Example::`` blocks in ``station COMMAND --help``."""
    text = build_parser(command)._subparsers._group_actions[0].choices[command].format_help()
    out = []
    for block in re.findall(r"Example::\n\n((?:    .*\n?)+)", text):
        joined = block.replace("\\\n", " ")
        out += [shlex.split(line) for line in joined.splitlines() if line.strip()]
    return out


def _shortened(argv: list[str]) -> list[str]:
    """An example as printed (run in ``tmp_path``), with a short duration; a recording only
    checks its units (``--check``)."""
    args = list(argv[1:])
    if "--duration" in args:
        args[args.index("--duration") + 1] = "30s"
    if args[0] == "record":
        args.append("--check")
    return args


EXAMPLES = [(c, e) for c in COMMAND_HELP for e in _examples(c)]


def test_help_has_examples_to_run() -> None:
    assert {c for c, _ in EXAMPLES} >= {"record", "simulate"}


@pytest.mark.parametrize(("command", "argv"), EXAMPLES, ids=[c for c, _ in EXAMPLES])
def test_help_example_runs_as_printed(command: str, argv: list[str], tmp_path: Path,
                                      monkeypatch: pytest.MonkeyPatch,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    assert argv[0] == "station" and argv[1] == command
    status = main(_shortened(argv))
    out, err = capsys.readouterr()
    assert status == 0, f"{shlex.join(argv)}: {out} {err}"
    if command == "record":
        assert json.loads(out)["state"] == "checked"


def test_profile_model_file_found_from_any_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    from station.model.profiles import PROFILE_DIR, load_profile

    monkeypatch.chdir(tmp_path)  # no profiles/ here
    url = str(load_profile("VG951").transport["url"])
    model = Path(re.search(r"model=([^&]+)", url).group(1))  # type: ignore[union-attr]
    assert model.is_absolute() and model == (PROFILE_DIR / "models" / "VG951.toml").resolve()
    assert main(["record", "--check", "--profile", "VG951"]) == 0
    assert json.loads(capsys.readouterr().out)["state"] == "checked"


def test_profile_model_path_relative_to_the_profile_file(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    from station.model.profiles import PROFILE_DIR, load_profile

    own = tmp_path / "mine"
    (own / "noise").mkdir(parents=True)
    (own / "noise" / "gyro.toml").write_text(
        (PROFILE_DIR / "models" / "CRG20.toml").read_text())
    text = (PROFILE_DIR / "VG951.toml").read_text().replace(
        "model=models/VG951.toml", "model=noise/gyro.toml")
    (own / "P.toml").write_text(text)
    monkeypatch.chdir(tmp_path)
    url = str(load_profile(own / "P.toml").transport["url"])
    assert f"model={(own / 'noise' / 'gyro.toml').resolve()}" in url


def test_package_data_ships_profiles_and_models() -> None:
    import tomllib

    data = tomllib.loads(Path(__file__).parents[1].joinpath("pyproject.toml").read_text())
    files = data["tool"]["setuptools"]["data-files"]
    assert files["share/gyro-station/profiles/models"] == ["profiles/models/*.toml"]
    assert files["share/gyro-station/profiles"] == ["profiles/*.toml"]


def test_devices_prints_urls_a_shipped_profile_accepts(capsys: pytest.CaptureFixture[str]) -> None:
    from devices.urls import SUPPORTED

    assert main(["devices"]) == 0
    lines = [line.split("record:", 1)[1] for line in capsys.readouterr().out.splitlines()
             if line.strip().startswith("record:    station")]
    assert len(lines) == len(SUPPORTED)
    by_profile: dict[str, list[str]] = {}
    for line in lines:
        argv = shlex.split(line)
        assert argv[:3] == ["station", "record", "--check"]
        by_profile.setdefault(argv[4], []).append(argv[6])
    for profile, urls in by_profile.items():  # one check per profile, every unit at once
        argv = ["record", "--check", "--profile", profile]
        for url in urls:
            argv += ["--unit", url]
        status = main(argv)
        answer = json.loads(capsys.readouterr().out)
        assert status == 0 and answer["state"] == "checked", answer["problems"]


@pytest.mark.parametrize("command", ["analyze", "grade", "report"])
def test_several_files_point_to_fleet(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        main([command, "a.csv", "b.csv", "c.csv"])
    err = capsys.readouterr().err
    assert stop.value.code == 2 and err.count("\n") == 1
    assert "unrecognized arguments: b.csv c.csv" in err
    assert f"station fleet {command}" in err


def test_simulate_quiet_prints_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "q.csv"
    assert main(["simulate", "--model", "VG951", "--duration", "60s", "--quiet",
                 "--out", str(out)]) == 0
    assert capsys.readouterr() == ("", "") and out.is_file()
    assert main(["simulate", "--model", "VG951", "--duration", "60s", "--out", str(out)]) == 0
    assert "wrote 600 samples" in capsys.readouterr().err  # without --quiet it says so
