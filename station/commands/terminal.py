"""What a command shows on the operator's terminal: a progress line with its ETA, and
counts in words (:func:`station.model.wording.plural`).

Progress goes to stderr only when stderr is a terminal (a log file or a pipe gets no
carriage returns) and ``--quiet`` was not given.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

from station.model.wording import duration_text, plural

__all__ = ["ProgressLine", "duration_text", "plural"]


class ProgressLine:
    """``PREFIX: 42.0 % (N of M UNIT), ETA 3 min 20 s`` rewritten in place on a terminal.

    Silent when ``stream`` is not a terminal or ``quiet`` is set; the ETA is the elapsed
    time scaled to what is left.
    """

    def __init__(
        self,
        prefix: str,
        unit: str = "samples",
        *,
        quiet: bool = False,
        stream: TextIO | None = None,
    ) -> None:
        self.prefix, self.unit = prefix, unit
        self.stream = sys.stderr if stream is None else stream
        self.shown = not quiet and self.stream.isatty()
        self._start = time.monotonic()
        self._open = False

    def update(self, done: int, total: int) -> None:
        """Show ``done`` of ``total``; a newline once ``done`` reaches ``total``."""
        if not self.shown or total <= 0:
            return
        elapsed = time.monotonic() - self._start
        eta = f", ETA {duration_text(elapsed * (total - done) / done)}" if 0 < done < total else ""
        end = "\n" if done >= total else ""
        print(
            f"\r{self.prefix}: {100.0 * done / total:5.1f} % ({done} of {total} {self.unit})"
            f"{eta}\033[K",
            end=end,
            file=self.stream,
            flush=True,
        )
        self._open = done < total
