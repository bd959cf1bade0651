"""The settings of a simulated device, as a ``sim+`` URL's query keys give them."""

from __future__ import annotations

import secrets
import time
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from functools import partial
from typing import Any

import numpy as np

from analysis.models.accel_noise import gravity_by_axis
from analysis.models.power_cycle import PowerCycleModel
from analysis.units.conversions import S_PER_H
from analysis.units.earth import earth_rate_by_axis, parse_orientation
from devices.errors import DeviceConfigurationError
from devices.sim.clock import WarpClock
from devices.sim.faults import FaultConfig, SimCore
from devices.sim.powered import PoweredSignal, PoweredUnit, parse_fixture
from devices.sim.signal import SignalSource

#: Fault knobs a URL sets (``garbage_max_bytes`` stays the device's own; ``seed`` is the
#: simulation's, the faults draw from ``seed + 1``).
FAULT_KEYS: tuple[str, ...] = tuple(
    f.name for f in fields(FaultConfig) if f.name not in ("garbage_max_bytes", "seed"))
#: Where the simulated gyro sits: the bench's latitude (deg) and its axes' directions
#: (``orientation=x:up,y:north,z:east``); the simulator then adds the Earth's rotation.
BENCH_KEYS: tuple[str, ...] = ("latitude", "orientation")
#: A simulated gyro on a simulated fixture (``fixture=HOST:PORT/OUTPUT``) and its turn-on,
#: warm-up and temperature behaviour (:class:`analysis.models.power_cycle.PowerCycleModel`'s
#: attributes, by these URL keys).
POWER_CYCLE_KEYS: dict[str, str] = {
    "turn_on_s": "turn_on_s", "turn_on_jitter_s": "turn_on_jitter_s",
    "turn_on_bias_deg_h": "turn_on_bias_deg_h", "warmup_deg_h": "warmup_deg_h",
    "warmup_tau_s": "warmup_tau_s", "tempco": "tempco_deg_h_per_c",
    "tempco2": "tempco2_deg_h_per_c2", "tempco_ref_c": "reference_c"}
FIXTURE_KEYS: tuple[str, ...] = ("fixture", *POWER_CYCLE_KEYS)
#: Axis names of a simulated gyro, in the order of its rate columns.
SIM_AXIS_NAMES = ("x", "y", "z")


@dataclass(frozen=True)
class SimParams:
    """Query keys of a simulated device URL (times in simulated seconds).

    Attributes
    ----------
    model : str
        Noise model: a preset name or a TOML file.
    rate : float
        Sample rate, Hz.
    warp : float
        Time-warp factor (simulated seconds per wall second).
    seed : int or None
        Seed of the signal; the faults draw from ``seed + 1``. A URL without ``seed=``
        gets one drawn at random when it is parsed (:func:`parse_sim_params`), so every
        simulated unit has its own serial number (:attr:`serial_number`).
    history : int
        Samples whose rates and lost indices the simulator keeps for tests (0: counts
        only, so that an overnight run stays in bounded memory).
    faults : FaultConfig
        Dropped, corrupted and junk-preceded frames (per-frame probabilities: URL keys
        ``drop``, ``corrupt``, ``garbage``), periodic disconnects and stalls
        (``disconnect_every_s``, ``disconnect_for_s``, ``stall_every_s``,
        ``stall_for_s``, s) and clock error (``drift_ppm``).
    latitude : float or None
        Latitude of the bench, deg (URL key ``latitude``); with ``orientation`` the
        simulated gyro also measures the Earth's rotation, as a real one at rest does.
    orientation : str
        Direction of each axis (URL key ``orientation``: ``x:up,y:north,z:east``; a
        direction is up, down, north, south, east, west or ``east/north/up`` numbers).
    fixture : str
        ``HOST:PORT/OUTPUT`` of the simulated fixture whose relay output powers the unit
        and whose chamber warms it ("" for none: always powered, at 25 degC).
    power_cycle : PowerCycleModel
        Turn-on, warm-up and temperature behaviour on the fixture (URL keys of
        :data:`POWER_CYCLE_KEYS`).
    held : bool
        The device starts held (the operator's hold, :meth:`SimCore.pause`): it samples
        nothing until it is resumed, so that a recorded unit's first sample (counter 0)
        falls due when the run starts. Not a URL key: the recorder asks for it
        (:func:`devices.urls.open_device`).
    """

    model: str = "STIM300"
    rate: float = 500.0
    warp: float = 1.0
    seed: int | None = None
    history: int = 0
    faults: FaultConfig = field(default_factory=FaultConfig)
    latitude: float | None = None
    orientation: str = ""
    fixture: str = ""
    power_cycle: PowerCycleModel = field(default_factory=PowerCycleModel)
    held: bool = False

    @property
    def serial_number(self) -> str:
        """The serial number the simulated unit reports: ``SIM-<seed>`` (the seed that
        draws its noise, given or drawn), which no two units of a bench share."""
        return f"SIM-{self.seed if self.seed is not None else 0}"


#: Seeds drawn for a simulated unit without ``seed=`` are below this (a CANopen node
#: reports its seed as its UNSIGNED32 serial number, object 0x1018:4).
DRAWN_SEED_LIMIT = 1 << 31


def query_number(key: str, text: str, kind: Callable[[str], Any]) -> Any:
    """``kind(text)`` of a URL query value; a DeviceConfigurationError naming the key."""
    try:
        return kind(text)
    except ValueError as exc:
        raise DeviceConfigurationError(f"URL key {key}={text!r} is not a number") from exc


