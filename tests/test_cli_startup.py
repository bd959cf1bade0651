"""``station --help`` starts at once: a command's module (and scipy, matplotlib, numba,
h5py, the device libraries it imports) is imported only when that command runs."""

from __future__ import annotations

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


def test_a_command_imports_what_it_needs_when_named() -> None:
    """``station analyze --help`` builds analyze's own parser (its choices come from the
    analysis), and still does not start numba or the TUI."""
    loaded = _modules_after(["analyze", "--help"])
    assert "scipy" in loaded
    assert not {"textual", "numba"} & set(loaded)
