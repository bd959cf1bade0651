"""The STIM300 codec against its data sheet (TS1524 rev. 31) and a real unit's datagram.

The bytes here are built from the document's layout (Table 5-20 order, Table 5-22 dummy
bytes, 7.5.2.2 scale factors and counter), never with the station's encoder; the tables
are typed here from the document, not imported from the codec.
"""

from __future__ import annotations

import os
import time
import tty
from pathlib import Path

import pytest

from devices.codecs.crc import crc32_mpeg2
from devices.codecs.stim300 import Stim300Codec
from devices.errors import CodecError, DeviceConfigurationError
from devices.gaps import CounterTracker, counter_samples
from devices.sim.stim300_unit import SimulatedStim300, sheet_crc
from devices.stream import StreamRateSource
from devices.transports.serial import SerialTransport
from devices.urls import open_device
from station.cli import main as station_main
from tests.devices.helpers import collect, gap_truths, replay_batches

CAPTURES = Path(__file__).resolve().parents[2].parent / "shared" / "real-captures" / "stim300"
REAL = CAPTURES / "stim300_geirhovland_0xAF_reconstructed.bin"

#: Table 5-21 (0xAF: Table 5-20) -> (Table 5-12 bytes, Table 5-22 dummy bytes).
DOCUMENT = {0x90: (18, 2), 0x91: (28, 0), 0x92: (28, 0), 0x93: (38, 2), 0x94: (25, 3),
            0xA5: (42, 2), 0xA6: (42, 2), 0xA7: (59, 1), 0xF0: (22, 2), 0xF1: (32, 0),
            0xF2: (32, 0), 0xF3: (42, 2), 0xF4: (29, 3), 0xF5: (46, 2), 0xF6: (46, 2),
            0xF7: (63, 1), 0xAF: (63, 1)}


def datagram_0x94(counter: int, rate_words: tuple[int, int, int] = (16384, -8192, 1),
                  crlf: bool = False) -> bytes:
    """A rate + temperature datagram laid out by hand from Table 5-20 (ID, 3 x int24
    rates, status, 3 x int16 temperatures, status, counter, latency) with Table 5-22's
    3 dummy bytes in the CRC."""
    body = bytes([0x94])
    for w in rate_words:
        body += w.to_bytes(3, "big", signed=True)
    body += b"\x00" + (25 * 256).to_bytes(2, "big") * 3 + b"\x00"
    body += bytes([counter]) + (500).to_bytes(2, "big")
    assert len(body) == 25 - 4
    wire = body + crc32_mpeg2(body + b"\x00" * 3).to_bytes(4, "big")
    return wire + b"\r\n" if crlf else wire


def test_real_0xaf_datagram_decodes_to_the_publishers_values() -> None:
    """geirhovland/stim300 README: a real unit at rest, full datagram 0xAF, CR/LF
    terminated (geirhovland_README_excerpt.txt holds the printed values)."""
    if not REAL.exists():
        pytest.skip(f"the real STIM300 capture is not here ({REAL})")
    wire = REAL.read_bytes()
    assert len(wire) == 63 + 2 and wire[-2:] == b"\r\n"  # Table 5-12: 63 bytes + CR LF
    assert crc32_mpeg2(wire[:59] + b"\x00") == 3326689990  # Table 5-22: 1 dummy byte
    assert sheet_crc(wire[:59] + b"\x00") == 3326689990  # the simulator's own CRC
    codec = Stim300Codec(0xAF, crlf=True, rate_hz=125)
    result = codec.decode(wire)
    assert (result.crc_failures, result.discarded_bytes, result.rest) == (0, 0, b"")
    (frame,) = result.frames
    reading = codec.to_reading(frame)
    assert reading.rate_deg_s == (0.017822265625, -0.0806884765625, 0.05242919921875)
    assert (frame.counter, frame.latency_us) == (225, 506)
    assert frame.aux is not None and frame.aux.to_bytes(3, "big") == bytes([255, 239, 2])
    clusters = codec.clusters(frame)
    assert clusters.accel_g == (-0.011890411376953125, -0.016986846923828125,
                                1.0138282775878906)
    assert clusters.incl_g == pytest.approx(
        (-0.007907867431640625, -0.01989459991455078, 0.999640703201294), rel=1e-15)
    assert clusters.gyro_temperature_c == (35.625, 35.75, 35.625)
    assert clusters.accel_temperature_c == (35.09765625, 35.0390625, 35.109375)
    assert clusters.incl_temperature_c == (35.58203125, 35.7109375, 35.58203125)
    assert reading.status == 0 and reading.device_status == 0
    assert codec.encode(frame) == wire


