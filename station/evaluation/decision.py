"""Decisions of grading: a figure's verdict against a limit under the profile's rule, an
axis' grade from its figures' verdicts, the order of grades, and which record column is which
profile axis."""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Protocol

from station.errors import StationError
from station.model.kinds import INDETERMINATE, Verdict
from station.model.profiles import Profile


class GradingError(StationError, ValueError):
    """A run that cannot be graded with a profile (too short, axes missing, ...)."""


def decide(
    value: float | None, low: float | None, high: float | None, limit: float, rule: str
) -> Verdict:
    """Verdict of one figure against an upper ``limit`` under a decision rule.

    ``simple``: pass when the value is within the limit, else fail (the interval is
    ignored). ``guard-banded``: pass when the upper confidence bound is within the limit,
    fail when the lower bound is beyond it, indeterminate when the interval straddles it.
    ``strict``: pass only when the upper bound is within the limit, fail otherwise.
    A figure that could not be computed is indeterminate under every rule.
    """
    if value is None:
        return INDETERMINATE
    if rule == "simple":
        return "pass" if value <= limit else "fail"
    if high is None or low is None:
        return INDETERMINATE
    if high <= limit:
        return "pass"
    if rule == "strict" or low > limit:
        return "fail"
    return INDETERMINATE


class Verdicted(Protocol):
    """A graded figure: its verdict at each grade that limits it."""

    @property
    def verdicts(self) -> Mapping[str, str]: ...


def assign_grade(figures: Sequence[Verdicted], grades: tuple[str, ...], reject: str
                 ) -> tuple[str, str, str | None]:
    """(grade, deciding grade, could_reach) of an axis from its figures' verdicts.

    The grade is the best grade at which every limited figure passes; when none does and
    some grade had no fail but an indeterminate verdict, the axis is ``indeterminate``;
    otherwise it is ``reject``.
    """
    first_open: str | None = None
    for grade in grades:
        verdicts = [f.verdicts[grade] for f in figures if grade in f.verdicts]
        if all(v == "pass" for v in verdicts):
            return grade, grade, first_open
        if "fail" not in verdicts and first_open is None:
            first_open = grade
    if first_open is not None:
        return INDETERMINATE, first_open, None
    return reject, grades[-1], None


def grade_rank(grade: str, profile: Profile) -> int:
    """Order of grades, best first: the profile's grades, then indeterminate, then reject."""
    if grade in profile.grades:
        return profile.grades.index(grade)
    return len(profile.grades) + (0 if grade == INDETERMINATE else 1)


def _axis_token(name: str) -> str:
    return re.split(r"[_\-. ]", name.lower())[-1]


def match_axes(profile_axes: tuple[str, ...], record_axes: tuple[str, ...]) -> dict[str, int]:
    """Column index of each profile axis in a record: by name, by last name token (``gyro_x``
    is ``x``), or one to one when both have a single axis.

    Raises
    ------
    GradingError
        When an axis of the profile is not in the record.
    """
    out: dict[str, int] = {}
    tokens = [_axis_token(a) for a in record_axes]
    for axis in profile_axes:
        if axis in record_axes:
            out[axis] = record_axes.index(axis)
        elif tokens.count(axis.lower()) == 1:
            out[axis] = tokens.index(axis.lower())
        elif len(profile_axes) == 1 and len(record_axes) == 1:
            out[axis] = 0
        else:
            raise GradingError(f"the profile grades axis {axis!r}, the record has "
                               f"{', '.join(record_axes)}")
    return out
