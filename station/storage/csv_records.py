"""Rate records on disk: read a CSV (plain or gzip'd) into a :class:`RateRecord`, write one back.

CSV format (the interface other commands rely on):

* lines starting with ``#`` are comments (anywhere in the file);
* the first other line is a header naming the columns;
* an optional ``time`` column (also ``time_s`` or ``t``) in seconds; without it the
  sample rate must be given (``--rate HZ``). A step of the time column that spans
  several sample periods (within 1 % of a whole number of them) is a gap: the samples
  it skips are missing, and the analysis leaves them out rather than joining the two
  sides (``RateRecord.sample_index``);
* a column named ``accel_*`` or ``acc_*`` is one accelerometer axis, in m/s^2 unless
  ``accel_units`` says otherwise (``g``, ``mg``), read into ``RateRecord.accel_m_s2``;
* every other column is one gyro axis, in deg/s unless ``units`` says otherwise
  (``rad/s``, ``deg/h``); a record of accelerometer columns only has no gyro axis
  (``rate_deg_s`` of shape (N, 0));
* ``.csv.gz`` files are read directly.
"""

from __future__ import annotations

import gzip
import io
import math
import re
import warnings
import zlib
from collections.abc import Sequence
from pathlib import Path
from typing import IO

import numpy as np
from numpy.typing import NDArray

from station.errors import RecordFormatError
from station.model.records import RateRecord, regular_or_none
from station.model.wording import plural

#: Factor from each accepted input unit to deg/s.
UNIT_TO_DEG_S = {"deg/s": 1.0, "rad/s": 180.0 / math.pi, "deg/h": 1.0 / 3600.0}
TIME_COLUMNS = ("time", "time_s", "t")
#: Standard gravity (m/s^2): the unit g.
_G = 9.80665
#: Factor from each accepted accelerometer input unit to m/s^2.
UNIT_TO_M_S2 = {"m/s^2": 1.0, "g": _G, "mg": _G * 1e-3}
#: Column-name prefixes of accelerometer axes.
ACCEL_PREFIXES = ("accel_", "acc_")


def is_accel_column(name: str) -> bool:
    """Whether a CSV column (by its header name) is an accelerometer axis."""
    return name.strip().lower().startswith(ACCEL_PREFIXES)


def check_units(units: str, accel_units: str) -> None:
    """Refuse a rate unit or an accelerometer unit the reader does not know, or one given
    for the other quantity.

    Raises
    ------
    RecordFormatError
        One line naming the unit.
    """
    if units not in UNIT_TO_DEG_S:
        kind = " is an acceleration unit" if units in UNIT_TO_M_S2 else ""
        raise RecordFormatError(
            f"unknown rate unit {units!r}{kind}; --units takes {', '.join(UNIT_TO_DEG_S)} "
            f"(accel_* columns take --accel-units)"
        )
    if accel_units not in UNIT_TO_M_S2:
        kind = " is a rate unit" if accel_units in UNIT_TO_DEG_S else " is not one"
        raise RecordFormatError(
            f"accelerometer unit {accel_units!r}{kind}; --accel-units takes "
            f"{', '.join(UNIT_TO_M_S2)} for the accel_* columns"
        )


def _open_text(path: Path) -> IO[str]:
    if path.suffix == ".gz":
        return io.TextIOWrapper(gzip.open(path, "rb"), encoding="utf-8")
    return open(path, encoding="utf-8")


