"""Raw CAN gyros end to end: simulated node -> python-can virtual bus -> adapter.

Proves for a shared-frame layout (8-bit counter), a frame-per-axis layout (AUTOSAR E2E
Profile 1: 4-bit alive counter 0..14) and the shipped Bosch MM7.10 layout (no CRC, a
4-bit counter 0..15, offset-binary signals) that the adapter returns exactly the
generated samples to the layout's resolution, that dropped and corrupted frames come back
as gaps of exactly the lost samples (an incomplete per-axis sample included), and that a
silent node is reported lost and picked up again with the outage counted exactly.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from devices.can_raw import CanRateSource
from devices.codecs.base import Reading
from devices.codecs.can_frame import PER_AXIS_LAYOUT
from devices.transports.can import CanTransport
from devices.urls import open_device
from tests.devices.helpers import check_accounting, check_lost_share, collect, device_index

LAYOUTS = {"shared": (256, 2.0**-14), "per_axis": (15, 0.5e-6), "MM7.10": (16, 0.0025)}


@pytest.mark.parametrize("layout", LAYOUTS)
def test_round_trip_exact_samples(layout: str) -> None:
    modulus, half_lsb = LAYOUTS[layout]
    with open_device(
        f"sim+can://STIM300?layout={layout}&rate=500&warp=5&history=100000&seed=5"
    ) as dev:
        dev.source.open()
        got = collect(dev.source, 1200)
        core = dev.simulator.core
        offset = device_index(got, core, modulus, atol=2 * half_lsb)
        # No fault is injected: the node loses only what fell due while a loaded host
        # starved its thread (in its ledger; none on a quiet host): each one declared.
        declared, lost = check_accounting(got, core, offset)
        assert declared == lost
        check_lost_share(got, declared)
        np.testing.assert_allclose(got.rate, core.history(got.counter + offset),
                                   atol=half_lsb + 1e-12, rtol=0)
        desc = dev.source.describe()
        assert desc.counter_modulus == modulus
        assert desc.has_temperature == (layout != "shared")


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.slow
def test_faults_are_exact_gaps_and_node_loss_reconnects(layout: str) -> None:
    modulus, half_lsb = LAYOUTS[layout]
    url = (f"sim+can://STIM300?layout={layout}&rate=500&warp=5&history=100000&seed=6&drop=0.02"
           "&corrupt=0.02&disconnect_every_s=1.0&disconnect_for_s=4")  # 0.8 s wall > 0.5 s
    with open_device(url) as dev:
        dev.source.open()
        got = collect(dev.source, 1800, deadline_s=30)
        core = dev.simulator.core
        offset = device_index(got, core, modulus, atol=2 * half_lsb)
        declared, lost = check_accounting(got, core, offset)
        assert declared == lost and len(lost) >= 2000
        # (without the E2E CRC the CAN controller's own CRC drops a corrupted frame)
        assert (got.crc_errors > 0) == (layout != "MM7.10") and got.disconnects >= 1
        assert {"disconnect", "reconnect"} <= set(got.event_kinds())
        assert "counter+elapsed" in {g.method for g in got.gaps}


def test_gap_times_are_on_the_units_clock() -> None:
    """The gaps' times come from the bus's frame stamps mapped to the unit's (warped)
    clock, origin included: each is when the sample after it fell due on the unit's
    clock (to a few ms), not the host's uptime times the warp, and not when a loaded
    host got round to reading it (the samples' receive times: up to a second later)."""
    url = "sim+can://STIM300?layout=shared&rate=500&warp=5&seed=8&drop=0.05&history=100000"
    with open_device(url) as dev:
        dev.source.open()
        got = collect(dev.source, 1000)
        core = dev.simulator.core
        offset = device_index(got, core, 256, atol=2.0**-13)
        check_accounting(got, core, offset)
        assert len(got.gaps) >= 10
        for gap in got.gaps:
            due_s = core.due_time(gap.after_counter + gap.missing_samples + 1 + offset)
            # (two pairings of the wall and unit clocks, each to well under 1 ms of wall)
            assert abs(gap.receive_time_s - due_s) < 0.02, (gap, due_s)


def test_node_silence_limit_is_on_the_units_clock() -> None:
    """At warp 20 a 2 s outage of the node lasts 0.1 s of wall time: longer than the
    0.5 s silence limit on the unit's own (simulated) time base, so it is reported and
    the node picked up again, the outage counted from the frame time stamps."""
    url = ("sim+can://STIM300?layout=shared&rate=100&warp=20&seed=9&history=100000"
           "&disconnect_every_s=3&disconnect_for_s=2")
    with open_device(url) as dev:
        dev.source.open()
        got = collect(dev.source, 700, deadline_s=30)
        core = dev.simulator.core
        kinds = got.event_kinds()
        assert kinds.count("disconnect") >= 2 and kinds.count("reconnect") >= 2, kinds
        offset = device_index(got, core, 256, atol=2.0**-13)
        declared, lost = check_accounting(got, core, offset)
        assert declared == lost and len(lost) >= 300


def test_a_silence_read_late_is_still_a_node_loss() -> None:
    """A host that reads the frames from before and after an outage in one go (here the
    test sleeps through it, as a loaded host's scheduler may) never sees the node
    silent as it happens: the frames' time stamps show the silence, reported all the
    same, at the moment the limit ran out."""
    import time

    url = ("sim+can://STIM300?layout=shared&rate=100&warp=20&seed=9&history=100000"
           "&disconnect_every_s=3&disconnect_for_s=2")  # silent from 3 to 5 simulated s
    with open_device(url) as dev:
        dev.source.open()
        time.sleep(0.35)  # 7 simulated s
        got = collect(dev.source, 400)
        core = dev.simulator.core
        events = [e for b in got.batches for e in b.events]
        # (a loaded host that starves the node's thread for 0.5 simulated s makes more)
        assert [e.kind for e in events] == ["connect"] + ["disconnect", "reconnect"] * (
            len(events) // 2), events
        assert got.disconnects == 0  # none seen as it happened
        offset = device_index(got, core, 256, atol=2.0**-13)
        declared, lost = check_accounting(got, core, offset)
        assert declared == lost and len(lost) >= 190
        outage = max(got.gaps, key=lambda g: g.missing_samples)
        limit_s = core.due_time(outage.after_counter + offset) + 0.5  # the last frame's + 0.5
        assert [e for e in events if e.kind == "disconnect" and "time stamps" in e.detail
                and abs(e.receive_time_s - limit_s) < 0.02], (events, limit_s)


def test_frames_a_held_node_sent_before_its_hold_are_not_read_across_it() -> None:
    """The recorder holds a simulated node until the run starts; frames it sent before
    the hold took effect carry times before it, and its counter goes on after it without
    a gap: read together, the hold (here 4 simulated s, 2000 samples) would be counted as
    counter wraps. From ``quiet_until_now`` on they are not read."""
    with open_device("sim+can://STIM300?rate=500&warp=4&seed=1") as dev:
        source, core = dev.source, dev.simulator.core
        source.open()
        time.sleep(0.1)  # the node sends before the station holds it
        core.pause()
        time.sleep(1.0)
        source.quiet_until_now()  # the run starts
        core.resume()
        got = collect(source, 300)
    gaps = [g for b in got.batches for g in b.gaps]
    assert not [g for g in gaps if g.missing_high > 20], gaps
    assert got.counter[0] > 0  # the samples before the hold are not the run's


def test_frames_a_whole_number_of_wraps_apart_never_make_one_sample() -> None:
    """Profile 1's alive counter (0..14, a frame per axis) at 500 Hz comes round every
    30 ms. A sample whose Y frame is lost just before a 3.99 s outage (1995 samples, 133
    wraps) and the sample with the same counter just after it, whose X frame is lost,
    must not make one sample of the first's X and the second's Y and Z: both are gaps. On
    the real python-can virtual bus, with the frames' time stamps as the node gave them."""
    layout, rate_hz, channel = PER_AXIS_LAYOUT, 500.0, "wraps-apart"
    node = CanTransport("virtual", channel, preserve_timestamps=True)
    source = CanRateSource(CanTransport("virtual", channel), layout, model="STIM300",
                           serial_number="T-1", sample_rate_hz=rate_hz, silence_timeout_s=10.0)
    source.open()
    node.open()
    t0 = time.time() - 5.0  # stamped in the past: the whole story is on the bus at once

    def send(index: int, axes: str = "xyz") -> None:
        reading = Reading((0.001 * index, -0.001 * index, 0.5), index, temperature_c=25.0)
        for axis, frame in zip("xyz", layout.from_reading(reading), strict=True):
            if axis in axes:
                node.send(frame.arbitration_id, layout.encode(frame), t0 + index / rate_hz)

    try:
        for i in range(480, 494):
            send(i)
        send(494, "xz")  # Y lost, then the node is silent for 1995 samples
        send(2489, "yz")  # X lost: the same counter as 494
        for i in range(2490, 2505):
            send(i)
        got = collect(source, 29)
    finally:
        node.close()
        source.close()
    assert len(got.counter) == 29  # 480..493 and 2490..2504: no sample made of two
    rate = got.rate
    np.testing.assert_allclose(rate[14:, 0], 0.001 * np.arange(2490, 2505), atol=1e-6)
    [gap] = got.gaps
    assert gap.missing_samples == 1996 and gap.low == gap.high == 1996  # 494..2489
