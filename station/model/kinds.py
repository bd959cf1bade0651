"""Names of kinds the station compares, as Literal types the type checker holds to."""

from __future__ import annotations

from typing import Literal, get_args

from devices.protocols import EventKind, GapMethod

#: The verdict of one figure against one limit (:func:`station.evaluation.decision.decide`).
Verdict = Literal["pass", "fail", "indeterminate"]
VERDICTS: tuple[Verdict, ...] = get_args(Verdict)
#: The grade (and verdict) of a unit whose figures' intervals straddle a limit.
INDETERMINATE: Verdict = "indeterminate"


def verdict_of_grade(grade: str, reject: str) -> Verdict:
    """The verdict a unit's grade stands for: fail for the profile's ``reject`` grade,
    indeterminate for :data:`INDETERMINATE`, pass for any other grade."""
    if grade == INDETERMINATE:
        return INDETERMINATE
    return "fail" if grade == reject else "pass"

#: Entries the recorder adds to a unit's event log besides the adapters' link events.
RecorderKind = Literal["gap", "error", "end"]
#: Kinds of a unit's event log: the adapters' link events (:data:`devices.protocols.EventKind`)
#: and the recorder's own.
LogKind = EventKind | RecorderKind
LOG_KINDS: tuple[LogKind, ...] = (*get_args(EventKind), *get_args(RecorderKind))
#: How a gap was counted (:data:`devices.protocols.GapMethod`, or ``salvage``: rows of a
#: damaged run file ``station recover`` could not read); "" for any other entry.
LogMethod = GapMethod | Literal["salvage", ""]
LOG_METHODS: tuple[LogMethod, ...] = (*get_args(GapMethod), "salvage", "")


def log_kind(text: str) -> LogKind | None:
    """The event kind ``text`` names (as a run file stores it), None if it names none."""
    for kind in LOG_KINDS:
        if kind == text:
            return kind
    return None


def log_method(text: str) -> LogMethod | None:
    """The gap method ``text`` names ("" for none), None if it names no known method."""
    for method in LOG_METHODS:
        if method == text:
            return method
    return None
