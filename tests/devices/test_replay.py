"""Capture and replay: recorded exchanges fed back to the real adapters.

Hand-written Xbus scripts check the ``expected_protocol`` behaviour (setup commands and
acknowledgements matched exactly, a wrong write or an unused step fails). Captures of
simulated STIM300 (pty) and raw-CAN (python-can virtual bus) sessions, each with a
disconnect longer than a counter period, replay to the same samples, counters and gaps
as the live session: the replay clock gives the adapters the recorded silences, so
even the wraps hidden in the outage are counted the same.
"""

from __future__ import annotations

import json
import time
import uuid
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from devices.can_raw import CanRateSource
from devices.capture import step_to_json
from devices.codecs.base import Reading
from devices.codecs.can_frame import SHARED_LAYOUT
from devices.codecs.stim300 import Stim300Codec
from devices.codecs.xbus import MID_GOTO_CONFIG, MID_GOTO_MEASUREMENT, XbusCodec, XbusMessage
from devices.errors import DeviceDisconnectedError, DeviceError
from devices.protocols import RateSource
from devices.replay import (
    CaptureFormatError,
    EndOfReplayError,
    Lost,
    Read,
    RecordingByteTransport,
    RecordingCanTransport,
    Recv,
    ReplayByteTransport,
    ReplayCanTransport,
    ReplayMismatchError,
    Send,
    UnusedExchangesError,
    Write,
    expected_exchanges,
    load_capture,
    recording_transport,
    replay_transport,
)
from devices.sim.can_device import CanBroadcastDevice
from devices.sim.params import parse_sim_params, sim_core
from devices.sim.serial_device import PtySerialDevice
from devices.stream import StreamRateSource
from devices.transports.can import CanTransport
from devices.transports.modbus import ModbusTransport
from devices.transports.serial import SerialTransport
from tests.devices.helpers import Collected

XBUS = XbusCodec()
GOTO_CONFIG = XBUS.encode(XbusMessage(MID_GOTO_CONFIG, b""))
GOTO_MEASUREMENT = XBUS.encode(XbusMessage(MID_GOTO_MEASUREMENT, b""))


def _ack(mid: int) -> bytes:
    return XBUS.encode(XbusMessage(mid + 1, b""))


def _mtdata2(counter: int, rate_deg_s: tuple[float, float, float]) -> bytes:
    reading = Reading(rate_deg_s, counter, 0, counter / 400.0, 25.0)
    return XBUS.encode(XBUS.from_reading(reading))


def _xbus_source(transport: ReplayByteTransport) -> StreamRateSource:
    return StreamRateSource(transport, XBUS, model="MTi", serial_number="T",
                            sample_rate_hz=400.0, clock=transport.clock, ack_timeout_s=0.5)


def test_xbus_setup_and_data_replay_exactly() -> None:
    """The adapter's setup writes are matched byte for byte (its single write of both
    commands against two write steps with the first acknowledgement between them), then
    the data frames decode to the scripted samples, across the 16-bit counter wrap."""
    # Xsens "MT Low Level Communication Protocol": GoToConfig FA FF 30 00 D1 and its
    # acknowledgement FA FF 31 00 D0 (checksum: BID..CS sums to 0 mod 256).
    assert GOTO_CONFIG == bytes.fromhex("faff3000d1")
    assert _ack(MID_GOTO_CONFIG) == bytes.fromhex("faff3100d0")
    rates = [(0.5, -1.25, 3.0), (0.75, -1.0, 2.5), (1.0, 0.0, -2.0)]
    script = [Write(GOTO_CONFIG), Read(_ack(MID_GOTO_CONFIG)), Write(GOTO_MEASUREMENT),
              Read(_ack(MID_GOTO_MEASUREMENT)),
              Read(_mtdata2(65534, rates[0]) + _mtdata2(65535, rates[1])[:7]),
              Read(_mtdata2(65535, rates[1])[7:] + _mtdata2(0, rates[2]))]
    with expected_exchanges(script) as transport:
        assert isinstance(transport, ReplayByteTransport)
        source = _xbus_source(transport)
        source.open()
        got = Collected([source.read(0.05), source.read(0.05)])
        source.close()
    np.testing.assert_array_equal(got.counter, [65534, 65535, 65536])
    np.testing.assert_allclose(got.rate, rates, rtol=1e-6)  # float32 rad/s on the wire
    np.testing.assert_allclose(got.column("device_time_s"), np.array([65534, 65535, 0]) / 400)
    assert got.gaps == [] and got.event_kinds() == ["connect"]


