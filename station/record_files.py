"""Rate records on disk: read a CSV (plain or gzip'd) into a :class:`RateRecord`, write one back.

CSV format (the interface other commands rely on):

* lines starting with ``#`` are comments (anywhere in the file);
* the first other line is a header naming the columns;
* an optional ``time`` column (also ``time_s`` or ``t``) in seconds; without it the
  sample rate must be given (``--rate HZ``);
* every other column is one gyro axis, in deg/s unless ``units`` says otherwise
  (``rad/s``, ``deg/h``);
* ``.csv.gz`` files are read directly.
"""

from __future__ import annotations

import gzip
import io
import math
import warnings
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import numpy as np
from numpy.typing import NDArray

from station.errors import RecordFormatError

#: Factor from each accepted input unit to deg/s.
UNIT_TO_DEG_S = {"deg/s": 1.0, "rad/s": 180.0 / math.pi, "deg/h": 1.0 / 3600.0}
TIME_COLUMNS = ("time", "time_s", "t")


@dataclass(frozen=True)
class RateRecord:
    """A static gyro record in memory.

    Attributes
    ----------
    rate_deg_s : ndarray, shape (N, k)
        Rate per axis in deg/s.
    sample_rate_hz : float
        Sample rate in Hz.
    axis_names : tuple of str
        One name per column of ``rate_deg_s``.
    source : str
        Where the record came from (a path), for reports.
    temperature_c : ndarray or None
        Temperature in degC per sample, when the record has one.
    """

    rate_deg_s: NDArray[np.float64]
    sample_rate_hz: float
    axis_names: tuple[str, ...]
    source: str = ""
    temperature_c: NDArray[np.float64] | None = field(default=None)

    @property
    def n_samples(self) -> int:
        """Number of samples per axis."""
        return int(self.rate_deg_s.shape[0])

    @property
    def duration_s(self) -> float:
        """Length of the record in seconds."""
        return self.n_samples / self.sample_rate_hz

    def select(self, axis: str | int) -> RateRecord:
        """A record with only one axis, chosen by name or index."""
        if isinstance(axis, str):
            if axis not in self.axis_names:
                raise RecordFormatError(
                    f"no axis {axis!r} in {self.source or 'the record'}; axes: {', '.join(self.axis_names)}"
                )
            index = self.axis_names.index(axis)
        else:
            index = axis
        return RateRecord(self.rate_deg_s[:, index : index + 1], self.sample_rate_hz,
                          (self.axis_names[index],), self.source, self.temperature_c)

    def slice_time(self, start_s: float = 0.0, stop_s: float | None = None) -> RateRecord:
        """The part of the record between ``start_s`` and ``stop_s`` (seconds from its start)."""
        i0 = max(0, int(round(start_s * self.sample_rate_hz)))
        i1 = self.n_samples if stop_s is None else int(round(stop_s * self.sample_rate_hz))
        if i1 - i0 < 2:
            raise RecordFormatError(
                f"time slice {start_s}..{stop_s} s leaves fewer than 2 samples of a "
                f"{self.duration_s:.1f} s record"
            )
        temp = None if self.temperature_c is None else self.temperature_c[i0:i1]
        return RateRecord(self.rate_deg_s[i0:i1], self.sample_rate_hz, self.axis_names,
                          self.source, temp)


def _open_text(path: Path) -> IO[str]:
    if path.suffix == ".gz":
        return io.TextIOWrapper(gzip.open(path, "rb"), encoding="utf-8")
    return open(path, encoding="utf-8")


def read_csv_record(
    path: str | Path, *, sample_rate_hz: float | None = None, units: str = "deg/s"
) -> RateRecord:
    """Read a CSV rate record (see the module docstring for the format).

    Parameters
    ----------
    path : str or Path
        ``.csv`` or ``.csv.gz`` file.
    sample_rate_hz : float, optional
        Sample rate in Hz; required when the file has no time column, and preferred over
        the time column when both are present.
    units : {"deg/s", "rad/s", "deg/h"}
        Unit of the rate columns; converted to deg/s.

    Raises
    ------
    RecordFormatError
        Unknown unit, no header, no axis column, unparsable or non-finite values,
        irregular time stamps, or no way to know the sample rate.
    """
    path = Path(path)
    if units not in UNIT_TO_DEG_S:
        raise RecordFormatError(f"unknown rate unit {units!r}; use one of {', '.join(UNIT_TO_DEG_S)}")
    try:
        return _read_csv(path, sample_rate_hz, units)
    except (UnicodeDecodeError, EOFError, zlib.error, gzip.BadGzipFile) as exc:
        raise RecordFormatError(f"{path}: not a text CSV record (its bytes are not UTF-8 "
                                f"text{' compressed with gzip' if path.suffix == '.gz' else ''}"
                                f": {type(exc).__name__}); give a CSV file or a run file "
                                f"(.h5)") from None


