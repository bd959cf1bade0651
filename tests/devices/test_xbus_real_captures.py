"""The Xbus codec and adapter against what a real Xsens MTi-G-710 sent.

``../shared/real-captures/xsens-mtig710/{1,2}/output.bin`` are 100 MTData2 messages each
as the unit sent them (set 1 float32 with the StatusWord, set 2 FP12.20 with the
StatusByte; GNSS PVT data at 4 Hz in messages of their own), and ``output.golden`` their
publisher's decode (einride/xsens-go ``testdata/``): the decode is compared field by
field, and streaming the bytes through the adapter must give every sample, valid, with no
gap where the PacketCounter steps over a GNSS message.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from devices.codecs.xbus import (
    MID_GOTO_CONFIG,
    MID_GOTO_MEASUREMENT,
    XbusCodec,
    XbusMessage,
    parse_mtdata2,
)
from devices.errors import NoRateError
from devices.replay import Read, ReplayByteTransport, Write, expected_exchanges
from devices.stream import StreamRateSource
from tests.devices.helpers import Collected

CAPTURES = Path(__file__).resolve().parents[3] / "shared" / "real-captures" / "xsens-mtig710"
SETS = ("1", "2")
pytestmark = pytest.mark.skipif(not CAPTURES.is_dir(),
                                reason=f"the real MTi-G-710 captures are not at {CAPTURES}")
#: Acknowledgements of GoToConfig / GoToMeasurement from the document (MID + 1, no data):
#: FA FF 31 00 D0 and FA FF 11 00 F0.
ACKS = (bytes.fromhex("faff3100d0"), bytes.fromhex("faff1100f0"))


def golden_blocks(path: Path) -> list[dict[str, list[str]]]:
    """The publisher's decode: one ``{item name: its value lines}`` per message."""
    blocks: list[dict[str, list[str]]] = []
    current: dict[str, list[str]] = {}
    name = ""
    for line in path.read_text().splitlines() + [""]:
        if not line.strip():
            if current:
                blocks.append(current)
            current = {}
        elif line.startswith(" "):
            current[name].append(line.strip())
        else:
            name = line.rstrip(":")
            current[name] = []
    return blocks


def _xyz(lines: list[str]) -> tuple[float, ...]:
    return tuple(float(v.split(":", 1)[1]) for v in lines)


def _item(block: dict[str, list[str]], prefix: str) -> list[str] | None:
    found = [v for k, v in block.items() if k.split("(")[0] == prefix]
    return found[0] if found else None


def _capture(which: str) -> bytes:
    return (CAPTURES / which / "output.bin").read_bytes()


@pytest.mark.parametrize("which", SETS)
def test_every_message_decodes_as_its_publisher_decoded_it(which: str) -> None:
    codec = XbusCodec(accel=True)
    result = codec.decode(_capture(which))
    golden = golden_blocks(CAPTURES / which / "output.golden")
    assert (len(result.frames), result.crc_failures, result.discarded_bytes, result.rest) == \
        (100, 0, 0, b"")
    assert len(golden) == 100
    n_samples = 0
    for message, block in zip(result.frames, golden, strict=True):
        counter = int(block["PacketCounter"][0])
        reading = codec.to_reading(message)
        rates = _item(block, "RateOfTurn")
        if rates is None:  # a GNSS PVT message: no sample, but a counted message
            assert "GNSSPVTData" in block
            assert reading is None and codec.rateless_counter(message) == counter
            continue
        n_samples += 1
        assert reading is not None and codec.rateless_counter(message) is None
        assert reading.counter == counter
        assert reading.device_time_s == pytest.approx(int(block["SampleTimeFine"][0]) / 1e4,
                                                      abs=1e-9)
        # rad/s exactly as the publisher read them (deg/s here)
        assert tuple(math.radians(r) for r in reading.rate_deg_s) == \
            pytest.approx(_xyz(rates), rel=1e-14, abs=1e-300)
        accel = _item(block, "Acceleration")
        assert accel is not None and reading.accel_m_s2 == _xyz(accel)  # m/s^2, exact
        word = block.get("StatusWord", block.get("StatusByte"))
        assert word is not None and reading.device_status == int(word[0], 2)
        assert reading.status == 0  # a healthy unit: self-test passed, no clipping
    assert n_samples == 96


