"""Every refusal is one line on stderr and exit status 2: a port in use, an empty serial
number, a CSV header naming a column twice, a negative reserve, a unit the recorder
refuses."""

from __future__ import annotations

import socket
from pathlib import Path

from station.cli import main


def _refused(args: list[str], capsys) -> str:
    """``station ARGS``' one line of refusal (exit 2; argparse's exit through SystemExit)."""
    try:
        status = main(args)
    except SystemExit as exc:
        status = int(exc.code or 0)
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert status == 2 and len(lines) == 1, (status, captured.err)
    assert "Traceback" not in captured.err
    return lines[0]


def test_a_port_in_use_is_one_line(tmp_path: Path, capsys) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        line = _refused(["serve", "--db", str(tmp_path / "r.sqlite"), "--port", str(port)],
                        capsys)
    assert f"--port {port}" in line and "in use" in line
    assert not (tmp_path / "r.sqlite").exists()


def test_bad_values_are_refused_in_one_line(tmp_path: Path, capsys) -> None:
    record = tmp_path / "dup.csv"
    record.write_text("time,x,x\n" + "".join(f"{i / 10},0.1,0.2\n" for i in range(100)))
    assert "repeats 'x'" in _refused(["analyze", str(record)], capsys)
    assert "repeats 'x'" in _refused(["grade", str(record), "--no-store"], capsys)
    record.write_text("time,x,y\n" + "".join(f"{i / 10},0.1,0.2\n" for i in range(100)))
    for serial in ("", "   "):
        line = _refused(["grade", str(record), "--serial", serial, "--no-store"], capsys)
        assert "--serial" in line and "empty serial" in line
    line = _refused(["record", "--unit", "sim+serial://VG951?rate=10", "--duration", "10s",
                     "--reserve-mb", "-1", "--out", str(tmp_path / "runs")], capsys)
    assert "--reserve-mb -1" in line
    assert not (tmp_path / "runs").exists()


def test_a_run_the_recorder_refuses_is_one_line(tmp_path: Path, capsys) -> None:
    line = _refused(["record", "--profile", "VG951", "--unit", "sim+serial://VG951?rate=200",
                     "--duration", "10s", "--quiet", "--out", str(tmp_path / "runs")], capsys)
    assert line.startswith("station record: error: the run was not started: unit1")
    assert "200 Hz" in line and "10 Hz" in line