def parse_sim_params(host_model: str, query: dict[str, str]) -> SimParams:
    """Simulation parameters from a URL's host part and query (unknown keys are left).

    Raises
    ------
    DeviceConfigurationError
        A key has a value of the wrong type or out of range.
    """
    model = query.get("model", host_model) or SimParams.model
    rate = query_number("rate", query.get("rate", str(SimParams.rate)), float)
    warp = query_number("warp", query.get("warp", str(SimParams.warp)), float)
    seed = (query_number("seed", query["seed"], int) if "seed" in query
            else secrets.randbelow(DRAWN_SEED_LIMIT))  # a unit of its own: SIM-<seed>
    history = query_number("history", query.get("history", "0"), int)
    if not (rate > 0 and warp > 0):
        raise DeviceConfigurationError(f"rate and warp must be > 0, got rate={rate} Hz, "
                                       f"warp={warp}")
    if history < 0:
        raise DeviceConfigurationError(f"history must be >= 0 samples, got {history}")
    knobs = {key: query_number(key, query[key], float) for key in FAULT_KEYS if key in query}
    try:
        faults = FaultConfig(**knobs, seed=None if seed is None else seed + 1)
    except ValueError as exc:
        raise DeviceConfigurationError(str(exc)) from exc
    latitude = query_number("latitude", query["latitude"], float) if "latitude" in query else None
    orientation = query.get("orientation", "")
    if (latitude is None) != (not orientation):
        raise DeviceConfigurationError("a simulated gyro on a bench needs both latitude=DEG and "
                                       "orientation=x:up,... (or neither)")
    try:
        earth_rate_by_axis(latitude, parse_orientation(orientation), SIM_AXIS_NAMES)
    except ValueError as exc:
        raise DeviceConfigurationError(str(exc)) from exc
    physics = {attr: query_number(key, query[key], float)
               for key, attr in POWER_CYCLE_KEYS.items() if key in query}
    fixture = query.get("fixture", "")
    if physics and not fixture:
        raise DeviceConfigurationError(
            f"URL keys {', '.join(k for k in POWER_CYCLE_KEYS if k in query)} describe a unit "
            f"on a simulated fixture: give fixture=HOST:PORT/OUTPUT too")
    if fixture:
        parse_fixture(fixture)
    try:
        power_cycle = PowerCycleModel(**physics)
    except ValueError as exc:
        raise DeviceConfigurationError(f"simulated turn-on behaviour: {exc}") from exc
    return SimParams(model, rate, warp, seed, history, faults, latitude, orientation, fixture,
                     power_cycle)


def sim_core(params: SimParams, n_axes: int, clock: WarpClock | None = None, *,
             n_accel_axes: int = 0) -> tuple[SimCore, WarpClock]:
    """The simulator core of a ``sim+`` URL and its time-warped clock.

    It keeps counts of what it generated and lost, and the rates and lost indices of
    the latest ``params.history`` samples only: memory is bounded whatever the run length.
    With ``params.held`` it is returned held (paused) until :meth:`SimCore.resume`.

    Parameters
    ----------
    params : SimParams
        The URL's settings.
    n_axes : int
        Axes of the simulated gyro.
    clock : WarpClock or None
        An existing clock to share (a device run in another process gets its parent's,
        so both count simulated seconds from the same origin); a new one by default.
    n_accel_axes : int
        Accelerometer axes of a simulated IMU (0: a gyro): their gravity comes from the
        bench orientation when the URL gives one, else +g on z.
    """
    core = _new_core(params, n_axes, clock, n_accel_axes)
    if params.held:
        core.pause()  # (before its device's thread starts: no sample before the resume)
    return core, core.clock


def _new_core(params: SimParams, n_axes: int, clock: WarpClock | None, n_accel_axes: int
              ) -> SimCore:
    """The core of :func:`sim_core`, running."""
    clock = clock if clock is not None else WarpClock(params.warp)
    earth = None
    if params.latitude is not None:
        rates = earth_rate_by_axis(params.latitude, parse_orientation(params.orientation),
                                   SIM_AXIS_NAMES[:n_axes])
        earth = [0.0 if r is None else r / S_PER_H for r in rates]
    gravity = (gravity_by_axis(parse_orientation(params.orientation),
                               SIM_AXIS_NAMES[:n_accel_axes]).tolist()
               if params.orientation and n_accel_axes else None)
    signal_source = partial(SignalSource, params.model, params.rate, n_axes=n_axes,
                            earth_rate_deg_s=earth, n_accel_axes=n_accel_axes,
                            gravity_m_s2=gravity)
    if not params.fixture:
        signal = signal_source(seed=params.seed)
        return SimCore(signal, params.rate, clock, params.faults, history=params.history)
    # On a fixture, each opening of the unit (each recorded segment) draws fresh noise:
    # keyed by the seed, the switch-on count and the fixture time of the opening.
    unit = PoweredUnit(params.fixture, params.power_cycle, seed=params.seed or 0, n_axes=n_axes)
    on_count = unit.first_read(clock)
    noise_seed = int(np.random.SeedSequence(
        [params.seed or 0, on_count, time.monotonic_ns() % (1 << 32)]).generate_state(1)[0])
    powered = PoweredSignal(signal_source(seed=noise_seed), unit)
    core = SimCore(powered, params.rate, clock, params.faults, history=params.history)
    powered.bind(core)
    unit.attach(core)
    core.on_close(unit.stop)
    return core
