"""``record --sequence``: run (or resume) a profile's test sequence on every unit of a fixture.

:func:`prepare_sequence` checks the request against the sequence (a supply switch per
unit where it switches them, a chamber where it sets one), finds a sequence of the same
name, profile and units left unfinished in the output folder (resumed, not restarted),
opens the fixture's devices, and returns the prepared run; :meth:`PreparedSequence.execute`
runs it. With ``power=("sim",)`` or ``chamber="sim"`` a simulated fixture
(:class:`~devices.sim.fixture_server.SimulatedFixture`) is served on 127.0.0.1 for the
run, every unit (simulated, ``sim+``) is wired to its own relay output and sits in its
chamber, and the sequence's durations count on the fixture's warped clock.
"""

from __future__ import annotations

import uuid
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any
from urllib.parse import parse_qsl, urlsplit

from analysis.models.power_cycle import ThermalModel
from devices.errors import DeviceError
from devices.fixture import ModbusChamber, ModbusPowerSwitch, open_chamber, open_power_switch
from devices.sim.clock import WarpClock
from devices.sim.fixture_server import SimulatedFixture
from station.errors import RecordFormatError, UsageError
from station.evaluation.sequence_cycles import switch_on_cycles, unit_segments
from station.model.bench import load_bench
from station.model.documents import Subscriber
from station.model.profiles import Profile, load_profile
from station.model.sequence_runs import SequenceRun
from station.model.sequences import SequenceSpec, Step
from station.recording.sequence_runner import SequenceClock, SequenceConfig, SequenceRunner
from station.storage.hdf5 import open_run_file, unit_counts
from station.storage.sequence_files import read_sequence, segment_path

SIM = "sim"


@dataclass(frozen=True)
class SimFixtureSettings:
    """The physics of a simulated fixture (``--power sim``, ``--chamber sim``).

    Attributes
    ----------
    ambient_c : float
        Air, die and set point at the start, degC.
    chamber_tau_s : float
        The air's time constant following the set point, s.
    unit_tau_s : float
        The units' thermal time constant, s.
    self_heating_c : float
        How much warmer a powered unit's die gets than the air, degC.
    """

    ambient_c: float = 25.0
    chamber_tau_s: float = 600.0
    unit_tau_s: float = 120.0
    self_heating_c: float = 0.0


@dataclass(frozen=True)
class SequenceRequest:
    """A sequence to run.

    Attributes
    ----------
    sequence : str
        Its name in the profile (``[sequence.NAME]``).
    profile : str
        Profile name or TOML path.
    units : tuple of str
        Device URLs, one per unit.
    power : tuple of str
        Each unit's supply switch (one URL per unit), or ``("sim",)``; empty when the
        sequence switches nothing.
    chamber : str or None
        The chamber's URL, or ``"sim"``.
    out : Path
        Folder for the sequence file and its segments, or a ``.h5`` path.
    operator, lot : str
        Run metadata.
    bench : str or None
        Bench file (latitude, axis directions).
    fixture : SimFixtureSettings
        The simulated fixture's physics, when one is asked for.
    chamber_log_s : float
        Sequence seconds between the chamber readings the journal keeps.
    """

    sequence: str
    profile: str
    units: tuple[str, ...]
    power: tuple[str, ...] = ()
    chamber: str | None = None
    out: Path = Path("runs")
    operator: str = ""
    lot: str = ""
    bench: str | None = None
    fixture: SimFixtureSettings = field(default_factory=SimFixtureSettings)
    chamber_log_s: float = 60.0


def _sim_warp(url: str) -> float | None:
    """A ``sim+`` URL's warp (1 when unset); None for hardware."""
    parts = urlsplit(url)
    if not parts.scheme.lower().startswith("sim+"):
        return None
    return float(dict(parse_qsl(parts.query)).get("warp", "1"))


def _with_key(url: str, key: str, value: str) -> str:
    if key in dict(parse_qsl(urlsplit(url).query)):
        raise UsageError(f"{url}: the simulated fixture wires its units itself; drop {key}=")
    return f"{url}{'&' if '?' in url else '?'}{key}={value}"