def read_csv_record(
    path: str | Path, *, sample_rate_hz: float | None = None, units: str = "deg/s",
    accel_units: str = "m/s^2",
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
    accel_units : {"m/s^2", "g", "mg"}
        Unit of the accelerometer columns (``accel_*``, ``acc_*``); converted to m/s^2.

    Raises
    ------
    RecordFormatError
        Unknown unit (or a rate unit for the accelerometers), a column name that says a
        rate unit on an accelerometer axis, no header, no axis column, unparsable or
        non-finite values, irregular time stamps, or no way to know the sample rate.
    """
    path = Path(path)
    check_units(units, accel_units)
    try:
        return _read_csv(path, sample_rate_hz, units, accel_units)
    except (UnicodeDecodeError, EOFError, zlib.error, gzip.BadGzipFile) as exc:
        raise RecordFormatError(f"{path}: not a text CSV record (its bytes are not UTF-8 "
                                f"text{' compressed with gzip' if path.suffix == '.gz' else ''}"
                                f": {type(exc).__name__}); give a CSV file or a run file "
                                f"(.h5)") from None


def _read_csv(path: Path, sample_rate_hz: float | None, units: str,
              accel_units: str) -> RateRecord:
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
        named = [h.lower() for h in header if h]
        repeated = sorted({h for h in named if named.count(h) > 1})
        if repeated:  # two columns of one axis: which would be graded?
            raise RecordFormatError(
                f"{path}:{header_line}: the header names each column once, it repeats "
                f"{', '.join(repr(h) for h in repeated)} ({','.join(header)!r})")
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
            message = _parse_error(path, header_line, len(header), str(exc))
            raise RecordFormatError(message) from None
    if data.shape[0] == 0:
        raise RecordFormatError(f"{path}: header but no data rows")
    if data.shape[1] != len(header):
        raise RecordFormatError(
            f"{path}: {data.shape[1]} values per row, header names {len(header)} columns"
        )
    lower = [h.lower() for h in header]
    time_index = next((lower.index(c) for c in TIME_COLUMNS if c in lower), None)
    temp_index = next(
        (i for i, h in enumerate(lower) if h in ("temperature_c", "temp_c", "temperature")), None
    )
    columns = [i for i in range(len(header)) if i not in (time_index, temp_index)]
    accel_idx = [i for i in columns if is_accel_column(header[i])]
    axis_idx = [i for i in columns if i not in accel_idx]
    for i in accel_idx:
        _check_accel_name(path, header[i])
    if not axis_idx and not accel_idx:
        raise RecordFormatError(f"{path}: no rate or accelerometer column besides "
                                f"time/temperature")
    fs, index = _time_grid(path, data, time_index, sample_rate_hz)
    rate = data[:, axis_idx] * UNIT_TO_DEG_S[units]
    accel = data[:, accel_idx] * UNIT_TO_M_S2[accel_units] if accel_idx else None
    for what, values in (("rate", rate), ("acceleration", accel)):
        bad = None if values is None else ~np.isfinite(values)
        if bad is not None and bad.any():
            row = int(np.argmax(bad.any(axis=1)))
            raise RecordFormatError(
                f"{path}: non-finite {what} in data row {row + 1}; clean the file first"
            )
    temp = None if temp_index is None else data[:, temp_index].copy()
    return RateRecord(
        np.ascontiguousarray(rate), fs, tuple(header[i] for i in axis_idx), str(path), temp,
        index, None if accel is None else np.ascontiguousarray(accel),
        tuple(header[i] for i in accel_idx),
    )


#: Name endings that say a rate unit (``accel_x_deg_s``): a column mislabelled.
_RATE_SUFFIXES = ("_deg_s", "_dps", "_rad_s", "_deg_h")


def _check_accel_name(path: Path, name: str) -> None:
    """Refuse an accelerometer column whose name says a rate unit."""
    low = name.strip().lower()
    if low.endswith(_RATE_SUFFIXES):
        raise RecordFormatError(
            f"{path}: column {name!r} is an accelerometer axis (accel_*) but its name says a "
            f"rate unit; rename it, or give --accel-units {'|'.join(UNIT_TO_M_S2)}"
        )


def _data_line(path: Path, header_line: int, row: int) -> int | None:
    """File line (1-based) of data row ``row`` (0-based; comment and blank lines skipped)."""
    with _open_text(path) as fh:
        seen = -1
        for lineno, line in enumerate(fh, start=1):
            stripped = line.split("#", 1)[0].strip()
            if lineno > header_line and stripped:
                seen += 1
                if seen == row:
                    return lineno
    return None


def _parse_error(path: Path, header_line: int, n_columns: int, message: str) -> str:
    """One line naming the file line of numpy's parse error, and what the format expects.

    numpy counts data rows from 0 when a value does not convert ("at row R, column C", C
    from 1) and from 1 when the column count changes ("at row R").
    """
    expected = (
        f"the format is {n_columns} numbers per line separated by commas, as the header "
        f"on line {header_line}"
    )
    bad = re.search(r"could not convert string '(.*)' to \w+ at row (\d+), column (\d+)", message)
    if bad:
        line = _data_line(path, header_line, int(bad.group(2)))
        return (
            f"{path}, line {line}: value {bad.group(3)} ({bad.group(1)!r}) is not a number; "
            f"{expected}"
        )
    changed = re.search(r"number of columns changed from (\d+) to (\d+) at row (\d+)", message)
    if changed:
        line = _data_line(path, header_line, int(changed.group(3)) - 1)
        return (
            f"{path}, line {line}: {plural(int(changed.group(2)), 'value')} where the lines "
            f"before have {changed.group(1)}; {expected}"
        )
    return f"{path}: cannot read the values after line {header_line} ({message}); {expected}"


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


#: A time step within this fraction of a sample period of a whole number of periods is regular.
TIME_STEP_TOLERANCE = 0.01


def _time_grid(
    path: Path, data: NDArray[np.float64], time_index: int | None, given: float | None
) -> tuple[float, NDArray[np.int64] | None]:
    """(sample rate in Hz, grid index of each row or None when the rows have no gap).

    The time column decides the gaps: a step of k periods (k >= 2, within 1 % of a
    period) means k - 1 missing samples. With ``--rate`` given, the time column counts
    only when its own period agrees with that rate and every step is a whole number of
    periods. A ``--rate`` that disagrees with the time column's own step is refused: one
    of the two is wrong, and analysing at the wrong rate scales every figure. A time column
    at the given rate whose steps are irregular is ignored, as the option promises.

    Raises
    ------
    RecordFormatError
        No way to know the rate, a time column that does not increase or is irregular
        without ``--rate``, or a ``--rate`` the time column contradicts.
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
            raise RecordFormatError(
                f"{path}: one row is not enough to know the sample rate; give --rate HZ"
            )
        return float(given), None
    dt = np.diff(t)
    period = float(np.median(dt)) if given is None else 1.0 / float(given)
    if given is None and not period > 0:
        raise RecordFormatError(f"{path}: time column does not increase")
    median_dt = float(np.median(dt))
    if given is not None and abs(median_dt - period) > TIME_STEP_TOLERANCE * period:
        says = f"{median_dt:g} s ({1.0 / median_dt:g} Hz)" if median_dt > 0 else f"{median_dt:g} s"
        raise RecordFormatError(
            f"{path}: the time column steps {says} but --rate says {float(given):g} Hz; leave "
            f"out --rate to use the time column (in s), or correct the one that is wrong"
        )
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
    accel_m_s2: NDArray[np.float64] | None = None,
    accel_axis_names: Sequence[str] = (),
) -> Path:
    """Write a rate record as CSV (``time`` in s, one column per axis in deg/s); gzip if ``.gz``.

    ``sample_index`` (grid index of each row, see :class:`RateRecord`) writes the times
    of a record with gaps, so that reading it back finds them. ``accel_m_s2`` (shape
    (N, j), m/s^2) adds one column per accelerometer axis after the rates, named by
    ``accel_axis_names`` (each given an ``accel_`` prefix where it has none, so that
    reading it back finds an accelerometer axis, in m/s^2).
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
    if accel_m_s2 is not None:
        accel = np.asarray(accel_m_s2, dtype=float).reshape(rate.shape[0], -1)
        accel_names = list(accel_axis_names)
        if len(accel_names) != accel.shape[1]:
            accel_names = ([f"accel_{c}" for c in "xyz"[: accel.shape[1]]]
                           if accel.shape[1] <= 3 else
                           [f"accel_{i}" for i in range(accel.shape[1])])
        columns.extend(accel.T)
        header.extend(n if is_accel_column(n) else f"accel_{n}" for n in accel_names)
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
