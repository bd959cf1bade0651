"""What opening a device URL gives: the adapter, its time base, and for a simulation the
simulated device behind it (which offers the :class:`~devices.protocols.Simulated`
capability)."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from devices.protocols import RateSource
from devices.sim.clock import WarpClock
from devices.sim.faults import Ledger

#: How the station reads a unit's time when it is the station's own clock.
STATION_CLOCK = "station monotonic clock"


class SimControl(Protocol):
    """What the station uses of a simulated device's core, in this process
    (:class:`~devices.sim.faults.SimCore`) or in another
    (:class:`~devices.sim.process.RemoteSimCore`)."""

    clock: WarpClock

    @property
    def ledger(self) -> Ledger:
        """Samples generated, delivered and lost."""

    @property
    def sample_rate_hz(self) -> float:
        """Nominal sample rate, Hz."""

    def pause(self) -> None:
        """Hold sampling."""

    def resume(self, run_for_s: float | None = None) -> None:
        """Release the hold (ending ``run_for_s`` of its clock after it)."""

    def clear_faults(self) -> None:
        """Turn the injected faults off (a clean end of a run)."""

    def stop_after(self, n_samples: int | None) -> int | None:
        """Generate no sample beyond the first ``n_samples`` (the end of a run); returns
        the count it ends on."""


class Simulator(Protocol):
    """A running simulated device."""

    @property
    def core(self) -> SimControl:
        """Its core: the samples due, the faults, the ledger."""

    def stop(self) -> None:
        """Stop it and release its transport."""


@dataclass
class OpenedDevice:
    """The adapter a URL names, and the unit's time base.

    Attributes
    ----------
    source : RateSource
        The adapter (not opened yet).
    url : str
        The device URL it was opened from.
    hardware_url : str or None
        For a simulation another process can reach (a pty, a TCP port, a
        ``udp_multicast`` bus) and that runs in real time: the hardware URL by which a
        second station opens it as a real device. None otherwise.
    clock : callable or None
        The unit's own time base, s, when it is not the station's monotonic clock (a
        simulation's warped clock, a replay's recorded seconds).
    time_base : str
        That time base in words, for the run file.
    time_warp : float
        Seconds of the unit's time base per wall second (1 for hardware).
    replayed : bool
        The samples come from a file (a capture or a byte dump), at the rate they were
        recorded at, not from a unit set up now.
    """

    source: RateSource
    url: str = ""
    hardware_url: str | None = None
    clock: Callable[[], float] | None = None
    time_base: str = STATION_CLOCK
    time_warp: float = 1.0
    replayed: bool = False

    @property
    def unit_clock(self) -> Callable[[], float]:
        """The unit's time base (s): its own clock, else the station's monotonic clock."""
        return self.clock or time.monotonic

    def close(self) -> None:
        """Close the adapter."""
        self.source.close()

    def __enter__(self) -> OpenedDevice:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclass
class SimulatedDevice(OpenedDevice):
    """A ``sim+`` URL's adapter and the simulated device it talks to; offers the
    :class:`~devices.protocols.Simulated` capability (hold, end on a sample, count)."""

    simulator: Simulator | None = None

    def __post_init__(self) -> None:
        if self.simulator is None:
            raise ValueError("a simulated device needs its simulator")
        clock = self.simulator.core.clock
        self.clock = clock
        self.time_warp = clock.warp
        self.time_base = f"simulated device clock, warp x{clock.warp:g}"

    @property
    def core(self) -> SimControl:
        """The simulated device's core."""
        assert self.simulator is not None
        return self.simulator.core

    @property
    def ledger(self) -> Ledger:
        """The simulator's ledger: samples generated, delivered, lost."""
        return self.core.ledger

    def pause(self) -> None:
        """Hold sampling."""
        self.core.pause()

    def resume(self, run_for_s: float | None = None) -> None:
        """Release the hold; with ``run_for_s``, generate nothing due more than that (s
        of its clock) after the release."""
        self.core.resume(run_for_s)

    def clear_faults(self) -> None:
        """Turn the injected faults off."""
        self.core.clear_faults()

    def finish_after(self, n_samples: int | None) -> int | None:
        """Generate no sample beyond the first ``n_samples`` (None: go on); returns the
        count it ends on (fewer where :meth:`resume`'s ``run_for_s`` end comes first)."""
        return self.core.stop_after(n_samples)

    def samples_sent(self) -> int:
        """Samples the simulated device has generated so far."""
        return self.core.ledger.generated

    def close(self) -> None:
        """Close the adapter, then stop the simulator."""
        try:
            self.source.close()
        finally:
            assert self.simulator is not None
            self.simulator.stop()
            stop = getattr(self.simulator.core, "stop_attached", None)
            if stop is not None:  # a core in this process: what runs beside it (a supply)
                stop()
