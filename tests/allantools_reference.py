"""The Stable32 reference files that allantools ships in its source distribution.

allantools' PyPI sdist holds its test directory: ``tests/phasedat`` (PHASE.DAT, the phase
file distributed with Stable32, and Stable32's outputs for it), ``tests/gps`` (GPS 1PPS
against an H-maser, Stable32 1.53 outputs) and ``tests/Cs5071A`` (a 5071A caesium clock
against an H-maser, Stable32 outputs). Nothing of it is committed here: the fixture
downloads the sdist of the installed allantools version the way a user would
(``pip download --no-deps --no-binary :all:``), extracts only those files into the pytest
cache and reuses them on later runs. Offline, point ``GYRO_ALLANTOOLS_SDIST`` at a copy of
the sdist. If neither works, the tests that need the files fail and say why.
"""

from __future__ import annotations

import gzip
import importlib.metadata
import os
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

import numpy as np
import pytest

#: Folders of allantools' tests directory that hold Stable32 reference data.
REFERENCE_FOLDERS = ("phasedat", "gps", "Cs5071A")
_DATA_SUFFIXES = (".txt", ".dat", ".gz")


def _download_sdist(version: str, into: Path) -> Path:
    local = os.environ.get("GYRO_ALLANTOOLS_SDIST")
    if local:
        return Path(local)
    cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "--no-binary", ":all:",
           f"allantools=={version}", "-d", str(into)]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    except (OSError, subprocess.TimeoutExpired) as exc:
        pytest.fail(
            f"cannot download the allantools {version} sdist for its Stable32 reference files "
            f"({exc}); set GYRO_ALLANTOOLS_SDIST to a local allantools-{version}.tar.gz"
        )
    found = sorted(into.glob("allantools-*.tar.gz")) + sorted(into.glob("AllanTools-*.tar.gz"))
    if proc.returncode != 0 or not found:
        pytest.fail(
            f"`{' '.join(cmd)}` failed (exit {proc.returncode}): {proc.stderr.strip()[-800:]}; "
            f"set GYRO_ALLANTOOLS_SDIST to a local allantools-{version}.tar.gz"
        )
    return found[0]


def _extract(sdist: Path, root: Path) -> None:
    with tarfile.open(sdist) as tar:
        for member in tar.getmembers():
            parts = Path(member.name).parts
            if (
                member.isfile()
                and len(parts) == 4
                and parts[1] == "tests"
                and parts[2] in REFERENCE_FOLDERS
                and parts[3].lower().endswith(_DATA_SUFFIXES)
            ):
                target = root / parts[2] / parts[3]  # our own path: nothing in the archive picks it
                target.parent.mkdir(parents=True, exist_ok=True)
                source = tar.extractfile(member)
                assert source is not None
                target.write_bytes(source.read())


@pytest.fixture(scope="session")
def allantools_tests(pytestconfig: pytest.Config, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Folder holding ``phasedat/``, ``gps/`` and ``Cs5071A/`` of allantools' test data:
    in pytest's cache (kept between runs), or a temporary folder with ``-p no:cacheprovider``."""
    version = importlib.metadata.version("allantools")
    name = f"allantools-{version}-reference"
    cache = getattr(pytestconfig, "cache", None)
    root = Path(cache.mkdir(name)) if cache is not None else tmp_path_factory.mktemp(name)
    done = root / "extracted"
    if not done.exists():
        with tempfile.TemporaryDirectory() as tmp:
            sdist = _download_sdist(version, Path(tmp))
            try:
                _extract(sdist, root)
            except (OSError, tarfile.TarError) as exc:
                pytest.fail(f"cannot read the allantools sdist {sdist}: {exc}")
        missing = [f for f in REFERENCE_FOLDERS if not (root / f).is_dir()]
        if missing:
            pytest.fail(f"the allantools {version} sdist has no tests/{', tests/'.join(missing)}")
        done.write_text(version)
    return root


def read_phase(path: Path) -> np.ndarray:
    """Phase values (first column) of a reference data file, '#' lines skipped."""
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt", errors="replace") as f:
        return np.array(
            [
                float(line.split()[0])
                for line in f
                if line.strip() and not line.lstrip().startswith("#")
            ]
        )


def read_stable32(path: Path) -> tuple[str, np.ndarray]:
    """(sigma type, rows) of a Stable32 output file: AF, tau, #, alpha, min, sigma, max."""
    sigma = ""
    rows = []
    with open(path, encoding="utf-8", errors="replace") as f:
        for line in f:
            if "Sigma Type:" in line:
                sigma = line.split(":", 1)[1].strip()
            elif line.strip() and not line.lstrip().startswith("#"):
                rows.append([float(v) for v in line.split()])
    return sigma, np.array(rows)


#: Stable32's sigma type -> our deviation name.
STABLE32_KINDS = {
    "Allan": "adev", "Overlapping Allan": "oadev", "Modified Allan": "mdev", "Time": "tdev",
    "Hadamard": "hdev", "Overlapping Hadamard": "ohdev", "Total": "totdev", "Thêo1": "theo1",
}
