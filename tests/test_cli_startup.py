"""``station --help`` and every ``station COMMAND --help`` start at once: scipy,
matplotlib, numba, the TUI and the device libraries are imported by the functions that do
a command's work, never by its parser."""

from __future__ import annotations

import json
import subprocess
import sys

HEAVY = ("scipy", "matplotlib", "numba", "h5py", "textual", "can", "serial", "pymodbus", "canopen")


def _modules_after(argv: list[str]) -> list[str]:
    code = (
        f"import sys\nfrom station.cli import main\ntry:\n    main({argv!r})\n"
        f"except SystemExit:\n    pass\n"
        f"print('loaded:', *(m for m in {HEAVY!r} if m in sys.modules))"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    return run.stdout.strip().splitlines()[-1].split()[1:]


def test_help_imports_no_heavy_library_and_lists_every_command() -> None:
    assert _modules_after(["--help"]) == []
    run = subprocess.run(
        [sys.executable, "-m", "station", "--help"], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0
    for name in ("analyze", "record", "grade", "report", "tui", "davar", "recover"):
        assert f"    {name}" in run.stdout, name


#: What no sub-command imports for ``--help``, a refused argument or a completing shell
#: (h5py may be: 0.05 s, and ``watch``/``recover`` read run files by it).
NOT_FOR_HELP = tuple(m for m in HEAVY if m != "h5py")


def test_no_command_imports_scipy_matplotlib_or_numba_for_help_errors_or_completion() -> None:
    """Every sub-command's ``--help`` and argument errors, and the parser a completing shell
    gets (every command registered), import none of scipy, matplotlib, numba, the TUI or
    the device libraries: they come with the work a command does (issue 40 part 1). One
    process for all: what any command imported stays in ``sys.modules``, so each command
    is checked for what it added."""
    code = f"""
import contextlib, io, json, sys
from station.cli import build_parser, main
from station.commands import COMMAND_HELP
loaded = {{}}
for name in COMMAND_HELP:
    before = {{m for m in {NOT_FOR_HELP!r} if m in sys.modules}}
    for argv in ([name, "--help"], [name, "--no-such-option"]):
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            try:
                main(argv)
            except SystemExit as exc:
                assert exc.code == (0 if argv[1] == "--help" else 2), (argv, exc.code)
    loaded[name] = sorted({{m for m in {NOT_FOR_HELP!r} if m in sys.modules}} - before)
build_parser(None)
loaded["(completion)"] = sorted(m for m in {NOT_FOR_HELP!r} if m in sys.modules)
print(json.dumps(loaded))
"""
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    loaded = json.loads(run.stdout.strip().splitlines()[-1])
    assert "analyze" in loaded and "tui" in loaded
    assert {name: mods for name, mods in loaded.items() if mods} == {}
