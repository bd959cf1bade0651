"""What a spec sheet's header says about the test house: company, logo, station name, test
conditions and the approval block, from a small TOML file.

::

    # sheet.toml (station report --header sheet.toml, or $STATION_SHEET_HEADER)
    company = "Gyro Works Ltd."
    station = "EOL bench 3"                     # else $STATION_NAME, else the host name
    logo = "logo.png"                           # PNG, relative to this file
    conditions = "static, on a granite table, 23 +- 1 degC, no vibration isolation"
    approval = ["Tested by", "Approved by"]      # one signature line each

Every key is optional; an unknown key is refused by name (a misspelt ``aproval`` would
otherwise vanish from every sheet without a word).
"""

from __future__ import annotations

import os
import tomllib
from dataclasses import dataclass
from pathlib import Path

from station.errors import UsageError

#: Environment variables: the header file a report uses when none is given, and the
#: station's name when the header file names none.
HEADER_ENV = "STATION_SHEET_HEADER"
STATION_NAME_ENV = "STATION_NAME"
_KEYS = ("company", "station", "logo", "conditions", "approval")


@dataclass(frozen=True)
class SheetHeader:
    """The test house's part of a spec sheet's header (every field optional)."""

    company: str = ""
    station: str = ""
    logo: Path | None = None
    conditions: str = ""
    approval: tuple[str, ...] = ()


def load_sheet_header(path: str | Path) -> SheetHeader:
    """Read a sheet header file (the module docstring shows one).

    Raises
    ------
    UsageError
        A file that does not exist or is not TOML, an unknown key, a value of the wrong
        type, a logo that is not an existing PNG.
    """
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise UsageError(f"no sheet header file {path}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise UsageError(f"{path}: not a TOML sheet header ({exc})") from None
    unknown = sorted(set(data) - set(_KEYS))
    if unknown:
        raise UsageError(
            f"{path}: unknown key {', '.join(map(repr, unknown))}; a sheet header "
            f"takes {', '.join(_KEYS)}"
        )
    for key in ("company", "station", "logo", "conditions"):
        if not isinstance(data.get(key, ""), str):
            raise UsageError(f"{path}: {key} must be text")
    approval = data.get("approval", [])
    if not isinstance(approval, list) or not all(isinstance(a, str) for a in approval):
        raise UsageError(
            f'{path}: approval must be a list of texts, e.g. ["Tested by", "Approved by"]'
        )
    logo = None
    if data.get("logo"):
        logo = (path.parent / data["logo"]).resolve()
        if logo.suffix.lower() != ".png" or not logo.is_file():
            raise UsageError(f"{path}: logo {data['logo']!r} must be an existing PNG file")
    return SheetHeader(
        data.get("company", ""),
        data.get("station", ""),
        logo,
        data.get("conditions", ""),
        tuple(approval),
    )


def station_name(header: SheetHeader | None, host: str) -> str:
    """The station's name: the header's, else ``$STATION_NAME``, else the recording host's
    name marked as such (``"vm (host name)"``), else ``"-"``."""
    if header is not None and header.station:
        return header.station
    if os.environ.get(STATION_NAME_ENV):
        return os.environ[STATION_NAME_ENV]
    return f"{host} (host name)" if host else "-"
