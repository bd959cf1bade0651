"""A recorded run as the analysis, grading and report code see it: units, records, metadata.

:func:`station.storage.runs.open_run` reads any run file the station knows (a recorder
HDF5 file, or a plain CSV record, which becomes a run of one unit with no metadata) into a
:class:`RunInfo`. Grading, reports and the TUI use only this, never the file layout.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from station.model.records import RateRecord


@dataclass(frozen=True)
class RunEvent:
    """One entry of a run's event log (connect, disconnect, crc_error, resync, gap, ...).

    ``time_s`` is station time from the run start (s); ``missing_samples`` is set for gaps,
    and ``missing_low``/``missing_high`` bound it where a counter's wrap count was not
    certain (None: the count is exact, or the file predates the bounds).
    """

    unit_id: str
    kind: str
    time_s: float
    count: int = 1
    missing_samples: int = 0
    detail: str = ""
    missing_low: int | None = None
    missing_high: int | None = None


@dataclass(frozen=True)
class UnitRun:
    """One gyro of a run: who it is and what it recorded."""

    unit_id: str
    model: str
    serial_number: str
    record: RateRecord
    protocol: str = ""
    transport: str = ""
    settings: dict[str, str] = field(default_factory=dict)
    events: tuple[RunEvent, ...] = ()

    @property
    def n_gaps(self) -> int:
        """Number of gaps in this unit's record."""
        return sum(1 for e in self.events if e.kind == "gap")

    @property
    def missing_samples(self) -> int:
        """Samples lost in gaps, in total."""
        return sum(e.missing_samples for e in self.events if e.kind == "gap")


@dataclass(frozen=True)
class RunInfo:
    """A run: its metadata (strings in UTC ISO 8601 for times) and its units."""

    path: str
    units: tuple[UnitRun, ...]
    profile: str = ""
    #: Version, SHA-256 and path of the profile file the run was recorded with ("" if
    #: none; runs recorded before the path was kept have none).
    profile_version: str = ""
    profile_sha256: str = ""
    profile_path: str = ""
    operator: str = ""
    lot: str = ""
    station_host: str = ""
    software_version: str = ""
    start_utc: str = ""
    stop_utc: str = ""
    stop_reason: str = ""
    interrupted: bool = False
    #: The test bench (latitude, axis directions) as JSON (:mod:`station.model.bench`); "" if none.
    bench: str = ""

    def unit(self, unit_id: str) -> UnitRun:
        """The unit with this id (or serial number)."""
        for u in self.units:
            if unit_id in (u.unit_id, u.serial_number):
                return u
        ids = ", ".join(u.unit_id for u in self.units)
        raise KeyError(f"no unit {unit_id!r} in {self.path}; units: {ids}")
