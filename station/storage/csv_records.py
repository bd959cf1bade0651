"""Rate records on disk: read a CSV (plain or gzip'd) into a :class:`RateRecord`, write one back.

CSV format (the interface other commands rely on):

* lines starting with ``#`` are comments (anywhere in the file);
* the first other line is a header naming the columns;
* an optional ``time`` column (also ``time_s`` or ``t``) in seconds; without it the
  sample rate must be given (``--rate HZ``). A step of the time column that spans
  several sample periods (within 1 % of a whole number of them) is a gap: the samples
  it skips are missing, and the analysis leaves them out rather than joining the two
  sides (``RateRecord.sample_index``);
* every other column is one gyro axis, in deg/s unless ``units`` says otherwise
  (``rad/s``, ``deg/h``);
* ``.csv.gz`` files are read directly.
"""

from __future__ import annotations

import gzip
import io
import math
import warnings
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
    sample_index : ndarray of int or None
        Where each sample sits on the record's time grid (sample ``i`` was taken
        ``sample_index[i] / sample_rate_hz`` s after the first, so ``sample_index[0]``
        is 0): samples missing in gaps are skipped indices. None for a record without
        gaps (the indices are then ``0 .. N - 1``).
    """

    rate_deg_s: NDArray[np.float64]
    sample_rate_hz: float
    axis_names: tuple[str, ...]
    source: str = ""
    temperature_c: NDArray[np.float64] | None = field(default=None)
    sample_index: NDArray[np.int64] | None = field(default=None)

    @property
    def n_samples(self) -> int:
        """Number of samples per axis (those present; missing ones are not counted)."""
        return int(self.rate_deg_s.shape[0])

    @property
    def span_samples(self) -> int:
        """Length of the record on its time grid, missing samples included."""
        return self.n_samples if self.sample_index is None else int(self.sample_index[-1]) + 1

    @property
    def duration_s(self) -> float:
        """Length of the record in seconds of true time (gaps included)."""
        return self.span_samples / self.sample_rate_hz

    @property
    def missing_samples(self) -> int:
        """Samples missing in gaps inside the record."""
        return self.span_samples - self.n_samples

    def present_mask(self) -> NDArray[np.bool_]:
        """True at each grid index that holds a sample (length :attr:`span_samples`)."""
        mask = np.zeros(self.span_samples, dtype=bool)
        mask[slice(None) if self.sample_index is None else self.sample_index] = True
        return mask

    def gridded(self, column: int) -> NDArray[np.float64]:
        """One axis' rate (deg/s) on the time grid, NaN where a sample is missing."""
        if self.sample_index is None:
            return self.rate_deg_s[:, column]
        out = np.full(self.span_samples, np.nan)
        out[self.sample_index] = self.rate_deg_s[:, column]
        return out

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
                          (self.axis_names[index],), self.source, self.temperature_c,
                          self.sample_index)

    def slice_time(self, start_s: float = 0.0, stop_s: float | None = None) -> RateRecord:
        """The part of the record between ``start_s`` and ``stop_s`` (seconds of true time
        from its start, gaps included); the slice starts at its first sample present."""
        i0 = max(0, int(round(start_s * self.sample_rate_hz)))
        i1 = self.span_samples if stop_s is None else int(round(stop_s * self.sample_rate_hz))
        if self.sample_index is None:
            k0, k1 = min(i0, self.n_samples), min(max(i1, i0), self.n_samples)
        else:
            k0, k1 = (int(k) for k in np.searchsorted(self.sample_index, [i0, max(i1, i0)]))
        if k1 - k0 < 2:
            raise RecordFormatError(
                f"time slice {start_s}..{stop_s} s leaves fewer than 2 samples of a "
                f"{self.duration_s:.1f} s record"
            )
        temp = None if self.temperature_c is None else self.temperature_c[k0:k1]
        index = None if self.sample_index is None else regular_or_none(self.sample_index[k0:k1])
        return RateRecord(self.rate_deg_s[k0:k1], self.sample_rate_hz, self.axis_names,
                          self.source, temp, index)


