"""The live progress line of a recording (a run-document subscriber).

One line per refresh: elapsed and remaining time, then per unit its samples, rate,
CRC errors, gaps (samples missing), reconnects and its current Allan deviation at 1 s
and 100 s (overlapping estimator on 1-s averages of its first axis, deg/h). On a
terminal the line is redrawn in place; otherwise a line is printed every
``plain_interval_s``.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from typing import TextIO

import numpy as np

from station.model.documents import Descriptor, Document, EventBatch, RunStart, RunStop, UnitTally

DEG_S_TO_DEG_H = 3600.0


@dataclass
class BlockAverager:
    """Averages of consecutive blocks of ``block`` samples (1 s of a unit's first axis)."""

    block: int
    means: list[float] = field(default_factory=list)
    _sum: float = 0.0
    _n: int = 0

    def add(self, values: np.ndarray) -> None:
        """Add samples (1-D, deg/s)."""
        i = 0
        while i < len(values):
            take = min(self.block - self._n, len(values) - i)
            self._sum += float(values[i:i + take].sum())
            self._n += take
            i += take
            if self._n == self.block:
                self.means.append(self._sum / self.block)
                self._sum, self._n = 0.0, 0

    def adev_deg_h(self, tau_s: float) -> float | None:
        """Allan deviation at ``tau_s`` (s, a whole number of seconds), deg/h; None if too
        little data (fewer than 2 tau + 1 s)."""
        n = len(self.means)
        if n < 2 * tau_s + 1:
            return None
        from analysis.allan.variance import allan_variance  # scipy: loaded once a value is due

        result = allan_variance(np.asarray(self.means), 1.0, taus=np.array([tau_s]))
        return float(result.adev[0]) * DEG_S_TO_DEG_H


def _hms(seconds: float) -> str:
    seconds = max(0, int(seconds))
    return f"{seconds // 3600:02d}:{seconds % 3600 // 60:02d}:{seconds % 60:02d}"


def _count(n: int) -> str:
    return f"{n / 1e6:.2f}M" if n >= 1e6 else f"{n / 1e3:.1f}k" if n >= 1e4 else str(n)


def _adev(value: float | None) -> str:
    return "-" if value is None else f"{value:.3g}"


class ProgressLine:
    """Prints the progress line of a run from its documents.

    Parameters
    ----------
    stream : text stream
        Where to print (stderr by default).
    refresh_s : float
        Minimum time between redraws, s (wall).
    plain_interval_s : float
        Time between lines when ``stream`` is not a terminal, s.
    """

    def __init__(self, stream: TextIO | None = None, *, refresh_s: float = 0.5,
                 plain_interval_s: float = 10.0) -> None:
        self.stream = stream or sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.refresh_s = refresh_s if self.tty else plain_interval_s
        self.duration_s = 0.0
        self.tallies: dict[str, UnitTally] = {}
        self.averagers: dict[str, BlockAverager] = {}
        self.rates: dict[str, float] = {}
        self.warps: dict[str, float] = {}
        self._t0 = time.monotonic()
        self._last_draw = 0.0

    def __call__(self, document: Document) -> None:
        """Take one run document."""
        if isinstance(document, RunStart):
            self.duration_s = document.duration_s
            self._t0 = time.monotonic()
        elif isinstance(document, Descriptor):
            rate = document.description.sample_rate_hz
            self.tallies[document.unit_id] = UnitTally()
            self.averagers[document.unit_id] = BlockAverager(max(1, round(rate)))
            self.rates[document.unit_id] = rate
            self.warps[document.unit_id] = document.time_warp
        elif isinstance(document, EventBatch):
            self.tallies[document.unit_id].add(document)
            if len(document):
                self.averagers[document.unit_id].add(document.rate_deg_s[:, 0])
            if time.monotonic() - self._last_draw >= self.refresh_s:
                self.draw()
        elif isinstance(document, RunStop):
            self.draw()
            if self.tty:
                self.stream.write("\n")
            self.stream.write(f"stopped: {document.reason}\n")
            self.stream.flush()

    def line(self) -> str:
        """The current progress line."""
        elapsed = time.monotonic() - self._t0
        left = max((self.duration_s - t.last_time_s) / self.warps[u]
                   for u, t in self.tallies.items()) if self.tallies else 0.0
        parts = [f"{_hms(elapsed)} elapsed, {_hms(left)} left"]
        for uid, t in self.tallies.items():
            avg = self.averagers[uid]
            state = "" if t.connected else " DISCONNECTED"
            parts.append(
                f"{uid}{state}: {_count(t.samples)} smp @{self.rates[uid]:g} Hz, crc "
                f"{t.crc_errors}, gaps {t.gaps} ({t.missing} miss), reconn {t.reconnects}, "
                f"adev 1s {_adev(avg.adev_deg_h(1))} 100s {_adev(avg.adev_deg_h(100))} deg/h")
        return " | ".join(parts)

    def draw(self) -> None:
        """Print the line now."""
        self._last_draw = time.monotonic()
        if self.tty:
            self.stream.write("\r\x1b[2K" + self.line())
        else:
            self.stream.write(self.line() + "\n")
        self.stream.flush()
