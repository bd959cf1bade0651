"""Raw byte dumps (what a unit sent, nothing else) replayed through ``replay://DUMP?protocol=P``:
every sample the encoder wrote comes back, on the device's own time where the protocol has
one and at the nominal rate otherwise, with no gap the device did not make; refusals are
one line; and the device's status word travels beside the one validity convention."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from devices.batching import BatchBuilder
from devices.codecs.base import Reading
from devices.dump_replay import ListeningCodec, dump_steps
from devices.errors import DeviceConfigurationError
from devices.gaps import CounterTracker
from devices.protocols import NO_DEVICE_STATUS, SampleBatch
from devices.serial_codecs import stream_codec
from devices.urls import open_device
from tests.devices.helpers import replay_batches

#: a rate each protocol's unit offers (a STIM300 sends at 125-2000 Hz in octaves)
RATE_HZ = {"stim300": 250.0, "kvh1750": 200.0, "xbus": 200.0}


def _dump(path: Path, protocol: str, counters: list[int], *, rate_hz: float | None = None,
          times_s: list[float] | None = None, garbage_at: int | None = None) -> list[Reading]:
    """Write what a unit of ``protocol`` sends for these counters (our encoder) to ``path``;
    returns the readings as the codec reads them back."""
    rate_hz = RATE_HZ[protocol] if rate_hz is None else rate_hz
    codec, _, _ = stream_codec(protocol, {}, rate_hz)
    out, back = b"", []
    for i, counter in enumerate(counters):
        t = (times_s[i] if times_s is not None else 100.0 + i / rate_hz)
        reading = Reading((0.01 * i, -0.02, 0.5), counter % codec.counter_modulus, 0,
                          t if codec.has_device_time else None,
                          25.0 if codec.has_temperature else None,
                          (0.1, -0.2, 9.8) if codec.n_accel_axes else None)
        frame = codec.from_reading(reading)
        if i == garbage_at:
            out += b"\x00\xff\x13"  # line noise between two frames
        out += codec.encode(frame)
        back.append(codec.to_reading(frame))
    path.write_bytes(out)
    return back


def _cat(batches: list[SampleBatch], name: str) -> np.ndarray:
    return np.concatenate([getattr(b, name) for b in batches if len(b)])


@pytest.mark.parametrize("protocol", ["stim300", "kvh1750", "xbus"])
def test_a_dump_replays_every_sample_with_no_gap(tmp_path: Path, protocol: str) -> None:
    counters = list(range(250, 250 + 600))  # across counter wraps of the 7- and 8-bit ones
    sent = _dump(tmp_path / "dump.bin", protocol, counters, garbage_at=300)
    rate = RATE_HZ[protocol]
    batches, source = replay_batches(f"replay://{tmp_path}/dump.bin?protocol={protocol}&rate={rate:g}")
    counter = _cat(batches, "counter")
    assert len(counter) == len(sent) == 600
    assert np.all(np.diff(counter) == 1)  # unwrapped, one step each: no gap
    assert not [g for b in batches for g in b.gaps]
    np.testing.assert_array_equal(_cat(batches, "rate_deg_s"),
                                  np.array([r.rate_deg_s for r in sent]))
    assert np.all(_cat(batches, "status") == 0)
    # the line noise is skipped and counted, nothing else
    skipped = sum(e.count for b in batches for e in b.events if e.kind == "resync")
    assert skipped == 3
    # the unit's clock: 600 samples span 599 periods, whatever the wall took
    times = _cat(batches, "receive_time_s")
    assert times[-1] - times[0] == pytest.approx(599 / rate, abs=1e-6)
    described = dict(source.describe().settings)
    assert described["time"] == ("device time" if protocol == "xbus"
                                 else "counter at the nominal rate")


def test_the_device_time_shows_an_outage_and_sets_the_rate(tmp_path: Path) -> None:
    """An Xbus dump with 300 samples missing (its counter and SampleTimeFine jump): the
    replay counts exactly those, and without rate= takes 100 Hz from the time stamps."""
    counters = [*range(1000, 1200), *range(1500, 1700)]
    times = [c / 100.0 for c in counters]
    _dump(tmp_path / "mti.bin", "xbus", counters, times_s=times)
    batches, source = replay_batches(f"replay://{tmp_path}/mti.bin?protocol=xbus")
    assert source.describe().sample_rate_hz == 100.0
    gaps = [g for b in batches for g in b.gaps]
    assert [(g.missing_samples, g.low, g.high) for g in gaps] == [(300, 300, 300)]
    times_got = _cat(batches, "receive_time_s")
    assert times_got[200] - times_got[199] == pytest.approx(3.01, abs=1e-6)  # 301 periods


def test_dump_steps_time_the_cuts_by_counter_or_device_time() -> None:
    codec, _, _ = stream_codec("stim300", {}, 1000.0)
    # samples 0, 1, 2, 5 (the counter steps by 2000/1000 = 2 a sample: 0, 2, 4, 10): two
    # samples lost, 3 periods
    frames = [codec.encode(codec.from_reading(Reading((0.0, 0.0, 0.0), c, 0,
                                                      temperature_c=20.0)))
              for c in (0, 1, 2, 5)]
    timing = dump_steps(b"".join(frames), codec, 1000.0)
    assert timing.readings == 4 and timing.time_source == "counter at the nominal rate"
    assert [s.t for s in timing.steps] == pytest.approx([0.0, 0.001, 0.002, 0.005])
    assert b"".join(s.data for s in timing.steps) == b"".join(frames)


def test_the_adapter_only_listens_to_a_dump(tmp_path: Path) -> None:
    """A dump holds no answer to the Xbus greeting: nothing is written, nothing awaited."""
    codec, _, _ = stream_codec("xbus", {}, 100.0)
    assert codec.greeting()  # (the live adapter does send GoToConfig, GoToMeasurement)
    listening = ListeningCodec(codec)
    assert listening.greeting() == b"" and listening.n_axes == codec.n_axes
    _dump(tmp_path / "d.bin", "xbus", list(range(10)))
    opened = open_device(f"replay://{tmp_path}/d.bin?protocol=xbus&rate=100")
    opened.source.open()
    opened.source.transport.write(b"\xfa\xff\x30\x00\xd1")  # dropped, never matched
    assert len(opened.source.read(0.05)) >= 1


@pytest.mark.parametrize(("query", "says"), [
    ("protocol=xbus&rate=100", "cannot read the byte dump"),
    ("protocol=nmea&rate=100", "unknown serial protocol 'nmea'"),
    ("protocol=stim300", "carries no device time: give the unit's nominal output rate"),
    ("protocol=kvh1750", "carries no device time"),
    ("protocol=xbus&rate=0", "must be > 0 Hz"),
])
def test_refusals_are_one_line(tmp_path: Path, query: str, says: str) -> None:
    name = "absent.bin" if "cannot read" in says else "d.bin"
    _dump(tmp_path / "d.bin", "stim300" if "stim300" in query else "kvh1750"
          if "kvh" in query else "xbus", list(range(5)))
    with pytest.raises(DeviceConfigurationError) as info:
        open_device(f"replay://{tmp_path}/{name}?{query}")
    assert says in str(info.value) and "\n" not in str(info.value)


def test_a_dump_of_another_protocol_is_refused(tmp_path: Path) -> None:
    _dump(tmp_path / "d.bin", "xbus", list(range(20)))
    with pytest.raises(DeviceConfigurationError, match="no stim300 sample decodes"):
        open_device(f"replay://{tmp_path}/d.bin?protocol=stim300&rate=125")
    with pytest.raises(DeviceConfigurationError, match="takes the URL keys protocol="):
        open_device(f"replay://{tmp_path}/d.bin")  # not a capture: a dump needs protocol=


def test_the_device_status_word_travels_beside_validity() -> None:
    builder = BatchBuilder(3, CounterTracker(256, 100.0), has_device_time=False,
                           has_temperature=False)
    builder.add(Reading((0.0, 0.0, 0.0), 1, status=0, device_status=0x77), 0.01)
    builder.add(Reading((0.0, 0.0, 0.0), 2, status=7, device_status=0x70), 0.02)
    builder.add(Reading((0.0, 0.0, 0.0), 3, status=0), 0.03)  # a message without a word
    batch = builder.take()
    assert batch.status.tolist() == [0, 7, 0]
    assert batch.device_status is not None
    assert batch.device_status.tolist() == [0x77, 0x70, NO_DEVICE_STATUS]
    builder.add(Reading((0.0, 0.0, 0.0), 4), 0.04)
    assert builder.take().device_status is None  # no word in the batch at all
    assert math.isclose(batch.receive_time_s[-1], 0.03)
