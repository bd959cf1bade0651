"""Any record or run file the station reads: a CSV record, or a recorder's HDF5 run file."""

from __future__ import annotations

from collections.abc import Collection
from pathlib import Path

from station.errors import RecordFormatError
from station.model.records import RateRecord
from station.model.runs import RunInfo, UnitRun
from station.storage.csv_records import read_csv_record
from station.storage.hdf5 import read_run, read_run_record, run_attributes
from station.storage.mapped_runs import long_unit_record, read_long_unit


def is_run_file(path: str | Path) -> bool:
    """Whether ``path`` names a recorder run file (``.h5``/``.hdf5``) rather than a CSV record."""
    return Path(path).suffix.lower() in (".h5", ".hdf5")


def read_record(
    path: str | Path, *, sample_rate_hz: float | None = None, units: str = "deg/s",
    unit: str | None = None, accel_units: str = "m/s^2",
) -> RateRecord:
    """Read a rate record from any supported file type: CSV (plain or gzip'd) or a run file.

    Parameters
    ----------
    path : str or Path
        ``.csv``, ``.csv.gz``, ``.txt``, or a recorder run file (``.h5``/``.hdf5``).
    sample_rate_hz, units, accel_units
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
    if is_run_file(path):
        return read_long_unit(path, unit) or read_run_record(path, unit)
    if unit is not None:
        raise RecordFormatError(f"{path}: --unit applies to run files (.h5) only")
    suffixes = "".join(path.suffixes[-2:]).lower()
    if suffixes.endswith(".csv") or suffixes.endswith(".csv.gz") or path.suffix.lower() == ".txt":
        return read_csv_record(path, sample_rate_hz=sample_rate_hz, units=units,
                               accel_units=accel_units)
    raise RecordFormatError(f"{path}: unknown record type; expected .csv, .csv.gz or .h5")


def open_run(
    path: str | Path,
    *,
    sample_rate_hz: float | None = None,
    units: str = "deg/s",
    only: Collection[str] | None = None,
    accel_units: str = "m/s^2",
) -> RunInfo:
    """Read a run file: a recorder HDF5 file, or a CSV record (a run of one unit).

    ``sample_rate_hz`` and ``units`` apply to CSV records only (see
    :func:`station.storage.csv_records.read_csv_record`); ``only`` names the units of a
    run file to read (None: all).
    """
    path = Path(path)
    if is_run_file(path):
        return read_run(path, only=only, long_record=long_unit_record)
    record = read_record(path, sample_rate_hz=sample_rate_hz, units=units,
                         accel_units=accel_units)
    unit = UnitRun(unit_id=path.name.split(".")[0], model="", serial_number="", record=record)
    return RunInfo(path=str(path), units=(unit,))


def recorded_attributes(path: str | Path) -> dict[str, str]:
    """What a run file recorded about its run (profile, bench, operator, ... as text); {}
    for a CSV record, which records none."""
    if not is_run_file(path):
        return {}
    return run_attributes(path)