@pytest.mark.parametrize("which", SETS)
def test_the_capture_precision_is_the_one_each_set_was_configured_for(which: str) -> None:
    """Set 1 float32 (0x8020, StatusWord 0xE020), set 2 FP12.20 (0x8021, StatusByte
    0xE010): the low bits of the identifiers, as outputconfig.golden lists them."""
    (first, *_), expected = XbusCodec().decode(_capture(which)).frames, {
        "1": {0x8020, 0x4020, 0xE020}, "2": {0x8021, 0x4021, 0xE010}}[which]
    assert expected <= set(parse_mtdata2(first.data))


def _stream(data: bytes, chunks: int = 10) -> Collected:
    """``data`` streamed through the adapter after the greeting, in ``chunks`` reads."""
    codec = XbusCodec(accel=True)
    size = math.ceil(len(data) / chunks)
    script = [Write(codec.encode(XbusMessage(MID_GOTO_CONFIG, b""))), Read(ACKS[0]),
              Write(codec.encode(XbusMessage(MID_GOTO_MEASUREMENT, b""))), Read(ACKS[1])]
    script += [Read(data[i:i + size]) for i in range(0, len(data), size)]
    with expected_exchanges(script) as transport:
        assert isinstance(transport, ReplayByteTransport)
        source = StreamRateSource(transport, codec, model="MTi-G-710", serial_number="real",
                                  sample_rate_hz=100.0, clock=transport.clock,
                                  ack_timeout_s=0.5)
        source.open()
        got = Collected([source.read(0.05) for _ in range(len(script) - 4)])
        source.close()
    return got


@pytest.mark.parametrize("which", SETS)
def test_streaming_the_capture_gives_every_sample_valid_and_no_gap(which: str) -> None:
    """96 samples (4 of the 100 messages are GNSS PVT data), counters one apart, no gap,
    no resynchronization, every status 0: the PacketCounter steps over a GNSS message are
    no lost sample."""
    got = _stream(_capture(which))
    assert len(got.counter) == 96
    np.testing.assert_array_equal(np.diff(got.counter), 1)
    assert got.gaps == [] and got.event_kinds() == ["connect"]
    assert not np.any(np.concatenate([b.status for b in got.batches]))


def test_a_sample_lost_beside_the_gnss_messages_still_shows() -> None:
    """Cut the IMU message just after the first GNSS message out of set 1: one gap of one
    sample, where the counter steps by 2 over the GNSS message and by 2 over the cut."""
    codec = XbusCodec()
    frames = codec.decode(_capture("1")).frames
    first_gnss = next(i for i, f in enumerate(frames) if codec.rateless_counter(f) is not None)
    kept = frames[:first_gnss + 1] + frames[first_gnss + 2:]
    got = _stream(b"".join(codec.encode(f) for f in kept))
    assert len(got.counter) == 95
    (gap,) = got.gaps
    assert gap.missing_samples == 1 and gap.missing_low == gap.missing_high == 1


def test_a_stream_without_rate_of_turn_is_refused_naming_it() -> None:
    """Only the GNSS messages of set 1 (and of set 2, later counters): no sample can ever
    come; the adapter says which item it needs instead of timing out."""
    codec = XbusCodec()
    gnss = [f for which in SETS for f in codec.decode(_capture(which)).frames
            if codec.rateless_counter(f) is not None]
    data = b"".join(codec.encode(XbusMessage(f.mid, _with_counter(f.data, 100 + i)))
                    for i, f in enumerate(gnss * 3))
    with pytest.raises(NoRateError, match=r"carry no RateOfTurn \(0x8020\).*hr=1"):
        _stream(data, chunks=4)


def _with_counter(data: bytes, counter: int) -> bytes:
    """MTData2 data with its PacketCounter value replaced."""
    at = data.index(bytes.fromhex("102002")) + 3
    return data[:at] + counter.to_bytes(2, "big") + data[at + 2:]