@pytest.mark.parametrize("ident", sorted(DOCUMENT))
def test_lengths_and_crc_dummy_bytes_are_the_documents(ident: int) -> None:
    length, dummy = DOCUMENT[ident]
    assert Stim300Codec(ident).frame_length == length
    assert Stim300Codec(ident, crlf=True).frame_length == length + 2
    assert (-(length - 4)) % 4 == dummy


def test_scale_factors_of_section_7_5_2_2() -> None:
    """5 g variant 2**-20 g; incremental angle 2**-21 deg per sample; incremental
    velocity 2**-22 m/s per sample at 10 g; integrated outputs refused by name."""
    g0 = 9.80665
    body = (bytes([0x91]) + (2**21).to_bytes(3, "big", signed=True) + bytes(6) + b"\x00"
            + (2**20).to_bytes(3, "big", signed=True) + bytes(6) + b"\x00"
            + bytes([16]) + bytes(2))
    wire = body + crc32_mpeg2(body).to_bytes(4, "big")  # Table 5-22: no dummy byte
    five_g = Stim300Codec(0x91, accel_range_g=5, rate_hz=125)
    reading = five_g.to_reading(five_g.decode(wire).frames[0])
    assert reading.accel_m_s2 == pytest.approx((g0, 0.0, 0.0), rel=1e-15)
    assert reading.rate_deg_s == (128.0, 0.0, 0.0)  # 2**21 / 2**14 deg/s
    incremental = Stim300Codec(0x91, rate_hz=125, gyro_output="incremental",
                               accel_output="incremental")
    reading = incremental.to_reading(incremental.decode(wire).frames[0])
    assert reading.rate_deg_s == (125.0, 0.0, 0.0)  # 1 deg per sample at 125 Hz
    assert reading.accel_m_s2 == pytest.approx((0.25 * 125, 0.0, 0.0))  # 2**20 / 2**22 m/s
    for key in ("gyro_output", "accel_output"):
        with pytest.raises(CodecError, match="integrated"):
            Stim300Codec(0x91, rate_hz=125, **{key: "integrated"})


def test_status_bytes_of_table_5_23() -> None:
    """Start-up (bit 6) in the gyro status byte: status non-zero, the byte kept."""
    body = bytearray(datagram_0x94(0)[:-4])
    body[10] = 0x40
    wire = bytes(body) + crc32_mpeg2(bytes(body) + b"\x00" * 3).to_bytes(4, "big")
    codec = Stim300Codec(0x94, rate_hz=125)
    reading = codec.to_reading(codec.decode(wire).frames[0])
    assert reading.status != 0 and reading.device_status == 0x40


class _Pty:
    def __init__(self) -> None:
        self.master, self.slave = os.openpty()
        tty.setraw(self.master)
        tty.setraw(self.slave)
        self.port = os.ttyname(self.slave)

    def close(self) -> None:
        for fd in (self.master, self.slave):
            os.close(fd)


def _record(wire: bytes, codec: Stim300Codec, expected: int) -> tuple[int, int, list[str]]:
    """(samples, declared missing, event kinds) a stream adapter records of ``wire``."""
    pty = _Pty()
    source = StreamRateSource(SerialTransport(pty.port), codec, model="STIM300",
                              serial_number="T", sample_rate_hz=125.0)
    source.open()
    try:
        os.write(pty.master, wire)
        samples, missing, kinds = 0, 0, []
        deadline = time.monotonic() + 5.0
        while samples < expected and time.monotonic() < deadline:
            batch = source.read(0.05)
            samples += len(batch)
            missing += sum(g.missing_samples for g in batch.gaps)
            kinds += [e.kind for e in batch.events]
        return samples, missing, kinds
    finally:
        source.close()
        pty.close()


@pytest.mark.parametrize("crlf", [False, True])
def test_a_125_hz_stream_built_from_the_data_sheet_loses_nothing(crlf: bool) -> None:
    """2 s at 125 Hz: the counter advances by 16 (2000 / 125) a datagram and wraps every
    16 datagrams. Every datagram recorded with 0 missing (it used to declare 15 missing
    after each); with 3 datagrams cut out, exactly 3 missing; CR LF is no resync."""
    counters = [(16 * i + 7) % 256 for i in range(250)]
    wire = [datagram_0x94(c, crlf=crlf) for c in counters]
    codec = Stim300Codec(0x94, rate_hz=125, crlf=crlf)
    samples, missing, kinds = _record(b"".join(wire), codec, 250)
    assert (samples, missing) == (250, 0)
    assert "resync" not in kinds and "crc_error" not in kinds
    cut = [w for i, w in enumerate(wire) if i not in (40, 131, 132)]
    samples, missing, kinds = _record(b"".join(cut), codec, 247)
    assert (samples, missing) == (247, 3)


