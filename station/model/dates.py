"""Dates a user gives to select gradings (``--since``, ``--until``, ``?since=``)."""

from __future__ import annotations

from datetime import date, datetime

from station.errors import UsageError


def check_date(name: str, value: str | None) -> None:
    """Refuse ``value`` unless it is an ISO 8601 date (``2026-06-02``) or date and time
    (``2026-06-02T08:00:00Z``) that exists: ``2026-13-45`` and ``2026-02-30`` are refused.

    Raises
    ------
    UsageError
        ``value`` is not such a date; ``name`` says which option or parameter gave it.
    """
    if value is None:
        return
    try:
        date.fromisoformat(value[:10])
        if len(value) > 10:
            datetime.fromisoformat(value.replace("Z", "+00:00"))
    except ValueError:
        raise UsageError(f"{name}={value!r} is not a date (YYYY-MM-DD)") from None
