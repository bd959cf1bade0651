"""AUTOSAR E2E Profile 1 on raw CAN: the standard's reference frames accepted and produced,
its alive counter 0..14 (15 fails the check, 14 -> 0 is no gap), and the simulated node's
frames checked against the CRC computed from the standard's definition
(:mod:`tests.devices.e2e_reference`), not against the codec.

Reference frames: ``../shared/real-captures/can-e2e/profile1-vectors.txt`` (zariiii9003/
autosar-e2e ``test/test_p01.py``, DATAID_BOTH) and, for the other DataID modes, the same
test file's ``e2e_p01_protect`` and ``e2e_p01_check`` results (DataID 0x123, 8 bytes).
"""

from __future__ import annotations

import time
import uuid
from pathlib import Path

import numpy as np
import pytest

from devices.can_raw import CanRateSource
from devices.codecs.can_frame import PER_AXIS_LAYOUT, CanFrameLayout, CanFrameValues, CanSignal
from devices.errors import CrcError
from devices.sim.can_device import CanBroadcastDevice
from devices.sim.e2e_p01_protect import Profile1Protector, crc_calculate_crc8
from devices.sim.params import parse_sim_params, sim_core
from devices.transports.can import CanTransport
from tests.devices.e2e_reference import p01_reference_crc
from tests.devices.helpers import collect

VECTORS = (Path(__file__).resolve().parents[3] / "shared" / "real-captures" / "can-e2e"
           / "profile1-vectors.txt")


def vector_layout(mode: str = "both") -> CanFrameLayout:
    """The vectors' configuration: DataID 0x123, CRC in byte 0, the alive counter in the low
    nibble of byte 1, 8 bytes; bytes 2-7 one (zero) signal."""
    return CanFrameLayout(axes=(CanSignal(0x123, 2, 4),), crc_byte=0, counter_byte=1,
                          counter_bits=4, data_id=0x123, data_id_mode=mode)  # type: ignore[arg-type]


def zero_frame(counter: int) -> CanFrameValues:
    return CanFrameValues(0x123, counter, (("axis0", 0),))


@pytest.mark.skipif(not VECTORS.is_file(), reason=f"{VECTORS} is not beside this checkout")
def test_the_reference_frames_are_accepted_and_produced() -> None:
    rows = [line.split() for line in VECTORS.read_text().splitlines()
            if line.strip() and not line.startswith("#")]
    assert len(rows) >= 2
    layout = vector_layout()
    assert layout.is_e2e_p01
    for counter, hex_frame in rows:
        frame = bytes.fromhex(hex_frame)
        assert layout.decode(0x123, frame) == zero_frame(int(counter))  # accepted
        assert layout.encode(zero_frame(int(counter))) == frame  # produced
        # and the CRC from the definition agrees: DataID low, high, then bytes 1..7
        assert frame[0] == p01_reference_crc(bytes((0x23, 0x01)) + frame[1:])


@pytest.mark.parametrize(("mode", "frames"), [
    ("both", ("cc00000000000000", "9101000000000000")),
    ("low", ("ce00000000000000", "9301000000000000")),
    ("alt", ("ce00000000000000", "0201000000000000")),
    ("nibble", ("2a10000000000000", "7711000000000000")),
])
def test_every_data_id_mode_as_autosar_e2e_computes_it(mode: str, frames: tuple[str, str]
                                                       ) -> None:
    """Counter 0 and 1 of each mode, as autosar-e2e's e2e_p01_protect writes them (the
    nibble mode sends the DataID's high-byte nibble, 1, in byte 1's high nibble)."""
    layout = vector_layout(mode)
    for counter, hex_frame in enumerate(frames):
        assert layout.encode(zero_frame(counter)).hex() == hex_frame
        assert layout.decode(0x123, bytes.fromhex(hex_frame)).counter == counter


@pytest.mark.parametrize(("mode", "frames"), [
    ("both", ("cc00000000000000", "9101000000000000")),
    ("low", ("ce00000000000000", "9301000000000000")),
    ("alt", ("ce00000000000000", "0201000000000000")),
    ("nibble", ("2a10000000000000", "7711000000000000")),
])
def test_the_simulated_nodes_protection_writes_autosar_e2es_frames(
        mode: str, frames: tuple[str, str]) -> None:
    """The simulated node's E2E_P01Protect (not the codec) on the same frames: sample 15
    and 16 carry counters 0 and 1 (the counter wraps at 15)."""
    protector = Profile1Protector(0x123, mode, crc_byte=0, counter_byte=1, counter_shift=0)
    for index, hex_frame in zip((15, 16), frames, strict=True):
        data = bytearray(8)
        protector.protect(data, index, counter=-1)  # (its own counter: the index mod 15)
        assert data.hex() == hex_frame


@pytest.mark.parametrize(("mode", "frame"), [
    ("both", "cc10000000000000"), ("low", "9311000000000000"),
    ("alt", "ce10000000000000"), ("nibble", "7721000000000000")])