def check_request(request: SequenceRequest, spec: SequenceSpec) -> None:
    """Refuse a request the sequence cannot run with.

    Raises
    ------
    UsageError
        No unit; the sequence switches supplies and no switch is given for each unit; it
        sets a chamber and none is given; a simulated fixture with real units.
    """
    n = len(request.units)
    if not n:
        raise UsageError("no unit: give --unit DEVICE_URL for each unit on the fixture")
    if spec.uses_power and not request.power:
        raise UsageError(f"sequence {spec.name} switches the units' supplies: give --power URL "
                         f"for each unit (modbus+tcp://HOST:PORT/UNIT?coil=N), or --power sim")
    if request.power and request.power != (SIM,) and len(request.power) != n:
        raise UsageError(f"{len(request.power)} --power for {n} --unit: give one supply switch "
                         f"per unit, in the order of the units")
    if spec.uses_chamber and not request.chamber:
        raise UsageError(f"sequence {spec.name} sets a chamber: give --chamber URL "
                         f"(modbus+tcp://HOST:PORT/UNIT), or --chamber sim")
    if SIM in (request.chamber, *request.power):
        warps = {_sim_warp(u) for u in request.units}
        if None in warps:
            raise UsageError("a simulated fixture (--power sim, --chamber sim) powers simulated "
                             "units only: give sim+ device URLs")
        if len(warps) != 1:
            raise UsageError(f"the units of a simulated fixture share its clock: give them one "
                             f"warp (they have {sorted(w for w in warps if w is not None)})")
        if request.power not in ((), (SIM,)) or request.chamber not in (None, SIM):
            raise UsageError("use --power sim and --chamber sim together (or real devices for "
                             "both)")


def sequence_path(out: Path, name: str) -> Path:
    """A new sequence file: ``out`` itself if it ends in .h5, else a new name in it."""
    if out.suffix.lower() in (".h5", ".hdf5"):
        return out
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    return out / f"seq-{name}-{stamp}-{uuid.uuid4().hex[:8]}.h5"


def find_unfinished(out: Path, name: str, profile: Profile, units: tuple[str, ...]
                    ) -> SequenceRun | None:
    """The newest sequence in ``out`` (a folder, or that file) with this name, profile and
    units that did not finish (None when there is none).

    Raises
    ------
    UsageError
        ``out`` is a sequence file that finished, or another sequence's.
    """
    if out.suffix.lower() in (".h5", ".hdf5"):
        if not out.exists():
            return None
        try:
            run = read_sequence(out)
        except RecordFormatError as exc:
            raise UsageError(f"{out} exists and is not a sequence file: choose another --out"
                             ) from exc
        if run.done:
            raise UsageError(f"{out} holds a finished sequence: choose another --out")
        if (run.name, run.profile, run.unit_urls) != (name, profile.name, units):
            raise UsageError(f"{out} holds sequence {run.name} of profile {run.profile} for "
                             f"other units: choose another --out")
        return run
    found = [run for run in readable_sequences(out)
             if not run.done and run.state != "failed" and run.name == name
             and run.profile == profile.name and run.unit_urls == units]
    return max(found, key=lambda r: r.start_utc) if found else None


def readable_sequences(folder: Path) -> list[SequenceRun]:
    """The sequence files (``seq-*.h5``) of ``folder`` that can be read, in name order
    (none when it is no folder)."""
    found = []
    for path in sorted(folder.glob("seq-*.h5")) if folder.is_dir() else []:
        try:
            found.append(read_sequence(path))
        except RecordFormatError:
            continue
    return found


