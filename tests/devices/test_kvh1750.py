"""KVH DSP-1750 / 1775: real messages, the document's formats, status bits and TEMPUNITS.

Golden data: three format-A messages a real unit sent (``../shared/real-captures/kvh1750``,
from TRECVT/ros_kvh1750 ``test/utest.cpp``: "early", gyros still starting, status 0x70,
seq 31; "basic", status 0x77, seq 104; "bad_crc", seq 105, CRC damaged), checked against
what that driver's own test expects of them; and the sample message of the KVH ICD
56-0298 rev. B, section 5.2.1 (Table 5-10: delta radians, degC). Formats B and C, and
the status and temperature settings, come from a simulated unit whose messages are laid
out from the document's tables apart from the codec (:mod:`devices.sim.kvh_unit`).
"""

from __future__ import annotations

import json
import math
import struct
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from analysis.units.conversions import STANDARD_GRAVITY_M_S2 as G
from devices.codecs.base import Reading
from devices.codecs.crc import crc32_mpeg2
from devices.codecs.kvh1750 import HEADERS, Kvh1750Codec
from devices.errors import CodecError, DeviceConfigurationError, DeviceProtocolError
from devices.sim.kvh_unit import BENCH_MAGNETIC_FIELD_GAUSS, KvhMessageWriter
from devices.urls import open_device
from station.model.profiles import load_profile
from station.recording.recorder import Recorder, RunConfig
from station.storage.hdf5 import open_run_file, read_unit
from tests.devices.helpers import collect, device_index

CAPTURES = Path(__file__).resolve().parents[3] / "shared" / "real-captures" / "kvh1750"
needs_captures = pytest.mark.skipif(
    not (CAPTURES / "trecvt_utest_messages.hex").is_file(),
    reason="../shared/real-captures/kvh1750 (real KVH 1750 messages) is not beside the "
           "checkout")


def _real_messages() -> dict[str, bytes]:
    lines = (CAPTURES / "trecvt_utest_messages.hex").read_text().splitlines()
    return {name: bytes.fromhex(hex_) for name, hex_ in
            (line.split() for line in lines if line and not line.startswith("#"))}


#: ICD 56-0298 rev. B, section 5.2.1: "an example data output string of Format A".
ICD_SAMPLE = bytes.fromhex("FE81FF55 37A96A6E 38586C1F B75BF862 BF803E78 BB650D28 3B0A37AC"
                           " 77 3D 0028 4BFA34D8")


@needs_captures
def test_real_messages_give_two_samples_and_one_crc_failure() -> None:
    """The publisher's expectations (utest.cpp): early: gyros not valid, accelerometers
    valid, seq 31, 29 degC; basic: all valid, seq 104, 29 degC; bad_crc: refused."""
    messages = _real_messages()
    codec = Kvh1750Codec("rad", "delta", 1000.0)
    result = codec.decode(messages["early"] + messages["basic"] + messages["bad_crc"])
    assert (len(result.frames), result.crc_failures, result.rest) == (2, 1, b"")
    early, basic = (codec.to_reading(f) for f in result.frames)
    assert (early.counter, early.temperature_c, early.device_status) == (31, 29.0, 0x70)
    assert early.status == 0x07  # the three gyros' valid bits missing: not a good sample
    assert (basic.counter, basic.temperature_c, basic.status, basic.device_status) == (
        104, 29.0, 0, 0x77)
    # a unit at rest: 1 g on z (the driver scales by 9.80665 as here)
    assert basic.accel_m_s2 == pytest.approx((-0.0010946046 * G, 0.00064476696 * G,
                                              0.99529767 * G), rel=1e-7)
    assert early.accel_m_s2 is not None and early.accel_m_s2[2] == pytest.approx(
        0.99724549 * G, rel=1e-7)
    # delta angles of about 1e-7 rad per sample: the Earth's rate at 1 kHz, within noise
    assert max(abs(r) for r in basic.rate_deg_s) < 0.01


def test_icd_sample_message() -> None:
    codec = Kvh1750Codec("rad", "delta", 1000.0)
    (frame,) = codec.decode(ICD_SAMPLE).frames
    reading = codec.to_reading(frame)
    assert (reading.counter, reading.status, reading.temperature_c) == (61, 0, 40.0)
    assert reading.accel_m_s2 is not None
    assert reading.accel_m_s2[0] == pytest.approx(-1.0019064 * G, rel=1e-7)


@pytest.mark.parametrize(("status", "expected"), [
    (0x77, 0), (0x70, 0x07), (0x07, 0x70), (0x37, 0x40), (0x75, 0x02), (0xF7, 0x80)])