def test_a_wrong_write_fails_with_both_byte_strings() -> None:
    script = [Write(GOTO_MEASUREMENT), Read(_ack(MID_GOTO_MEASUREMENT))]
    with pytest.raises(ReplayMismatchError) as info, expected_exchanges(script) as transport:
        assert isinstance(transport, ReplayByteTransport)
        _xbus_source(transport).open()
    message = str(info.value)
    assert "step 0" in message
    assert GOTO_MEASUREMENT.hex(" ") in message and GOTO_CONFIG.hex(" ") in message
    assert isinstance(info.value, AssertionError) and isinstance(info.value, DeviceError)


def test_a_mismatch_caught_in_the_block_fails_at_exit() -> None:
    with pytest.raises(ReplayMismatchError, match="caught"), \
            expected_exchanges([Write(b"\x01\x02")]) as transport:
        assert isinstance(transport, ReplayByteTransport)
        transport.open()
        with pytest.raises(ReplayMismatchError, match="01 03"):
            transport.write(b"\x01\x03")


def test_an_unused_step_fails_at_exit() -> None:
    extra = _mtdata2(7, (0.0, 0.0, 1.0))
    script = [Write(GOTO_CONFIG + GOTO_MEASUREMENT), Read(_ack(MID_GOTO_CONFIG)
                                                          + _ack(MID_GOTO_MEASUREMENT)),
              Read(_mtdata2(6, (0.0, 0.0, 1.0))), Read(extra)]
    with pytest.raises(UnusedExchangesError) as info, expected_exchanges(script) as transport:
        assert isinstance(transport, ReplayByteTransport)
        source = _xbus_source(transport)
        source.open()
        assert len(source.read(0.01)) == 1
    assert info.value.unused == (3,)
    assert str(info.value).startswith("1 of 4 recorded exchanges never used")
    assert extra.hex(" ") in str(info.value)


def test_end_of_script_is_a_disconnect_at_once_and_reopen_fails_too() -> None:
    """Replaying to the end does not hang: read raises EndOfReplayError (a
    DeviceDisconnectedError), and so does every reopen the adapter then tries."""
    script = [Write(GOTO_CONFIG + GOTO_MEASUREMENT),
              Read(_ack(MID_GOTO_CONFIG) + _ack(MID_GOTO_MEASUREMENT)),
              Read(_mtdata2(1, (0.0, 0.0, 0.0)))]
    with expected_exchanges(script) as transport:
        assert isinstance(transport, ReplayByteTransport)
        source = _xbus_source(transport)
        source.open()
        assert len(source.read(0.05)) == 1
        started = time.monotonic()
        for _ in range(3):  # the read that finds the end, then reopens
            with pytest.raises(EndOfReplayError):
                source.read(0.05)
        assert time.monotonic() - started < 0.2
    assert issubclass(EndOfReplayError, DeviceDisconnectedError)


# -- capture then replay a simulated session --------------------------------------

SIM_QUERY = {"rate": "500", "seed": "4", "disconnect_every_s": "0.6", "disconnect_for_s": "0.7"}
LIVE_S = 1.75  # the link is down 0.6..1.3 s (sim time = wall time, warp 1): 350 samples


