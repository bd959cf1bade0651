"""A simulated gyro wired to a simulated fixture: powered by its relay, warmed by its chamber.

A ``sim+`` URL with ``fixture=127.0.0.1:PORT/K`` puts the simulated unit on output ``K``
of a :class:`~devices.sim.fixture_server.SimulatedFixture`. A thread of the unit reads
the fixture's simulation wiring (over Modbus, :data:`~devices.codecs.fixture_map.SIM_WIRING`)
and holds the unit's sampling (:meth:`SimCore.power_off`) while its output is off and,
after each switch-on, for the turn-on time drawn for that switch-on; then it samples.
Every sample gets, on top of the noise model's signal
(:class:`analysis.models.power_cycle.PowerCycleModel`):

* the turn-on bias drawn for the current switch-on (the draw is keyed by the seed and the
  fixture's switch-on count, so a unit opened again during the same switch-on, as each
  recorded segment opens it, has the same turn-on bias and turn-on time; a fixture
  started again for a resumed sequence continues the count from the journal, so a unit
  the resume switches on again draws a new turn-on bias, as a real one does);
* the warm-up transient at the sample's time since switch-on (on the fixture's clock);
* the temperature bias at the die temperature, which the unit also reports.

The fixture's time and the unit's clock run at the same warp; their offset is measured
at every read of the wiring (a few milliseconds of wall time apart, that is the
uncertainty, times the warp).
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np

from analysis.models.power_cycle import PowerCycleModel, TurnOn
from analysis.units.conversions import S_PER_H
from devices.codecs.fixture_map import SIM_WIRING, SIM_WIRING_DEVICE_ID, OutletState
from devices.errors import DeviceConfigurationError, DeviceError
from devices.sim.clock import WarpClock
from devices.sim.faults import SimCore
from devices.sim.signal import SignalChunk, SignalSource
from devices.transports.modbus import ModbusTransport

#: Wall seconds between two reads of the wiring.
POLL_WALL_S = 0.02
#: Reads of the wiring when a unit opens (the quickest one sets the clock offset).
FIRST_READS = 8
#: Longest the die temperature is extrapolated from the last read, s (fixture time).
MAX_EXTRAPOLATION_S = 30.0


def parse_fixture(text: str) -> tuple[str, int, int]:
    """(host, port, output) of a ``fixture=HOST:PORT/OUTPUT`` URL key.

    Raises
    ------
    DeviceConfigurationError
        Not of that form.
    """
    where, _, output = text.partition("/")
    host, _, port = where.rpartition(":")
    try:
        return host or "127.0.0.1", int(port), int(output)
    except ValueError:
        raise DeviceConfigurationError(f"URL key fixture={text!r}: use fixture=HOST:PORT/OUTPUT "
                                       f"(a simulated fixture's address and the relay output "
                                       f"powering this unit)") from None


def turn_on_draw(model: PowerCycleModel, seed: int, on_count: int, n_axes: int) -> TurnOn:
    """What a simulated unit of seed ``seed`` draws at its fixture's switch-on number
    ``on_count`` (a simulation's truth, for a test or a demo to compare with)."""
    return model.draw(np.random.default_rng([seed, on_count, 0x70_0E]), n_axes)


@dataclass(frozen=True)
class _Sync:
    """The latest read of the wiring: offset fixture - unit clock (s), the fixture's time
    at the read, and the outlet."""

    offset_s: float
    fixture_s: float
    outlet: OutletState


class PoweredUnit:
    """The supply, warm-up and temperature of one simulated unit (see the module doc).

    Parameters
    ----------
    fixture : str
        ``HOST:PORT/OUTPUT`` of the simulated fixture and the output powering the unit.
    model : PowerCycleModel
        Turn-on, warm-up and temperature behaviour.
    seed : int
        Seed of the turn-on draws.
    n_axes : int
        Axes of the unit.
    """

    def __init__(self, fixture: str, model: PowerCycleModel, *, seed: int, n_axes: int) -> None:
        host, port, self.output = parse_fixture(fixture)
        self.model = model
        self.seed = seed
        self.n_axes = n_axes
        self._link = ModbusTransport("tcp", host, port=port, timeout_s=1.0)
        self._core: SimCore | None = None
        self._clock: WarpClock | None = None
        self._sync: _Sync | None = None
        self._turn_on: TurnOn | None = None
        self._draws: dict[int, TurnOn] = {}
        self._best_rtt_s = math.inf
        self._offset_s = 0.0
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.failures = 0

    def draw(self, on_count: int) -> TurnOn:
        """What switch-on number ``on_count`` drew (the same in every process)."""
        if on_count not in self._draws:
            self._draws[on_count] = turn_on_draw(self.model, self.seed, on_count, self.n_axes)
        return self._draws[on_count]

    def first_read(self, clock: WarpClock) -> int:
        """Connect, read the wiring once; returns the current switch-on count (what the
        noise of this opening is keyed by).

        Raises
        ------
        DeviceConfigurationError
            The fixture cannot be reached.
        """
        self._clock = clock
        try:
            self._link.open()
            for _ in range(FIRST_READS):  # the quickest of several exchanges sets the offset
                sync = self._read()
        except DeviceError as exc:
            raise DeviceConfigurationError(
                f"simulated fixture {self._link.target}:{self._link.port} not reachable "
                f"({exc}): start it first (URL key fixture=)") from exc
        return sync.outlet.on_count

    def _read(self) -> _Sync:
        """Read the wiring. The fixture stamps its time somewhere inside the exchange; the
        two clocks run at the same rate, so the offset is taken from the quickest exchange
        seen (its midpoint), as NTP does: a slow answer (a loaded host) does not shift it."""
        assert self._clock is not None
        start, count = SIM_WIRING.span(self.output)
        sent = self._clock()
        registers = self._link.read_registers(start, count, SIM_WIRING_DEVICE_ID, "input")
        received = self._clock()
        fixture_now, outlet = SIM_WIRING.decode(registers, self.output)
        if received - sent < self._best_rtt_s:
            self._best_rtt_s = received - sent
            self._offset_s = fixture_now - (sent + received) / 2.0
        sync = _Sync(self._offset_s, fixture_now, outlet)
        with self._lock:
            self._sync = sync
        return sync

    def attach(self, core: SimCore) -> None:
        """Hold ``core`` as the supply says, then follow the supply in a thread."""
        self._core = core
        assert self._sync is not None
        self._apply(self._sync)  # a boot in progress is released by the thread
        self._thread = threading.Thread(target=self._run, name="sim-supply", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop following the supply and close the link."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        self._link.close()

    def _apply(self, sync: _Sync) -> float | None:
        """Hold or release the core as the supply says; returns the wall seconds to the end
        of a boot in progress (None when none is)."""
        assert self._core is not None and self._clock is not None
        outlet = sync.outlet
        if not outlet.powered:
            self._core.power_off()
            with self._lock:
                self._turn_on = None
            return None
        drawn = self.draw(outlet.on_count)
        boot = outlet.on_time_s + drawn.turn_on_s
        remaining = boot - (self._clock() + sync.offset_s)
        if remaining > 0:
            self._core.power_off()
            return remaining / self._clock.warp
        with self._lock:
            self._turn_on = drawn
        self._core.power_on(at_s=boot - sync.offset_s)  # booted then, however late we are
        return None

    def _run(self) -> None:
        wait = POLL_WALL_S
        while not self._stop.wait(wait):
            try:
                if self.failures:
                    self._link.open()
                sync = self._read()
            except DeviceError:
                self._link.close()
                self.failures += 1
                if self.failures >= 10:  # the fixture is gone, and the supply with it
                    assert self._core is not None
                    self._core.power_off()
                wait = min(0.2, POLL_WALL_S * self.failures)
                continue
            self.failures = 0
            boot_in = self._apply(sync)
            if boot_in is not None and boot_in <= POLL_WALL_S:
                # the unit boots before the next read: release it on time, from what the
                # read said (a switch-off meanwhile is seen at the next read)
                if self._stop.wait(boot_in):
                    break
                self._apply(sync)
            wait = POLL_WALL_S

    # -- what each sample gets ---------------------------------------------------------
    def effects(self, period_start_clock_s: np.ndarray, period_s: float
                ) -> tuple[np.ndarray, np.ndarray]:
        """(bias deg/s, shape (n, n_axes); die temperature degC, shape (n,)) of samples
        whose periods start at these times of the unit's clock."""
        with self._lock:
            sync, turn_on = self._sync, self._turn_on
        n = len(period_start_clock_s)
        if sync is None:
            return np.zeros((n, self.n_axes)), np.full(n, 25.0)
        t_fixture = period_start_clock_s + sync.offset_s
        ahead = np.clip(t_fixture + period_s / 2 - sync.fixture_s, 0.0, MAX_EXTRAPOLATION_S)
        die = sync.outlet.die_c + sync.outlet.die_slope_c_per_s * ahead
        bias_h = self.model.temperature_bias_deg_h(die)[:, None] * np.ones(self.n_axes)
        if turn_on is not None:
            since_on = t_fixture - sync.outlet.on_time_s
            bias_h = (bias_h + self.model.transient_deg_h(since_on, period_s)[:, None]
                      + np.asarray(turn_on.bias_deg_h)[None, :])
        return bias_h / S_PER_H, die


class PoweredSignal(SignalSource):
    """A :class:`SignalSource` whose samples get a :class:`PoweredUnit`'s effects.

    The sample index of each read is the core's count of generated samples (every read
    of the signal generates that many); the unit's clock time of each sample period comes
    from the core's schedule.
    """

    def __init__(self, base: SignalSource, unit: PoweredUnit) -> None:
        # no SignalSource.__init__: the noise comes from ``base``, already built
        self.model = base.model
        self.n_axes = base.n_axes
        self.accel = base.accel
        self._base = base
        self.unit = unit
        self._core: SimCore | None = None

    def bind(self, core: SimCore) -> None:
        """The core whose schedule times the samples."""
        self._core = core

    def read(self, n_samples: int) -> SignalChunk:
        chunk = self._base.read(n_samples)
        if self._core is None or n_samples == 0:
            return chunk
        core = self._core
        first = core.ledger.generated
        start = core.due_time(first)
        step = core.due_time(first + 1) - start
        bias, die = self.unit.effects(start + step * np.arange(n_samples), step)
        accel = chunk.accel_m_s2
        if accel is not None and self._base.accel is not None:  # at the die temperature
            effect = self._base.accel.temperature_effect
            accel = accel + effect(die) - effect(chunk.temperature_c)
        return SignalChunk(chunk.rate_deg_s + bias, die, accel)