def test_every_valid_bit_counts(status: int, expected: int) -> None:
    """Table 5-8: a sample is good only with every present sensor's valid bit set; a set
    reserved bit (3, 7: always 0) is not a good sample either."""
    msg = KvhMessageWriter("A", "C", "deg", "rate", 100.0)(Reading((0.0,) * 3, 5))
    body = msg[:28] + bytes([status]) + msg[29:32]
    wire = body + crc32_mpeg2(body).to_bytes(4, "big")
    (frame,) = Kvh1750Codec().decode(wire).frames
    reading = Kvh1750Codec().to_reading(frame)
    assert (reading.status, reading.device_status) == (expected, status)
    # accelerometers left out of the recording: only the gyros' bits count
    gyro_only = Kvh1750Codec(accel=False).to_reading(frame).status
    assert gyro_only == expected & 0x8F


@pytest.mark.parametrize(("tempunits", "word", "celsius"), [
    ("C", 29, 29.0), ("0.01C", 2900, 29.0), ("F", 84, 28.888888888888889),
    ("0.01F", 8420, 29.0), ("0.01C", -1234, -12.34)])
def test_tempunits(tempunits: str, word: int, celsius: float) -> None:
    """Tables 5-2, 5-4: degC, 1/100 degC, degF or 1/100 degF: 2900 is 29 degC when the
    unit sends hundredths, never 2900 degC."""
    body = struct.pack(">4s6fBBh", HEADERS["A"], 0, 0, 0, 0, 0, 1, 0x77, 0, word)
    wire = body + crc32_mpeg2(body).to_bytes(4, "big")
    codec = Kvh1750Codec(tempunits=tempunits)  # type: ignore[arg-type]
    assert codec.to_reading(codec.decode(wire).frames[0]).temperature_c == pytest.approx(celsius)


def test_format_b_time_stamp_and_format_c_slots() -> None:
    """Format B: the UINT32 time stamp (us) is the device time (modulo 2^32 us; the gap
    accounting takes a step back as no device time); format C: the SPFP word
    is the temperature in messages whose sequence number is a multiple of 4, else the
    magnetic field, which gives no temperature."""
    b = KvhMessageWriter("B", "0.01C", "deg", "rate", 100.0)
    codec_b = Kvh1750Codec(message_format="B", tempunits="0.01C")
    wire = b(Reading((1.0, 2.0, 3.0), 7, 0, 4321.000123, 31.25))
    assert len(wire) == 40 and wire[:4] == bytes.fromhex("FE81FF56")
    reading = codec_b.to_reading(codec_b.decode(wire).frames[0])
    # the UINT32 of microseconds wraps every 2^32 us (4295 s)
    assert reading.device_time_s == pytest.approx(4321.000123 - 2**32 * 1e-6, abs=1e-7)
    assert (reading.temperature_c, reading.counter, reading.status) == (31.25, 7, 0)
    assert codec_b.has_device_time and not Kvh1750Codec().has_device_time
    c = KvhMessageWriter("C", "C", "deg", "rate", 100.0)
    codec_c = Kvh1750Codec(message_format="C")
    wires = b"".join(c(Reading((0.0,) * 3, n, 0, None, 30.5)) for n in range(8, 12))
    assert len(wires) == 4 * 38
    frames = codec_c.decode(wires).frames
    assert [codec_c.to_reading(f).temperature_c for f in frames] == [30.5, None, None, None]
    assert tuple(f.temperature for f in frames[1:]) == pytest.approx(BENCH_MAGNETIC_FIELD_GAUSS)


def test_the_format_comes_from_the_header_and_a_format_the_url_denies_is_refused() -> None:
    wire = KvhMessageWriter("B", "C", "deg", "rate", 100.0)(Reading((0.0,) * 3, 1, 0, 2.5))
    (frame,) = Kvh1750Codec().decode(wire).frames  # found, CRC checked
    # told no format: read by its header (the time stamp still there for the gap count)
    assert Kvh1750Codec().to_reading(frame).device_time_s == 2.5
    with pytest.raises(DeviceProtocolError, match="sends format B.*give format=B"):
        Kvh1750Codec(message_format="A").to_reading(frame)


@pytest.mark.parametrize(("query", "named"), [
    ("format=D", "format='D' must be A, B or C"),
    ("tempunits=K", "tempunits='K' must be C, F, 0.01C or 0.01F"),
    ("tempunit=C", "did you mean 'tempunits'"),
])
def test_a_setting_the_unit_cannot_have_is_refused_in_one_line(query: str, named: str) -> None:
    with pytest.raises(DeviceConfigurationError) as info:
        open_device(f"serial:///dev/ttyUSB0?protocol=kvh1750&{query}").close()
    assert named in str(info.value) and "\n" not in str(info.value)
    with pytest.raises(CodecError):
        Kvh1750Codec(message_format="a")  # type: ignore[arg-type]


@settings(max_examples=40, deadline=None)
@given(fmt=st.sampled_from("ABC"), tempunits=st.sampled_from(["C", "F", "0.01C", "0.01F"]),
       unit=st.sampled_from(["deg", "rad"]), output=st.sampled_from(["rate", "delta"]),
       counter=st.integers(0, 10**6), status=st.sampled_from([0, 0x01, 0x40, 0x77]),
       temperature=st.floats(-40.0, 85.0), time_s=st.floats(0.0, 4000.0))