def _drain(source: RateSource, until: Callable[[], bool], pause_s: float) -> Collected:
    """Read until ``until()`` (live) or the end of a replay, through disconnects."""
    out = Collected()
    while not until():
        try:
            batch = source.read(0.05)
        except EndOfReplayError:
            break
        except DeviceDisconnectedError:
            out.disconnects += 1
            time.sleep(pause_s)
            continue
        if len(batch) or batch.events:
            out.batches.append(batch)
    return out


def _assert_same(live: Collected, replayed: Collected) -> None:
    assert len(live.counter) > 400 and live.disconnects >= 1
    np.testing.assert_array_equal(replayed.counter, live.counter)
    np.testing.assert_array_equal(replayed.rate, live.rate)
    gaps = [(g.after_counter, g.missing_samples, g.method) for g in live.gaps]
    assert [(g.after_counter, g.missing_samples, g.method) for g in replayed.gaps] == gaps
    # 350 samples lost: more than an 8-bit counter period, counted from the silence.
    assert "counter+elapsed" in {g.method for g in live.gaps}
    assert replayed.event_kinds() == live.event_kinds()
    assert replayed.disconnects == live.disconnects


def test_stim300_capture_replays_to_the_same_samples(tmp_path: Path) -> None:
    path = tmp_path / "stim300.jsonl"
    params = parse_sim_params("STIM300", SIM_QUERY)
    codec = Stim300Codec(0x94)
    core, clock = sim_core(params, codec.n_axes)
    device = PtySerialDevice(codec, core, header=b"\x94").start()

    def adapter(transport: RecordingByteTransport | ReplayByteTransport,
                clock: Callable[[], float]) -> StreamRateSource:
        return StreamRateSource(transport, codec, model="STIM300", serial_number="SIM-4",
                                sample_rate_hz=params.rate, clock=clock,
                                max_latency_s=device.max_latency_s)

    try:
        recorder = recording_transport(SerialTransport(device.port), path,
                                       settings={"protocol": "stim300"})
        assert isinstance(recorder, RecordingByteTransport)
        live = adapter(recorder, clock)
        live.open()
        got_live = _drain(live, lambda: clock() > LIVE_S, 0.01)
        # Each exchange is on disk as it happens, before the transport is closed.
        assert len(load_capture(path).steps) > 50
        live.close()
    finally:
        device.stop()

    capture = load_capture(path)
    assert capture.kind == "serial" and ("protocol", "stim300") in capture.settings
    assert ("port", device.port) in capture.settings
    started = time.monotonic()
    with expected_exchanges(capture) as transport:
        assert isinstance(transport, ReplayByteTransport)
        assert ("replay", str(path)) in transport.settings
        replayed = adapter(transport, transport.clock)
        got_replay = _drain(replayed, lambda: False, 0.0)
    assert time.monotonic() - started < LIVE_S  # faster than the session itself
    _assert_same(got_live, got_replay)


def test_can_capture_replays_to_the_same_samples(tmp_path: Path) -> None:
    path = tmp_path / "can.jsonl"
    params = parse_sim_params("STIM300", SIM_QUERY)
    core, clock = sim_core(params, len(SHARED_LAYOUT.axes))
    channel = f"replay-test-{uuid.uuid4().hex[:12]}"
    device = CanBroadcastDevice(CanTransport("virtual", channel, preserve_timestamps=True),
                                SHARED_LAYOUT, core).start()

    def adapter(transport: RecordingCanTransport | ReplayCanTransport,
                clock: Callable[[], float]) -> CanRateSource:
        return CanRateSource(transport, SHARED_LAYOUT, model="VG951",
                             serial_number="SIM-4", sample_rate_hz=params.rate, clock=clock)

    try:
        recorder = recording_transport(CanTransport("virtual", channel), path)
        assert isinstance(recorder, RecordingCanTransport) and recorder.channel == channel
        live = adapter(recorder, clock)
        live.open()
        got_live = _drain(live, lambda: clock() > LIVE_S, 0.0)
        live.close()
    finally:
        device.stop()

    transport = replay_transport(load_capture(path))
    assert isinstance(transport, ReplayCanTransport)
    replayed = adapter(transport, transport.clock)
    got_replay = _drain(replayed, lambda: False, 0.0)
    transport.check_used_up()
    _assert_same(got_live, got_replay)