def test_the_simulated_unit_steps_its_counter_by_2000_over_rate() -> None:
    unit = SimulatedStim300(0x94, 125.0)
    assert [unit.counter(i) for i in (0, 1, 2, 15, 16)] == [0, 16, 32, 240, 0]
    assert SimulatedStim300(0x94, 2000.0).counter(257) == 1
    with open_device("sim+serial://STIM300?protocol=stim300&rate=125&seed=2") as dev:
        assert dev.source.describe().counter_modulus == 16  # samples per 0.128 s wrap
        dev.source.open()
        got, gaps = 0, []
        deadline = time.monotonic() + 20.0  # (a loaded host starts it late)
        while got < 60 and time.monotonic() < deadline:
            batch = dev.source.read(0.05)
            got += len(batch)
            gaps += list(batch.gaps)
        lost = len(dev.simulator.core.ledger.lost_indices.copy())
    assert got >= 60 and sum(g.missing_samples for g in gaps) == lost


@pytest.mark.parametrize(("url", "says"), [
    ("sim+serial://STIM300?protocol=stim300&rate=200", "125, 250, 500, 1000, 2000"),
    ("sim+serial://STIM300?protocol=stim300&rate=500&datagram=0x95", "0x95"),
    ("sim+serial://STIM300?protocol=stim300&rate=500&accel_range=20", "5, 10, 30 or 80"),
    ("sim+serial://STIM300?protocol=stim300&rate=500&termination=cr", "none or crlf"),
    ("serial:///dev/null?protocol=stim300&datagram=0xA7&baud=374400&rate=1000",
     "Table 5-12"),
])
def test_what_the_unit_cannot_send_is_refused_in_one_line(url: str, says: str) -> None:
    with pytest.raises(DeviceConfigurationError, match=says.replace(".", r"\.")) as err:
        open_device(url)
    assert "\n" not in str(err.value)


def test_the_cli_refuses_a_rate_the_unit_does_not_offer(tmp_path: Path, capsys) -> None:
    url = "sim+serial://STIM300?protocol=stim300&rate=200"
    code = station_main(["record", "--unit", url, "--duration", "1s", "--out", str(tmp_path)])
    err = capsys.readouterr().err.strip()
    # the record command's refusal: a heading, then one line per unit it refused
    assert code == 2 and "Traceback" not in err
    (line,) = [x for x in err.splitlines() if "unit1" in x]
    assert "Table 5-11" in line


def test_outages_of_a_data_sheet_unit_are_intervals_that_hold() -> None:
    """A simulated STIM300 at 500 Hz (a counter wrap every 0.128 s, 64 datagrams) cut off
    for 2 s at a time: only time counts the wraps, and each gap's interval holds the
    samples really lost (found from the simulated signal, not from the counter)."""
    url = ("sim+serial://STIM300?protocol=stim300&rate=500&warp=5&history=100000&seed=3"
           "&disconnect_every_s=1.0&disconnect_for_s=2")
    with open_device(url) as dev:
        dev.source.open()
        got = collect(dev.source, 1500, deadline_s=30)
        truths = gap_truths(got, dev.simulator.core, dev.source.describe().counter_modulus)
    outages = [t for t in truths if t.lost > 500]
    assert outages and all(t.held for t in truths)
    assert {t.declared.method for t in outages if t.declared} == {"counter+elapsed"}


