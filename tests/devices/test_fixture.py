"""The fixture around the gyros: relay and chamber register maps (pure, fuzzed), their
adapters against a simulated fixture on a real pymodbus server (127.0.0.1), and a
simulated gyro that its relay powers and its chamber warms."""

from __future__ import annotations

import time

import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st

from analysis.models.power_cycle import ThermalModel
from analysis.units.conversions import S_PER_H
from devices.codecs.fixture_map import SIM_WIRING, ChamberMap, OutletState, RelayMap
from devices.errors import CodecError, DeviceConfigurationError, DeviceProtocolError
from devices.fixture import open_chamber, open_power_switch
from devices.sim.fixture_server import SimulatedFixture
from devices.sim.powered import turn_on_draw
from devices.urls import open_device

FUZZ = settings(max_examples=50, deadline=None)


@FUZZ
@given(st.floats(-70.0, 180.0))
@example(1.05)
def test_set_point_round_trips_to_its_resolution(temperature: float) -> None:
    m = ChamberMap()
    # half a step of 0.1 degC, and the float error of a value that lies exactly halfway
    # (1.05 degC: 10.5 steps rounds to even, 1.0, and 1.05 - 1.0 is 0.05 + 4e-17)
    half_step = 0.5 * m.setpoint.scale * (1.0 + 1e-9)
    within = pytest.approx(temperature, abs=half_step)
    assert m.decode_setpoint(m.encode_setpoint(temperature)) == within
    assert m.decode_measured(m.encode_measured(temperature)) == within


@FUZZ
@given(st.lists(st.integers(-(2**20), 2**20), max_size=4))
def test_set_points_outside_the_chamber_are_refused(words: list[int]) -> None:
    m = ChamberMap(min_c=-40.0, max_c=85.0)
    for t in (-40.5, 85.5, float("nan"), float("inf")):
        with pytest.raises(CodecError):
            m.encode_setpoint(t)
    try:  # any register block decodes or fails as a FrameError, never anything else
        m.decode_measured(words)
    except CodecError:
        pass


@FUZZ
@given(st.floats(0.0, 4.0e6), st.lists(st.tuples(st.booleans(), st.integers(0, 65535),
                                                 st.floats(0.0, 4.0e6), st.floats(-60, 150),
                                                 st.floats(-1.0, 1.0)), min_size=1, max_size=6))
def test_sim_wiring_round_trips(now: float, outlets: list[tuple]) -> None:
    states = [OutletState(*o) for o in outlets]
    block = SIM_WIRING.encode(now, states)
    for k, s in enumerate(states):
        t, got = SIM_WIRING.decode(block, k)
        assert t == pytest.approx(now, abs=1e-3)
        assert (got.powered, got.on_count) == (s.powered, s.on_count)
        assert got.on_time_s == pytest.approx(s.on_time_s, abs=1e-3)
        assert got.die_c == pytest.approx(s.die_c, rel=1e-6, abs=1e-4)


def test_relay_map_and_urls_refuse_what_does_not_exist() -> None:
    with pytest.raises(CodecError):
        RelayMap(0, 4).coil(4)
    for url, key in (("serial:///dev/ttyUSB0?coil=1", "scheme .serial."),
                     ("modbus+tcp://10.0.0.5:502/1?coill=2", "coil"),
                     ("modbus+tcp://:502/1", "no host")):
        with pytest.raises(DeviceConfigurationError, match=key):
            open_power_switch(url)
    with pytest.raises(DeviceConfigurationError, match="bad chamber register keys"):
        open_chamber("modbus+tcp://10.0.0.6:502/1?kind=int64")


def test_relays_and_chamber_over_modbus() -> None:
    """Each output switches its own coil and reads back; the chamber takes a set point,
    refuses one out of range (a Modbus exception), and its air follows the set point
    through its lag, the dies through theirs, a powered die warmer by its self-heating."""
    thermal = ThermalModel(unit_tau_s=40.0, self_heating_c=2.0)
    with SimulatedFixture(2, warp=200.0, chamber_tau_s=60.0, thermal=thermal) as fx:
        relay0, relay1 = (open_power_switch(fx.power_url(k)) for k in range(2))
        chamber = open_chamber(fx.chamber_url)
        for d in (relay0, relay1, chamber):
            d.open()
        try:
            before = time.time()
            switched = relay1.set_power(True)
            assert before <= switched <= time.time()
            assert (relay0.is_powered(), relay1.is_powered()) == (False, True)
            assert fx.outlet(1).on_count == 1 and not fx.outlet(0).powered
            chamber.set_temperature(45.0)
            assert chamber.setpoint_c() == pytest.approx(45.0)
            with pytest.raises(CodecError):
                chamber.set_temperature(500.0)
            with pytest.raises(DeviceProtocolError):  # 250 degC: the server refuses
                chamber.transport.write_registers(0, [2500], 2)
            assert chamber.setpoint_c() == pytest.approx(45.0)
            time.sleep(1.5)  # 300 s of fixture time: 5 chamber time constants
            t = fx.time_s()
            air = chamber.temperature_c()
            assert air == pytest.approx(45.0 - 20.0 * np.exp(-t / 60.0), abs=0.6)
            powered, unpowered = fx.outlet(1).die_c, fx.outlet(0).die_c
            assert powered - unpowered == pytest.approx(2.0, abs=0.3)
        finally:
            for d in (relay0, relay1, chamber):
                d.close()