def test_can_send_is_matched_and_frames_carry_their_recorded_stamps() -> None:
    script = [Send(0x600, b"\x2b\x00"), Recv(0x180, b"\x01\x02", t=0.25),
              Recv(0x180, b"\x03", t=0.5)]
    with expected_exchanges(script) as transport:
        assert isinstance(transport, ReplayCanTransport)
        transport.open()
        with pytest.raises(ReplayMismatchError, match="0x601"):
            transport.send(0x601, b"\x2b\x00")
        transport.failures.clear()
        assert transport.recv(0.1) is None  # waits for the host's command
        transport.send(0x600, b"\x2b\x00")
        assert transport.recv(0.1) is None  # due at 0.25 s on the replay clock
        first = transport.recv(0.2)
        assert first is not None and bytes(first.data) == b"\x01\x02"
        second = transport.recv(0.3)
        assert second is not None and second.timestamp - first.timestamp == pytest.approx(0.25)
        assert transport.clock() == 0.5


# -- capture files ----------------------------------------------------------------

HEADER = json.dumps({"capture": 1, "kind": "serial", "settings": {"port": "/dev/ttyUSB0"}})


@pytest.mark.parametrize(("lines", "line", "why"), [
    ([HEADER, '{"t": 0.1, "dir": "read", "hex": "94a1"}', '{"t": 0.2, "dir": "re'], 3,
     "not a JSON line"),
    ([HEADER, '{"t": 0.1, "dir": "read", "hex": "9x"}'], 2, "not hex"),
    ([HEADER, '{"t": 0.1, "dir": "recv", "id": 384, "hex": "00"}'], 2, "not a step of a serial"),
    ([HEADER, '{"t": "soon", "dir": "write", "hex": "00"}'], 2, "number of seconds"),
    (['{"t": 0.1, "dir": "read", "hex": "00"}'], 1, "capture header"),
    (['{"capture": 2, "kind": "serial"}'], 1, "version 2"),
])
def test_bad_capture_files_name_the_file_and_line(tmp_path: Path, lines: list[str],
                                                  line: int, why: str) -> None:
    path = tmp_path / "bad.jsonl"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(CaptureFormatError, match=why) as info:
        load_capture(path)
    assert str(info.value).startswith(f"{path}:{line}: ")
    assert isinstance(info.value, DeviceError) and isinstance(info.value, ValueError)


def test_a_capture_file_round_trips(tmp_path: Path) -> None:
    lines = ['{"t":0.0,"dir":"open"}',
             '{"t":0.002,"dir":"recv","id":384,"hex":"0a0b","ext":true}',
             '{"t":0.003,"dir":"send","id":1536,"hex":""}',
             '{"t":0.9,"dir":"lost","op":"recv","error":"bus off"}']
    path = tmp_path / "hand.jsonl"
    header = json.dumps({"capture": 1, "kind": "can", "settings": {"channel": "can0"}})
    path.write_text("\n".join([header, lines[0], "", *lines[1:]]) + "\n", encoding="utf-8")
    capture = load_capture(path)
    assert capture.kind == "can" and capture.settings == (("channel", "can0"),)
    assert capture.steps[1] == Recv(384, b"\x0a\x0b", 0.002, extended=True)
    assert capture.steps[3] == Lost("recv", "bus off", 0.9)
    assert [json.dumps(step_to_json(s), separators=(",", ":")) for s in capture.steps] == lines


def test_only_serial_and_raw_can_transports_are_recorded(tmp_path: Path) -> None:
    with pytest.raises(TypeError, match="not CANopen or Modbus"):
        recording_transport(ModbusTransport("tcp", "127.0.0.1"), tmp_path / "x.jsonl")
    assert not (tmp_path / "x.jsonl").exists()