def _read_csv(path: Path, sample_rate_hz: float | None, units: str) -> RateRecord:
    with _open_text(path) as fh:
        header: list[str] | None = None
        header_line = 0
        for lineno, line in enumerate(fh, start=1):
            stripped = line.strip()
            if stripped and not stripped.startswith("#"):
                header = [h.strip() for h in stripped.split(",")]
                header_line = lineno
                break
        if header is None:
            raise RecordFormatError(f"{path}: no header line (only comments or empty)")
        if any(_is_number(h) for h in header):
            raise RecordFormatError(
                f"{path}:{header_line}: the first non-comment line must be a header naming the "
                f"columns (e.g. 'time,gyro_x'), got {','.join(header)!r}"
            )
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)  # "no data": reported below
                data = np.loadtxt(fh, delimiter=",", comments="#", ndmin=2, dtype=np.float64)
        except ValueError as exc:
            raise RecordFormatError(f"{path}: cannot parse the values after line {header_line}: {exc}") from exc
    if data.shape[0] == 0:
        raise RecordFormatError(f"{path}: header but no data rows")
    if data.shape[1] != len(header):
        raise RecordFormatError(f"{path}: {data.shape[1]} values per row, header names {len(header)} columns")
    lower = [h.lower() for h in header]
    time_index = next((lower.index(c) for c in TIME_COLUMNS if c in lower), None)
    temp_index = next((i for i, h in enumerate(lower) if h in ("temperature_c", "temp_c", "temperature")), None)
    axis_idx = [i for i in range(len(header)) if i not in (time_index, temp_index)]
    if not axis_idx:
        raise RecordFormatError(f"{path}: no rate column besides time/temperature")
    fs = _sample_rate(path, data, time_index, sample_rate_hz)
    rate = data[:, axis_idx] * UNIT_TO_DEG_S[units]
    bad = ~np.isfinite(rate)
    if bad.any():
        row = int(np.argmax(bad.any(axis=1)))
        raise RecordFormatError(f"{path}: non-finite rate in data row {row + 1}; clean the file first")
    temp = None if temp_index is None else data[:, temp_index].copy()
    return RateRecord(np.ascontiguousarray(rate), fs, tuple(header[i] for i in axis_idx), str(path), temp)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _sample_rate(path: Path, data: NDArray[np.float64], time_index: int | None, given: float | None) -> float:
    if given is not None:
        if not (math.isfinite(given) and given > 0):
            raise RecordFormatError(f"sample rate must be a positive number of Hz, got {given}")
        return float(given)
    if time_index is None:
        raise RecordFormatError(f"{path}: no time column; give the sample rate with --rate HZ")
    t = data[:, time_index]
    if len(t) < 2:
        raise RecordFormatError(f"{path}: one row is not enough to know the sample rate; give --rate HZ")
    dt = np.diff(t)
    period = float(np.median(dt))
    if not period > 0:
        raise RecordFormatError(f"{path}: time column does not increase")
    off = np.abs(dt - period) > 0.01 * period
    if off.any():
        row = int(np.argmax(off)) + 1
        raise RecordFormatError(
            f"{path}: irregular time stamps ({int(off.sum())} steps differ from {period} s by >1 %, "
            f"first after data row {row}); resample or give --rate HZ to ignore the time column"
        )
    return 1.0 / period


def write_csv_record(
    path: str | Path,
    rate_deg_s: NDArray[np.float64],
    sample_rate_hz: float,
    *,
    axis_names: Sequence[str] | None = None,
    comment: str = "",
    temperature_c: NDArray[np.float64] | None = None,
) -> Path:
    """Write a rate record as CSV (``time`` in s, one column per axis in deg/s); gzip if ``.gz``."""
    path = Path(path)
    rate = np.asarray(rate_deg_s, dtype=float)
    if rate.ndim == 1:
        rate = rate[:, None]
    names = list(axis_names or [f"gyro_{c}" for c in "xyz"[: rate.shape[1]]] or [])
    if len(names) != rate.shape[1]:
        names = [f"axis_{i}" for i in range(rate.shape[1])]
    columns = [np.arange(rate.shape[0]) / sample_rate_hz, *rate.T]
    header = ["time", *names]
    if temperature_c is not None:
        columns.append(np.asarray(temperature_c, dtype=float))
        header.append("temperature_c")
    table = np.column_stack(columns)
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "wt", encoding="utf-8") as fh:
        for line in comment.splitlines():
            fh.write(f"# {line}\n")
        fh.write(",".join(header) + "\n")
        np.savetxt(fh, table, delimiter=",", fmt="%.17g")
    return path


def read_record(
    path: str | Path, *, sample_rate_hz: float | None = None, units: str = "deg/s",
    unit: str | None = None,
) -> RateRecord:
    """Read a rate record from any supported file type: CSV (plain or gzip'd) or a run file.

    Parameters
    ----------
    path : str or Path
        ``.csv``, ``.csv.gz``, ``.txt``, or a recorder run file (``.h5``/``.hdf5``).
    sample_rate_hz, units
        For CSV records only (see :func:`read_csv_record`); a run file carries both.
    unit : str, optional
        For run files: the unit id (``unit2``) or serial number; default the first unit.

    Raises
    ------
    RecordFormatError
        Unknown file type, unreadable file, or no such unit.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(2, "No such file", str(path))
    if path.is_dir():
        raise RecordFormatError(f"{path} is a directory, not a record: give a file in it")
    if path.suffix.lower() in (".h5", ".hdf5"):
        from station.hdf5 import read_run_record  # the recorder's layout (imports this module)

        return read_run_record(path, unit)
    if unit is not None:
        raise RecordFormatError(f"{path}: --unit applies to run files (.h5) only")
    suffixes = "".join(path.suffixes[-2:]).lower()
    if suffixes.endswith(".csv") or suffixes.endswith(".csv.gz") or path.suffix.lower() == ".txt":
        return read_csv_record(path, sample_rate_hz=sample_rate_hz, units=units)
    raise RecordFormatError(f"{path}: unknown record type; expected .csv, .csv.gz or .h5")