def test_a_counter_that_steps_by_16_is_counted_in_samples() -> None:
    """CounterTracker with the STIM300's counter at 125 Hz: modulus 256 counted at 2000 Hz
    is 16 samples a wrap; one datagram lost is 1 missing (not 31); 2 s of silence (250
    samples, 15.6 wraps) is counted from the time, and its interval holds the truth."""
    tracker = CounterTracker(256, 125.0, counter_step=16)
    assert tracker.modulus == 16
    assert tracker.update(7, 0.0) == (0, None)
    assert tracker.update(23, 0.008) == (1, None)
    counter, gap = tracker.update(55, 0.024)  # 39 was lost
    assert counter == 3 and gap is not None
    assert (gap.missing_samples, gap.low, gap.high) == (1, 1, 1)
    sent = 3 + 251  # 250 lost, then this one
    counter, gap = tracker.update((7 + 16 * sent) % 256, 2.032, elapsed_s=2.008,
                                  elapsed_range_s=(1.95, 2.14))
    assert gap is not None and gap.method == "counter+elapsed"
    # 190 ms of uncertainty, more than a wrap (128 ms): two wrap counts fit
    assert gap.low <= 250 <= gap.high and gap.high - gap.low == 16
    assert counter_samples(7, 30, 256, 16) == 1  # a step off the grid: the nearest sample


def test_a_unit_borrowing_the_layout_counts_datagrams_at_any_rate() -> None:
    """``counter=datagram``: a unit of another model sending STIM300 datagrams (or a
    simulated one, where it is set for it) counts its datagrams, at a rate no STIM300
    offers; a STIM300 at an offered rate counts samples, 64 a wrap at 500 Hz."""
    url = "serial:///dev/does-not-exist?protocol=stim300&counter=datagram&rate=100"
    with open_device(url) as dev:
        assert dev.source.describe().counter_modulus == 256
    with open_device("sim+serial://VG951?protocol=stim300&rate=10&seed=1") as dev:
        assert dev.source.describe().counter_modulus == 256
    with open_device("serial:///dev/does-not-exist?protocol=stim300&rate=500") as dev:
        assert dev.source.describe().counter_modulus == 64


def datagram_0x93(counter: int, gyro_status: int = 0, *, gyro_words: tuple[int, int, int]
                  = (-760, 1400, -1411), accel_words: tuple[int, int, int]
                  = (700, -7960, 261100)) -> bytes:
    """A rate + acceleration + inclination datagram laid out by hand from Table 5-20 (ID,
    3 x int24 rates, status, 3 x int24 accelerations, status, 3 x int24 inclinations,
    status, counter, latency), Table 5-22's 2 dummy bytes in the CRC, CR LF ended."""
    body = bytes([0x93])
    for words, status in ((gyro_words, gyro_status), (accel_words, 0),
                          ((-1000, 2000, 1 << 22), 0)):
        body += b"".join(w.to_bytes(3, "big", signed=True) for w in words) + bytes([status])
    body += bytes([counter]) + (506).to_bytes(2, "big")
    assert len(body) == 38 - 4
    return body + crc32_mpeg2(body + b"\x00" * 2).to_bytes(4, "big") + b"\r\n"


def test_a_2000_hz_0x93_dump_with_start_up_datagrams_replays_with_no_gap(
        tmp_path: Path) -> None:
    """What a 30 g unit at 2000 samples/s sends from power-on (a rocket's STIM300 dump
    has this shape): 0x93 datagrams with CR LF, the counter stepping by 1 (7.5.2.2.18: it
    counts the 2000 Hz samples) through two wraps, the first ones flagged start-up
    (Table 5-23: 0xFF, bit 6 Start-Up, rates at a rail) and the file cut inside its last
    datagram. Every whole datagram is a sample, none missing; the start-up ones are not
    valid, the rest are; 2^18 LSB/g (Equation 3, 30 g) reads 1 g."""
    wire = b"".join(datagram_0x93((1 + i) % 256, 0xFF if i < 3 else 0,
                                  gyro_words=(0x780000, 0x780000, -0x780000) if i < 3
                                  else (-760, 1400, -1411))
                    for i in range(600))
    dump = tmp_path / "stim.bin"
    dump.write_bytes(wire + datagram_0x93(89)[:28])
    batches, _ = replay_batches(f"replay://{dump}?protocol=stim300&datagram=0x93&"
                                f"termination=crlf&accel_range=30&rate=2000")
    status = [s for b in batches for s in b.status.tolist()]
    assert len(status) == 600
    assert sum(g.missing_samples for b in batches for g in b.gaps) == 0
    assert [s != 0 for s in status[:4]] == [True, True, True, False]
    assert not any(status[3:])
    accel = [a for b in batches if len(b) and b.accel_m_s2 is not None
             for a in b.accel_m_s2.tolist()]
    assert accel[-1][2] / 9.80665 == pytest.approx(261100 / 2**18)
    rate = [r for b in batches for r in b.rate_deg_s.tolist()]
    assert rate[-1] == pytest.approx([-760 / 2**14, 1400 / 2**14, -1411 / 2**14])