def test_frames_autosar_e2e_rejects_fail_the_check(mode: str, frame: str) -> None:
    with pytest.raises(CrcError):
        vector_layout(mode).decode(0x123, bytes.fromhex(frame))


def test_alive_counter_15_fails_the_check() -> None:
    """15 is no value of Profile 1's counter: a frame carrying it fails the check even
    with a CRC that matches (e2e_p01_check: "counter must be in 0-14")."""
    frame = bytearray(8)
    frame[1] = 0x0F
    frame[0] = p01_reference_crc(bytes((0x23, 0x01)) + bytes(frame[1:]))
    with pytest.raises(CrcError, match="counter 15"):
        vector_layout().decode(0x123, bytes(frame))
    with pytest.raises(ValueError):
        vector_layout().encode(zero_frame(15))


def test_the_standards_chained_crc_is_init_0_without_final_xor() -> None:
    """AUTOSAR's Crc_CalculateCRC8 chained as E2E_P01Protect does it (the simulated node's
    way) equals the register started at 0 without a final XOR (the codec's and the test's)."""
    rng = np.random.default_rng(7)
    for _ in range(200):
        message = rng.integers(0, 256, int(rng.integers(1, 12))).astype(np.uint8).tobytes()
        chained = 0xFF
        for byte in message:  # one call per byte, each from the previous result
            chained = crc_calculate_crc8(bytes((byte,)), chained)
        assert chained ^ 0xFF == p01_reference_crc(message)
    # a start value of 0x00 puts 0xFF in the register, as a first call does: CRC-8/SAE-J1850
    assert crc_calculate_crc8(b"123456789", 0x00) == 0x4B  # (its check value)


def test_the_simulated_node_sends_profile1_frames() -> None:
    """Frames of the simulated per-axis node, read off the python-can virtual bus: every
    frame's counter is 0..14 and steps by one per sample (14 -> 0), its CRC is the one the
    standard's definition gives over DataID 0x0181 (low byte first) and bytes 0-6."""
    channel = f"p01-{uuid.uuid4().hex[:12]}"
    listener = CanTransport("virtual", channel)
    listener.open()
    core, _ = sim_core(parse_sim_params("STIM300", {"rate": "500", "warp": "5", "seed": "3"}),
                       3)
    node = CanBroadcastDevice(CanTransport("virtual", channel, preserve_timestamps=True),
                              PER_AXIS_LAYOUT, core, stamped=True).start()
    frames: list[tuple[int, bytes]] = []
    try:
        deadline = time.monotonic() + 10.0
        while len(frames) < 3 * 40 and time.monotonic() < deadline:
            msg = listener.recv(0.1)
            if msg is not None:
                frames.append((msg.arbitration_id, bytes(msg.data)))
    finally:
        node.stop()
        listener.close()
    assert len(frames) >= 3 * 40
    for aid in (0x181, 0x182, 0x183):
        data = [d for a, d in frames if a == aid]
        counters = [d[6] & 0x0F for d in data]
        assert max(counters) == 14 and all(d[6] >> 4 == 0 for d in data)
        # (no fault injected: a loaded host may still starve the node, which loses samples)
        steps = np.diff(counters) % 15
        assert (steps >= 1).all() and np.mean(steps == 1) > 0.9, counters
        for d in data:
            assert d[7] == p01_reference_crc(bytes((0x81, 0x01)) + d[:7])


def test_the_counter_wrap_14_to_0_is_no_gap() -> None:
    """45 samples (three wraps of 0..14) built from the standard, read by the adapter: 45
    samples, consecutive counters, no gap. (A wrap taken at 16 would count one lost sample
    at every 14 -> 0.)"""
    layout, rate_hz, channel = PER_AXIS_LAYOUT, 500.0, f"wrap-{uuid.uuid4().hex[:12]}"
    node = CanTransport("virtual", channel, preserve_timestamps=True)
    source = CanRateSource(CanTransport("virtual", channel), layout, model="test",
                           serial_number="T-1", sample_rate_hz=rate_hz, silence_timeout_s=10.0)
    source.open()
    node.open()
    t0 = time.time() - 1.0
    try:
        for index in range(45):
            for axis, aid in enumerate((0x181, 0x182, 0x183)):
                data = bytearray((1000 * index + axis).to_bytes(4, "little", signed=True)
                                 + bytes(4))
                data[6] = index % 15
                data[7] = p01_reference_crc(bytes((0x81, 0x01)) + bytes(data[:7]))
                node.send(aid, bytes(data), t0 + index / rate_hz)
        got = collect(source, 45)
    finally:
        node.close()
        source.close()
    assert got.gaps == [] and got.crc_errors == 0
    np.testing.assert_array_equal(np.diff(got.counter), 1)
    np.testing.assert_allclose(got.rate[:, 0], 1e-3 * np.arange(45), atol=1e-9)
