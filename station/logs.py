"""What the station's command line does with the transport libraries' log messages."""

from __future__ import annotations

import logging


def configure_logging() -> None:
    """Keep library log lines off the operator's terminal where the station reports the
    same thing itself.

    pymodbus logs every failed connection attempt as an error followed by its last 20
    frames in hex (on stderr, through Python's last-resort handler): during a Modbus
    unit's outage that is a screenful a second, and in the TUI it would draw over the
    screen. The adapter reports the outage as ``disconnect`` / ``reconnect`` events in the
    run file and the progress line, so only pymodbus's critical messages are kept.
    """
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
