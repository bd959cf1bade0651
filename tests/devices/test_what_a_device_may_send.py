"""What a device, or the operator, may send the station, and what the station makes of it.

* Device URLs: a key given twice, or one no adapter knows, is refused by name.
* A simulated CAN bus across processes stays on this host unless told otherwise.
* A Modbus register block with values that are not 16-bit integers is the codec's
  FrameError, never a TypeError.
* The sanity checks every adapter applies: a sample that is not a finite number or lies
  beyond the measurement range is a bad sample (left out, counted, its counter slot
  declared missing); a counter that breaks the sequence for one frame (a corrupted frame
  a weak checksum let through) is a bad sample, not two gaps of most of a counter period.
"""

from __future__ import annotations

import math
import socket
import warnings

import pytest
from hypothesis import given, settings, strategies as st

from devices.batching import BatchBuilder
from devices.codecs.base import Reading
from devices.codecs.modbus_map import GYRO_FLOAT32_MAP, GYRO_INT32_MAP
from devices.errors import DeviceConfigurationError, ExposedBusWarning, FrameError
from devices.gaps import CounterTracker
from devices.sim.process import MulticastChannel
from devices.urls import open_device
from tests.devices.helpers import multicast_unavailable


@pytest.mark.parametrize(("url", "named"), [
    ("sim+serial://STIM300?protocol=stim300&drop=0.1&drop=0.5", "'drop' is given twice"),
    ("sim+serial://STIM300?protocol=stim300&dorp=0.5", "unknown URL key 'dorp'"),
    ("serial:///dev/ttyUSB0?protocol=kvh1750&datagram=0x94", "unknown URL key 'datagram'"),
    ("sim+can://VG951?bitrate=500000", "unknown URL key 'bitrate'"),
    ("modbus+tcp://10.0.0.7:502/1?rate=10&baud=9600", "unknown URL key 'baud'"),
    ("sim+can://VG951?interface=udp_multicast&bind=everywhere", "bind='everywhere'"),
])
def test_a_repeated_or_unknown_url_key_is_refused_by_name(url: str, named: str) -> None:
    with pytest.raises(DeviceConfigurationError) as info:
        open_device(url).close()
    assert named in str(info.value)
    if "dorp" in url:
        assert "did you mean 'drop'" in str(info.value)


@pytest.mark.skipif(bool(multicast_unavailable()), reason=multicast_unavailable() or "")
def test_a_simulated_multicast_bus_stays_on_loopback_unless_told() -> None:
    channel = MulticastChannel.fresh()
    a, b = channel.transport(), channel.transport()
    a.open()
    b.open()
    try:
        sock = b.bus._multicast._socket  # type: ignore[union-attr]
        assert sock.getsockname() == (channel.group, channel.port)  # not 0.0.0.0
        assert sock.getsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL) == 0
        a.send(0x123, b"probe")
        assert bytes(b.recv(2.0).data) == b"probe"  # loopback works
        # a datagram to the port from an address (not the group) is not taken
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as other:
            other.sendto(b"injected", ("127.0.0.1", channel.port))
        assert b.recv(0.2) is None
    finally:
        a.close()
        b.close()
    wide = MulticastChannel.fresh(loopback=False).transport()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        wide.open()
    wide.close()
    assert any(issubclass(w.category, ExposedBusWarning) for w in caught)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.one_of(st.integers(-10, 70000), st.floats(), st.none(), st.text(max_size=2),
                          st.booleans()), max_size=120))
def test_modbus_blocks_of_anything_are_frame_errors_or_readings(block: list) -> None:
    for regs in (GYRO_INT32_MAP, GYRO_FLOAT32_MAP):
        try:
            regs.decode(block)
        except FrameError:
            pass


def _builder(**kwargs: object) -> BatchBuilder:
    return BatchBuilder(3, CounterTracker(256, 100.0), has_device_time=False,
                        has_temperature=False, **kwargs)


def _reading(counter: int, rate: float = 0.01) -> Reading:
    return Reading((rate, rate, rate), counter % 256)


def test_non_finite_and_out_of_range_samples_are_bad_samples_counted_and_declared() -> None:
    builder = _builder(rate_limit_deg_s=400.0)
    for i, rate in enumerate([0.01, math.nan, 0.01, math.inf, 0.01, 812.0, 0.01]):
        builder.add(_reading(i, rate), i / 100.0)
    batch = builder.take(1.0)
    assert batch.counter.tolist() == [0, 2, 4, 6]
    bad = [e for e in batch.events if e.kind == "bad_sample"]
    assert [e.detail for e in bad] == ["rate not a finite number"] * 2 + [
        "rate beyond the 400 deg/s range"]
    assert [(g.after_counter, g.missing_samples) for g in batch.gaps] == [(0, 1), (2, 1), (4, 1)]


def test_a_corrupted_counter_is_one_bad_sample_not_two_gaps() -> None:
    builder = _builder(check_continuity=True)
    for i, counter in enumerate([10, 11, 12, 75, 13, 14, 17, 18, 19]):  # 75: corrupted; 17: a gap
        builder.add(_reading(counter), i / 100.0)
    batch = builder.take(1.0)
    assert batch.counter.tolist() == [10, 11, 12, 13, 14, 17, 18, 19]
    assert [e.detail for e in batch.events if e.kind == "bad_sample"] == [
        "counter out of sequence"]
    assert [(g.after_counter, g.missing_samples) for g in batch.gaps] == [(14, 2)]


def test_a_jump_with_nothing_after_it_is_taken_once_it_waited_long_enough() -> None:
    builder = _builder(check_continuity=True)
    builder.add(_reading(1), 0.0)
    builder.add(_reading(40), 0.01)
    assert builder.take(0.02).counter.tolist() == [1]  # held: no next frame yet
    assert builder.take(1.0).counter.tolist() == [40]  # waited: a gap after all


@pytest.mark.parametrize(("step", "bounds_s", "expected"), [
    # bounds of 419.6-501 samples: 411 (1 wrap) and 667 (2) both near: uncertain
    (155, (3.364, 4.002), (1, 2)),
    # bounds of 184-226 samples: 9 is 20x off, 265 (1 wrap) is near: that one
    (9, (1.479, 1.80), (1, 1)),
])
def test_timing_that_contradicts_the_counter_never_makes_a_wrong_count_certain(
        step: int, bounds_s: tuple[float, float], expected: tuple[int, int]) -> None:
    """Bounds of the elapsed time that hold no wrap count (seen on a host at load 20:
    bytes delivered late) leave the neighbouring wrap counts as the gap's range."""
    tracker = CounterTracker(256, 125.0)
    tracker.update(0, 0.0)
    _, gap = tracker.update(step, 10.0, elapsed_s=sum(bounds_s) / 2.0,
                            elapsed_range_s=bounds_s)
    assert gap is not None
    low, high = expected
    assert (gap.missing_low, gap.missing_high) == (step + low * 256 - 1, step + high * 256 - 1)
    assert gap.missing_low <= gap.missing_samples <= gap.missing_high


def test_a_polled_counter_late_by_its_poll_is_not_a_wrap() -> None:
    """A 16-bit counter whose timing says 0.2-0.6 s for one step: the step, certain."""
    tracker = CounterTracker(65536, 25.0)
    tracker.update(10, 0.0)
    _, gap = tracker.update(11, 0.4, elapsed_range_s=(0.2, 0.6))
    assert gap is None