def test_simulated_unit_and_codec_agree(fmt: str, tempunits: str, unit: str, output: str,
                                        counter: int, status: int, temperature: float,
                                        time_s: float) -> None:
    """The simulator's messages, laid out from the tables, decode to what it was given
    (to the wire's resolution); the codec's own encoder sends the same bytes where it
    has the same information (not the magnetic slots of format C)."""
    writer = KvhMessageWriter(fmt, tempunits, unit, output, 400.0)
    codec = Kvh1750Codec(unit, output, 400.0, message_format=fmt,  # type: ignore[arg-type]
                         tempunits=tempunits)  # type: ignore[arg-type]
    sent = Reading((0.5, -120.0, 3e-4), counter, status, time_s, temperature,
                   (0.1, -2.0, 9.81))
    wire = writer(sent)
    got = codec.to_reading(codec.decode(wire).frames[0])
    assert got.rate_deg_s == pytest.approx(sent.rate_deg_s, rel=1e-6)
    assert got.accel_m_s2 == pytest.approx(sent.accel_m_s2, rel=1e-6)
    assert (got.counter, got.status) == (counter % 128, status)
    resolution = 0.01 if tempunits.startswith("0.01") else 1.0
    if fmt == "C" and counter % 4:
        assert got.temperature_c is None
    else:
        assert got.temperature_c is not None
        per_word_c = resolution * (5 / 9 if tempunits.endswith("F") else 1.0)
        assert abs(got.temperature_c - temperature) <= per_word_c / 2 + 1e-5
    if fmt == "B":
        assert got.device_time_s == pytest.approx(time_s, abs=1e-6)
    if fmt != "C" or counter % 4 == 0:
        assert codec.encode(codec.from_reading(sent)) == wire


@pytest.mark.parametrize("query", ["format=B&tempunits=0.01F", "format=C&unit=rad&output=delta"])
def test_simulated_unit_over_a_pty(query: str) -> None:
    url = (f"sim+serial://DSP-1750?protocol=kvh1750&{query}&rate=200&warp=2&history=10000"
           "&seed=4")
    with open_device(url) as dev:
        dev.source.open()
        got = collect(dev.source, 300)
        core = dev.simulator.core
        offset = device_index(got, core, 128)
        idx = got.counter + offset
        np.testing.assert_allclose(got.rate, core.history(idx), rtol=1e-6, atol=1e-12)
        assert not got.column("status").any()
        temperature = got.column("temperature_c")
        if "format=B" in query:
            np.testing.assert_allclose(got.column("device_time_s"), idx / 200.0, atol=1e-6)
            assert np.all(np.abs(temperature - 25.0) <= 0.5)
        else:
            carries = idx % 4 == 0
            assert carries.any() and np.isnan(temperature[~carries]).all()
            assert np.all(np.abs(temperature[carries] - 25.0) <= 0.5)
            assert dev.source.describe().has_device_time is False


@needs_captures
def test_samples_a_unit_flags_invalid_reach_the_run_file_as_not_valid(tmp_path: Path) -> None:
    """Through the whole path: bytes -> adapter -> recorder -> run file. The real
    messages, then messages whose status flags the accelerometers (all, or z) invalid:
    the run file keeps them, with a non-zero status."""
    real = _real_messages()
    writer = KvhMessageWriter("A", "C", "rad", "delta", 100.0)
    made = [writer(Reading((0.0,) * 3, seq, status, None, 29.0))
            for seq, status in ((106, 0x70), (107, 0x40), (108, 0))]
    messages = [(31, real["early"]), (104, real["basic"]), (105, real["bad_crc"]),
                *zip((106, 107, 108), made, strict=True)]
    capture = tmp_path / "kvh.jsonl"
    header = {"capture": 1, "kind": "serial", "started_unix_s": 0.0, "settings": {
        "replay_url": "serial://?protocol=kvh1750&unit=rad&output=delta&rate=100&warp=1"}}
    steps = [{"t": 0.0, "dir": "open"}] + [
        {"t": (seq - 31) / 100.0, "dir": "read", "hex": msg.hex()} for seq, msg in messages]
    capture.write_text("\n".join(json.dumps(x) for x in [header, *steps]) + "\n")
    recorder = Recorder(RunConfig((f"replay://{capture}",), 3600.0, tmp_path / "run.h5",
                                  profile=load_profile("ADIS16405")))
    recorder.run()
    with open_run_file(recorder.path) as f:
        unit = read_unit(f, "unit1")
    assert unit.counter.tolist() == [31, 104, 106, 107, 108]
    good = unit.status == 0
    assert good.tolist() == [False, True, False, False, True]
    kinds = [e["kind"].decode() if isinstance(e["kind"], bytes) else e["kind"]
             for e in unit.events]
    assert "crc_error" in kinds
    assert unit.temperature_c is not None and np.all(unit.temperature_c == 29.0)
    assert math.isclose(float(unit.accel_m_s2[1, 2]), 0.99529767 * G, rel_tol=1e-7)