def regular_or_none(sample_index: NDArray[np.int64]) -> NDArray[np.int64] | None:
    """Grid indices made to start at 0, or None when they have no gap (a contiguous record).

    Raises
    ------
    RecordFormatError
        Indices that do not increase (two samples at one time, or out of order).
    """
    index = np.asarray(sample_index, dtype=np.int64)
    if len(index) and np.any(np.diff(index) < 1):
        row = int(np.argmax(np.diff(index) < 1)) + 1
        raise RecordFormatError(f"sample {row} is not later than the one before it on the time grid")
    index = index - index[0] if len(index) else index
    return None if not len(index) or index[-1] == len(index) - 1 else index


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
    fs, index = _time_grid(path, data, time_index, sample_rate_hz)
    rate = data[:, axis_idx] * UNIT_TO_DEG_S[units]
    bad = ~np.isfinite(rate)
    if bad.any():
        row = int(np.argmax(bad.any(axis=1)))
        raise RecordFormatError(f"{path}: non-finite rate in data row {row + 1}; clean the file first")
    temp = None if temp_index is None else data[:, temp_index].copy()
    return RateRecord(np.ascontiguousarray(rate), fs, tuple(header[i] for i in axis_idx), str(path), temp,
                      index)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


#: A time step within this fraction of a sample period of a whole number of periods is regular.
TIME_STEP_TOLERANCE = 0.01


def _time_grid(path: Path, data: NDArray[np.float64], time_index: int | None, given: float | None
               ) -> tuple[float, NDArray[np.int64] | None]:
    """(sample rate in Hz, grid index of each row or None when the rows have no gap).

    The time column decides the gaps: a step of k periods (k >= 2, within 1 % of a
    period) means k - 1 missing samples. With ``--rate`` given, the time column counts
    only when its own period agrees with that rate and every step is a whole number of
    periods; otherwise it is ignored, as the option promises.
    """
    if given is not None and not (math.isfinite(given) and given > 0):
        raise RecordFormatError(f"sample rate must be a positive number of Hz, got {given}")
    if time_index is None:
        if given is None:
            raise RecordFormatError(f"{path}: no time column; give the sample rate with --rate HZ")
        return float(given), None
    t = data[:, time_index]
    if len(t) < 2:
        if given is None:
            raise RecordFormatError(f"{path}: one row is not enough to know the sample rate; give --rate HZ")
        return float(given), None
    dt = np.diff(t)
    period = float(np.median(dt)) if given is None else 1.0 / float(given)
    if given is None and not period > 0:
        raise RecordFormatError(f"{path}: time column does not increase")
    if given is not None and abs(float(np.median(dt)) - period) > TIME_STEP_TOLERANCE * period:
        return float(given), None  # the time column is in another unit or at another rate
    steps = np.rint(dt / period)
    off = (steps < 1) | (np.abs(dt - steps * period) > TIME_STEP_TOLERANCE * period)
    if off.any():
        if given is not None:
            return float(given), None
        row = int(np.argmax(off)) + 1
        raise RecordFormatError(
            f"{path}: irregular time stamps ({int(off.sum())} steps are not a whole number of "
            f"{period} s periods within 1 %, first after data row {row}); resample or give "
            f"--rate HZ to ignore the time column"
        )
    if given is None and np.all(steps == 1):
        return 1.0 / period, None
    index = np.concatenate(([0], np.cumsum(steps))).astype(np.int64)
    return 1.0 / period, regular_or_none(index)


def write_csv_record(
    path: str | Path,
    rate_deg_s: NDArray[np.float64],
    sample_rate_hz: float,
    *,
    axis_names: Sequence[str] | None = None,
    comment: str = "",
    temperature_c: NDArray[np.float64] | None = None,
    sample_index: NDArray[np.int64] | None = None,
) -> Path:
    """Write a rate record as CSV (``time`` in s, one column per axis in deg/s); gzip if ``.gz``.

    ``sample_index`` (grid index of each row, see :class:`RateRecord`) writes the times
    of a record with gaps, so that reading it back finds them.
    """
    path = Path(path)
    rate = np.asarray(rate_deg_s, dtype=float)
    if rate.ndim == 1:
        rate = rate[:, None]
    names = list(axis_names or [f"gyro_{c}" for c in "xyz"[: rate.shape[1]]] or [])
    if len(names) != rate.shape[1]:
        names = [f"axis_{i}" for i in range(rate.shape[1])]
    grid = np.arange(rate.shape[0]) if sample_index is None else np.asarray(sample_index)
    columns = [grid / sample_rate_hz, *rate.T]
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
    if path.suffix.lower() in (".h5", ".hdf5"):
        from station.hdf5 import read_run_record  # the recorder's layout (imports this module)

        return read_run_record(path, unit)
    if unit is not None:
        raise RecordFormatError(f"{path}: --unit applies to run files (.h5) only")
    suffixes = "".join(path.suffixes[-2:]).lower()
    if suffixes.endswith(".csv") or suffixes.endswith(".csv.gz") or path.suffix.lower() == ".txt":
        return read_csv_record(path, sample_rate_hz=sample_rate_hz, units=units)
    raise RecordFormatError(f"{path}: unknown record type; expected .csv, .csv.gz or .h5")
