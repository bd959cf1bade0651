"""A recorded run as the analysis, grading and report code see it: units, records, metadata.

:func:`station.storage.runs.open_run` reads any run file the station knows (a recorder
HDF5 file, or a plain CSV record, which becomes a run of one unit with no metadata) into a
:class:`RunInfo`. Grading, reports and the TUI use only this, never the file layout.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields

from station.model.kinds import LogKind
from station.model.records import RateRecord


@dataclass(frozen=True)
class RunEvent:
    """One entry of a run's event log (connect, disconnect, crc_error, resync, gap, ...).

    ``time_s`` is station time from the run start (s); ``missing_samples`` is set for gaps,
    and ``missing_low``/``missing_high`` bound it where a counter's wrap count was not
    certain (None: the count is exact, or the file predates the bounds).
    """

    unit_id: str
    kind: LogKind
    time_s: float
    count: int = 1
    missing_samples: int = 0
    detail: str = ""
    missing_low: int | None = None
    missing_high: int | None = None


@dataclass(frozen=True)
class UnitRun:
    """One gyro of a run: who it is and what it recorded.

    ``lsb_deg_s`` and ``lsb_relative`` are the step of its rate word on the link
    (:class:`devices.protocols.DeviceDescription`; a CSV record's ``--lsb``): 0.0 where not
    known (a CSV record, a file written before they were kept), when grading reads the
    step off the values.
    """

    unit_id: str
    model: str
    serial_number: str
    record: RateRecord
    protocol: str = ""
    transport: str = ""
    settings: dict[str, str] = field(default_factory=dict)
    events: tuple[RunEvent, ...] = ()
    lsb_deg_s: float = 0.0
    lsb_relative: float = 0.0

    @property
    def n_gaps(self) -> int:
        """Number of gaps in this unit's record."""
        return sum(1 for e in self.events if e.kind == "gap")

    @property
    def missing_samples(self) -> int:
        """Samples lost in gaps, in total."""
        return sum(e.missing_samples for e in self.events if e.kind == "gap")


@dataclass(frozen=True)
class RunMetadata:
    """Who recorded a run, where, with what and against which profile: the metadata the
    recorder's start document carries, the run file keeps as root attributes and the
    reader gives back (all text, "" where not given).

    Attributes
    ----------
    profile, profile_version, profile_sha256, profile_path : str
        The product profile and the file it was read from ("" if none; runs recorded
        before the path was kept have none).
    operator, lot : str
        Who recorded it, and the production lot.
    station_host, software_version : str
        Where, and with what station software.
    bench : str
        The test bench (latitude, axis directions) as JSON (:mod:`station.model.bench`).
    """

    profile: str = ""
    profile_version: str = ""
    profile_sha256: str = ""
    profile_path: str = ""
    operator: str = ""
    lot: str = ""
    station_host: str = ""
    software_version: str = ""
    bench: str = ""

    def as_attributes(self) -> dict[str, str]:
        """The run file's root attributes of this metadata (one per field)."""
        return asdict(self)

    @classmethod
    def from_attributes(cls, attributes: Mapping[str, object]) -> RunMetadata:
        """The metadata a run file's root attributes (as text) hold; missing ones are ""."""
        return cls(**{f.name: str(attributes.get(f.name, "")) for f in fields(cls)})


@dataclass(frozen=True)
class RunInfo:
    """A run: its units, its metadata, and how it ended (times in UTC ISO 8601)."""

    path: str
    units: tuple[UnitRun, ...]
    metadata: RunMetadata = field(default_factory=RunMetadata)
    start_utc: str = ""
    stop_utc: str = ""
    stop_reason: str = ""
    interrupted: bool = False
    #: The recorder's span, s: start to stop of a run that reached its requested
    #: duration (each unit's own clock); None where the run did not (an interrupted run,
    #: a replay that ran out, a CSV record): its records' own spans are then all there is.
    recorded_span_s: float | None = None

    def unit(self, unit_id: str) -> UnitRun:
        """The unit with this id (or serial number)."""
        for u in self.units:
            if unit_id in (u.unit_id, u.serial_number):
                return u
        ids = ", ".join(u.unit_id for u in self.units)
        raise KeyError(f"no unit {unit_id!r} in {self.path}; units: {ids}")