@dataclass
class PreparedSequence:
    """A sequence ready to run: its runner and what it holds open (close it after)."""

    runner: SequenceRunner
    spec: SequenceSpec
    fixture: SimulatedFixture | None
    resources: ExitStack

    @property
    def resumed(self) -> bool:
        """Whether this continues a sequence found unfinished."""
        return self.runner.resumed

    def execute(self) -> SequenceRun:
        """Run the steps (see :meth:`SequenceRunner.execute`)."""
        return self.runner.execute()

    def close(self) -> None:
        """Close the devices and stop a simulated fixture."""
        self.resources.close()

    def __enter__(self) -> PreparedSequence:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def prepare_sequence(request: SequenceRequest, *,
                     subscribers: Callable[[Step], list[Subscriber]] | None = None,
                     notify: Callable[[str], None] | None = None) -> PreparedSequence:
    """Check, open the fixture's devices, and build the runner (new or resumed).

    Raises
    ------
    UsageError
        A request the sequence cannot run with (:func:`check_request`).
    ProfileError
        No such profile or sequence.
    SequenceError
        A supply switch or the chamber cannot be reached.
    """
    from station.recording.sequence_runner import SequenceError

    profile = load_profile(request.profile)
    spec = profile.sequence(request.sequence)
    check_request(request, spec)
    given = tuple(request.units)
    urls = list(given)
    bench_json = ""
    if request.bench is not None:
        bench = load_bench(request.bench)
        urls, bench_json = [bench.sim_url(u) for u in urls], bench.as_json()
    stack = ExitStack()
    fixture: SimulatedFixture | None = None
    clock: SequenceClock | None = None
    power_urls, chamber_url = list(request.power), request.chamber or ""
    existing = find_unfinished(request.out, spec.name, profile, given)
    try:
        if SIM in (request.chamber, *request.power):
            s = request.fixture
            warp = _sim_warp(urls[0]) or 1.0
            # started again for a resume, the fixture's count of switch-ons goes on from
            # the journal's: a unit switched on again draws its next turn-on, not its first
            ons = [] if existing is None else [len(existing.switch_ons(u))
                                               for u in existing.unit_ids]
            fixture = SimulatedFixture(len(urls), warp=warp, ambient_c=s.ambient_c,
                                       chamber_tau_s=s.chamber_tau_s,
                                       thermal=ThermalModel(s.unit_tau_s, s.self_heating_c),
                                       on_counts=ons).start()
            stack.callback(fixture.stop)
            urls = [_with_key(u, "fixture", fixture.wiring(i)) for i, u in enumerate(urls)]
            power_urls = [fixture.power_url(i) for i in range(len(urls))] if request.power else []
            chamber_url = fixture.chamber_url if request.chamber else ""
            clock = fixture.clock
        elif all(w is not None for w in map(_sim_warp, urls)):
            clock = WarpClock(_sim_warp(urls[0]) or 1.0)
        switches: list[ModbusPowerSwitch] = []
        for url in power_urls:
            switch = open_power_switch(url)
            switch.open()
            stack.callback(switch.close)
            switches.append(switch)
        chamber: ModbusChamber | None = None
        if chamber_url:
            chamber = open_chamber(chamber_url)
            chamber.open()
            stack.callback(chamber.close)
    except DeviceError as exc:
        stack.close()
        raise SequenceError(f"the fixture cannot be reached: {exc}") from exc
    except BaseException:
        stack.close()
        raise
    path = Path(existing.path) if existing else sequence_path(request.out, spec.name)
    path.parent.mkdir(parents=True, exist_ok=True)
    config = SequenceConfig(spec, profile, tuple(urls), given,
                            tuple(request.power if request.power != (SIM,) else power_urls),
                            request.chamber or "", path, request.operator, request.lot,
                            bench_json, request.chamber_log_s)
    runner = SequenceRunner(config, power=switches, chamber=chamber, clock=clock,
                            existing=existing, subscribers=subscribers, notify=notify)
    return PreparedSequence(runner, spec, fixture, stack)


def sequence_summary(run: SequenceRun) -> list[dict[str, Any]]:
    """The ``--json-summary`` objects of a sequence: per unit, what its segments hold.

    ``cycles`` counts the unit's switch-ons that recorded data, as ``station grade`` counts
    them (:func:`station.evaluation.sequence_cycles.switch_on_cycles`): one a resume made
    is one."""
    out = []
    turn_ons = sum(1 for a, b in zip(run.steps, run.steps[1:], strict=False)
                   if a.kind == "power_on" and b.kind == "record"
                   and b.index in {s.step for s in run.segments})
    for unit_id, url in zip(run.unit_ids, run.unit_urls, strict=True):
        recorded = missing = 0
        for seg in run.segments:
            try:
                with open_run_file(segment_path(run, seg)) as f:
                    counts = unit_counts(f, unit_id)
            except (OSError, RecordFormatError, KeyError):
                continue
            recorded += counts.samples_recorded
            missing += counts.samples_missing_declared
        out.append({"unit": url, "unit_id": unit_id, "file": run.path, "sequence": run.name,
                    "state": run.state,
                    "cycles": len(switch_on_cycles(unit_segments(run, unit_id))),
                    "turn_ons": turn_ons, "segments": len(run.segments),
                    "interruptions": len(run.interruptions()),
                    "samples_recorded": recorded, "samples_missing_declared": missing})
    return out
