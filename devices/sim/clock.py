"""A time-warped clock shared by a simulated device and the adapter reading it."""

from __future__ import annotations

import time


class WarpClock:
    """Simulated seconds that run ``warp`` times faster than the wall clock.

    Parameters
    ----------
    warp : float
        Time-warp factor (> 0); 1 is real time.
    """

    def __init__(self, warp: float = 1.0) -> None:
        if not warp > 0:
            raise ValueError(f"warp must be > 0, got {warp}")
        self.warp = float(warp)
        self._origin = time.monotonic()

    def __call__(self) -> float:
        """Simulated time, s since the clock was made."""
        return (time.monotonic() - self._origin) * self.warp

    def sleep(self, simulated_s: float) -> None:
        """Sleep for ``simulated_s`` simulated seconds."""
        if simulated_s > 0:
            time.sleep(simulated_s / self.warp)
