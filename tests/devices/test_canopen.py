"""CANopen gyro: canopen LocalNode (the shipped EDS) <-> RemoteNode adapter on a
python-can virtual bus.

Proves that the adapter configures the node over SDO (heartbeat, output rate, TPDO1/2
mapping, event timer or SYNC-driven transmission) and starts it with NMT; that it returns exactly
the generated
samples (INT32 x scale) with continuous counters; that lost PDOs and an unplugged node
come back as gaps covering every lost sample, with the node loss reported from the
heartbeat and the reconnect logged; and it pins down canopen's LocalNode PDO pitfall.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Iterator

import canopen
import numpy as np
import pytest

from devices.canopen_node import CanopenRateSource
from devices.sim.canopen_device import GYRO_EDS, CanopenGyroNode
from devices.sim.clock import WarpClock
from devices.sim.faults import SimCore
from devices.sim.signal import SignalSource
from devices.transports.can import CanTransport
from devices.urls import open_device
from tests.devices.helpers import check_accounting, check_lost_share, collect, device_index


def test_round_trip_exact_samples_and_identity() -> None:
    with open_device("sim+canopen://STIM300/5?rate=100&warp=4&history=100000&seed=11") as dev:
        dev.source.open()
        got = collect(dev.source, 400)
        core = dev.simulator.core
        offset = device_index(got, core, 65536, atol=1e-6)
        # No fault is injected: the node loses only what fell due while a loaded host
        # starved its thread (in its ledger; none on a quiet host): each one declared.
        # The sample after such a loss is dropped too: its TPDO1 (no counter) cannot be
        # told from the lost sample's; declared, and only there.
        declared, lost = check_accounting(got, core, offset)
        assert declared - lost <= {i + 1 for i in lost}
        check_lost_share(got, declared)
        np.testing.assert_allclose(got.rate, core.history(got.counter + offset),
                                   atol=0.5e-6 + 1e-12, rtol=0)
        np.testing.assert_allclose(got.column("temperature_c"), 25.0, atol=0.005)
        desc = dev.source.describe()
        assert desc.serial_number == "11"  # read over SDO from 0x1018:4
        assert (desc.protocol, desc.counter_modulus) == ("canopen", 65536)


@contextlib.contextmanager
def spinning_thread(on: bool) -> Iterator[None]:
    """A thread spinning in this process (holding the interpreter half the time), or none."""
    stop = threading.Event()

    def spin() -> None:
        while not stop.is_set():
            pass

    spinner = threading.Thread(target=spin, daemon=True)
    if on:
        spinner.start()
    try:
        yield
    finally:
        stop.set()
        if on:
            spinner.join()


@pytest.mark.parametrize("busy", [False, True], ids=["idle", "busy"])
def test_sync_driven_tpdos_one_sample_per_sync(busy: bool) -> None:
    """``tpdo=sync``: transmission type 1, the adapter's SYNC producer paces the node.

    Busy: a thread spinning in the node's process makes each SYNC slower for the node to
    handle than the SYNC period (2.5 ms here). The node still sends, one sample per SYNC
    it took; taking SYNCs one at a time as they came, it once took them for ever and sent
    nothing (2 samples in 20 s)."""
    with open_device(
        "sim+canopen://STIM300/6?rate=100&warp=4&history=100000&seed=13&tpdo=sync"
    ) as dev:
        dev.source.open()
        with spinning_thread(busy):
            got = collect(dev.source, 300)
        core = dev.simulator.core
        assert dev.simulator.node.tpdo[1].trans_type == 1
        assert dev.simulator.node.tpdo[2].trans_type == 1
        offset = device_index(got, core, 65536, atol=1e-6)
        declared, lost = check_accounting(got, core, offset)
        assert declared == lost
        if not busy:
            assert lost == set()  # a SYNC-driven node samples only when asked
        np.testing.assert_allclose(got.rate, core.history(got.counter + offset),
                                   atol=0.5e-6 + 1e-12, rtol=0)


@pytest.mark.slow
def test_lost_pdos_and_unplugged_node_are_gaps_and_reconnect() -> None:
    url = ("sim+canopen://STIM300/7?rate=100&warp=4&history=100000&seed=12&drop=0.02&corrupt=0.01"
           "&disconnect_every_s=3&disconnect_for_s=2")
    with open_device(url) as dev:
        dev.source.open()
        got = collect(dev.source, 700, deadline_s=30)
        core = dev.simulator.core
        offset = device_index(got, core, 65536, atol=1e-6)
        declared, lost = check_accounting(got, core, offset)
        assert len(lost) >= 150
        # Besides the lost ones, only samples whose TPDO pairing was ambiguous (the
        # first after each outage, a TPDO1 lost next to a lost TPDO2) are declared.
        assert len(declared - lost) <= 2 * got.disconnects + 0.01 * len(got.counter)
        np.testing.assert_allclose(got.rate, core.history(got.counter + offset),
                                   atol=0.5e-6 + 1e-12, rtol=0)
        assert got.disconnects >= 1
        assert {"disconnect", "reconnect"} <= set(got.event_kinds())


def test_sdo_configuration_reaches_the_node() -> None:
    """The node boots at 50 Hz with its EDS mapping; the adapter asks for 100 Hz."""
    clock = WarpClock(4.0)
    core = SimCore(SignalSource("STIM300", 50.0, seed=3), 50.0, clock)
    channel = f"cfg-{time.monotonic_ns()}"
    node = CanopenGyroNode(CanTransport("virtual", channel), core, node_id=9).start()
    source = CanopenRateSource(CanTransport("virtual", channel), 9, GYRO_EDS,
                               sample_rate_hz=100.0, heartbeat_ms=40, clock=clock,
                               clock_scale=4.0)
    try:
        source.open()
        got = collect(source, 300)
        local = node.node
        assert local.sdo[0x1017].raw == 40 and local.sdo[0x2006].raw == 100
        assert [v.name for v in local.tpdo[2].map] == ["Rate Z", "Sample counter",
                                                     "Temperature"]
        assert local.tpdo[1].event_timer == 10 and local.tpdo[1].trans_type == 254
        assert core.sample_rate_hz == 100.0  # the node applied the rate written over SDO
        assert len(got.counter) >= 300
    finally:
        source.close()
        node.stop()


def test_local_node_pdo_payload_is_the_maps_own_copy() -> None:
    """canopen pitfall: writing the SDO object does not change what the TPDO sends."""
    node = canopen.LocalNode(5, str(GYRO_EDS))
    canopen.Network().add_node(node)  # no bus needed: nothing is sent
    node.tpdo.read(from_od=True)
    node.sdo["Rate X"].raw = 1234
    assert node.tpdo[1]["Rate X"].raw == 0
    node.tpdo[1]["Rate X"].raw = 1234
    assert bytes(node.tpdo[1].data[:4]) == (1234).to_bytes(4, "little")