def _read_for(source: object, wall_s: float) -> list:
    from devices.errors import DeviceTimeoutError

    batches = []
    end = time.monotonic() + wall_s
    while time.monotonic() < end:
        try:
            b = source.read(0.02)  # type: ignore[attr-defined]
        except DeviceTimeoutError:
            continue
        if len(b):
            batches.append(b)
    return batches


def test_a_simulated_gyro_on_the_fixture() -> None:
    """Silent while its relay is off; after switch-on, silent for the turn-on time its
    switch-on drew, then its bias carries the turn-on bias drawn, the warm-up transient
    and the temperature coefficient times its die's warming (the fixture's truth)."""
    warp = 100.0
    thermal = ThermalModel(unit_tau_s=50.0, self_heating_c=4.0)
    with SimulatedFixture(1, warp=warp, thermal=thermal) as fx:
        url = (f"sim+serial://VG951?protocol=xbus&rate=10&warp={warp:g}&seed=4"
               f"&fixture={fx.wiring(0)}&turn_on_s=3&turn_on_jitter_s=0.5"
               f"&turn_on_bias_deg_h=30&warmup_deg_h=40&warmup_tau_s=20&tempco=2")
        relay = open_power_switch(fx.power_url(0))
        relay.open()
        with open_device(url) as opened:
            source = opened.source
            source.open()
            assert not _read_for(source, 0.1)  # off: nothing
            switched = relay.set_power(True)
            clock = opened.simulator.core.clock  # type: ignore[union-attr]
            on_unit = clock() - (time.time() - switched) * warp
            batches = _read_for(source, 1.6)
            relay.set_power(False)
            relay.close()
        t = np.concatenate([b.receive_time_s for b in batches])
        c = np.concatenate([b.counter for b in batches])
        rate = np.concatenate([b.rate_deg_s[:, 0] for b in batches]) * S_PER_H
        temp = np.concatenate([b.temperature_c for b in batches])
    draw = turn_on_draw(opened.simulator.core.signal.unit.model, 4, 1, 3)  # type: ignore[union-attr]
    # its counter starts at 0 at the boot (a loaded host may miss the first frames)
    first = float(np.min(t[:400] - c[:400] / 10.0)) - on_unit
    # to 10 ms of wall time (x100) of the host's scheduling, the switch-on's exchange
    assert first == pytest.approx(draw.turn_on_s + 0.1, abs=1.0)
    since_on = first + c / 10.0
    early, late = since_on < 20.0, since_on > 120.0
    # VG951 has no bias of its own: the transient adds 40 exp(-t/20), the warming 2 degC^-1
    expected = draw.bias_deg_h[0] + 40.0 * np.exp(-since_on / 20.0) + 2.0 * (temp - 25.0)
    # the 40 s mean of the unit's own noise: white 1.45 deg/h per sample (0.07 over 400
    # samples) and its flicker, B = 0.125 deg/h, whose mean over a window wanders by
    # several B from one switch-on to the next (seen: 0.1 to 0.74 deg/h); the effects
    # checked are 30 (turn-on), 40 (transient) and 2 x 3.7 (warming) deg/h
    assert rate[late].mean() == pytest.approx(expected[late].mean(), abs=1.2)
    assert rate[early].mean() - rate[late].mean() > 15.0
    assert temp[-1] - temp[0] > 2.0  # the die warms by its self-heating


def test_a_fixture_started_again_goes_on_counting_switch_ons() -> None:
    """Started with the switch-ons a resumed sequence's journal holds, the next switch-on of
    an output is the one after them (a unit on it draws that switch-on's turn-on bias, not
    its first again); the other outputs count from 0; counts that do not fit are refused."""
    with SimulatedFixture(2, warp=50.0, on_counts=(3,)) as fx:
        assert (fx.outlet(0).on_count, fx.outlet(1).on_count) == (3, 0)
        relays = [open_power_switch(fx.power_url(k)) for k in range(2)]
        for relay in relays:
            relay.open()
        try:
            for relay in relays:
                relay.set_power(True)
            assert (fx.outlet(0).on_count, fx.outlet(1).on_count) == (4, 1)
        finally:
            for relay in relays:
                relay.close()
    for bad in ((1, 2, 3), (-1,)):
        with pytest.raises(ValueError, match="on_counts"):
            SimulatedFixture(2, on_counts=bad)
