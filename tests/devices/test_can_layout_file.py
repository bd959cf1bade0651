"""A raw CAN layout a user writes down for their own unit: the shipped Bosch MM7.10 layout
file read against frames built by hand from the signal definitions of
bosch-engineering/off_highway_sensor_drivers ``off_highway_mm7p10`` (not from our
encoder), found by name, by path and from a profile's URL beside it; a layout without a
counter counting lost samples from the frames' time stamps alone."""

from __future__ import annotations

import re
import time
import tomllib
import uuid
from pathlib import Path

import numpy as np
import pytest

from devices.bus_layouts import can_layout
from devices.can_raw import CanRateSource
from devices.codecs.base import Reading
from devices.codecs.can_frame import CanFrameLayout
from devices.errors import DeviceConfigurationError
from devices.model_files import shipped_profiles_dir
from devices.protocols import ACCEL_AXIS_NAMES
from devices.transports.can import CanTransport
from devices.urls import open_device
from station.model.profiles import load_profile
from tests.devices.helpers import check_accounting, collect, device_index

G = 9.80665
ROOT = Path(__file__).resolve().parents[2]
MM7_FILE = shipped_profiles_dir() / "layouts" / "MM7.10.toml"


def mm7_frame(rate_raw: int, stat: int, accel_raw: int, counter: int, acc_stat: int,
              byte2_low: int = 0, temp_raw: int = 0) -> bytes:
    """One MM7.10 frame from the driver's bit definitions: rate bits 0-15, bits 16-19
    (HW_Index in 0x17C), rate status 20-23, TEMP_RATE_Z 24-31 (0x174), acceleration 32-47,
    MSG_CNT 48-51, acceleration status 52-55, CRC 56-63 (left 0: not checked)."""
    word = (rate_raw | byte2_low << 16 | stat << 20 | temp_raw << 24 | accel_raw << 32
            | counter << 48 | acc_stat << 52)
    return word.to_bytes(8, "little")


def test_the_shipped_mm7_layout_reads_the_units_frames() -> None:
    layout = can_layout("MM7.10")
    assert layout == can_layout(str(MM7_FILE))  # by name or by path
    assert layout.crc == "none" and layout.counter_modulus == 16
    assert layout.arbitration_ids == (0x174, 0x178, 0x17C)
    frames = {
        0x178: mm7_frame(0x8000 + 200, 0x0, 0x8000 + 800, 9, 0x2),  # roll +1 deg/s, AX +1 g
        0x17C: mm7_frame(0, 0x4, 0xFFFF, 9, 0x0, byte2_low=0xA),  # pitch bottom, AZ top
        0x174: mm7_frame(0xFFFF, 0x8, 0x8000, 9, 0x1, temp_raw=75),  # yaw top, 25 degC
    }
    decoded = {aid: layout.decode(aid, data) for aid, data in frames.items()}
    reading = layout.to_reading(decoded)
    assert reading.counter == 9
    np.testing.assert_allclose(reading.rate_deg_s, (1.0, -163.84, 163.835), atol=1e-9)
    # 0.000127465 g per LSB from -4.1768 g, in m/s^2: (800 x 0.000127465 - 4.1768 + 4.1768 ...)
    want_g = (800 * 0.000127465 + 0x8000 * 0.000127465 - 4.1768,
              0x8000 * 0.000127465 - 4.1768, 0xFFFF * 0.000127465 - 4.1768)
    np.testing.assert_allclose(np.asarray(reading.accel_m_s2) / G, want_g, atol=1e-9)
    assert reading.temperature_c == 25.0
    # status nibbles side by side: roll, pitch, yaw, AX, AY, AZ; bit 3 (yaw's 8) is no fault
    assert reading.device_status == 0x012840
    assert reading.status == 0x012040
    # a clean sample: status 0, and the encoder gives back the unit's bytes
    clean = Reading((0.0, 0.0, 0.0), 3, temperature_c=25.0, accel_m_s2=(0.0, 0.0, G))
    again = layout.to_reading({f.arbitration_id: layout.decode(f.arbitration_id,
                                                               layout.encode(f))
                               for f in layout.from_reading(clean)})
    assert again.status == 0 and again.device_status == 0
    assert layout.encode(layout.decode(0x178, frames[0x178])) == frames[0x178]


def test_the_drivers_extreme_values_round_trip() -> None:
    """The driver's own test values (test_imu_receiver.cpp, testImuAndInfoMin/Max): rates
    -163.84 and 163.83 deg/s, accelerations -4.1768 and 4.176618 g, back within 0.001."""
    layout = can_layout("MM7.10")
    for rate, accel_g in ((-163.84, -4.1768), (163.83, 4.176618)):
        reading = Reading((rate,) * 3, 0, temperature_c=0.0, accel_m_s2=(accel_g * G,) * 3)
        got = layout.to_reading({f.arbitration_id: layout.decode(f.arbitration_id,
                                                                 layout.encode(f))
                                 for f in layout.from_reading(reading)})
        np.testing.assert_allclose(got.rate_deg_s, (rate,) * 3, atol=1e-3)
        np.testing.assert_allclose(np.asarray(got.accel_m_s2) / G, (accel_g,) * 3, atol=1e-3)


def test_a_profile_names_a_layout_file_beside_it(tmp_path: Path) -> None:
    """A profile's URL names ``layouts/unit.toml`` relative to the profile's own folder;
    loaded from anywhere, the URL names the file by its absolute path, and opens."""
    (tmp_path / "layouts").mkdir()
    (tmp_path / "layouts" / "unit.toml").write_text(MM7_FILE.read_text())
    vg951 = (shipped_profiles_dir() / "VG951.toml").read_text()
    url = "sim+can://STIM300?layout=layouts/unit.toml&rate=100&warp=5&seed=2"
    profile_text = re.sub(r'(?m)^url = ".*"$', f'url = "{url}"', vg951)
    (tmp_path / "UNIT.toml").write_text(profile_text)
    anchored = load_profile(tmp_path / "UNIT.toml").transport["url"]
    assert f"layout={tmp_path / 'layouts' / 'unit.toml'}" in anchored
    with open_device(anchored) as dev:
        desc = dev.source.describe()
        assert desc.counter_modulus == 16 and desc.accel_axes == ACCEL_AXIS_NAMES
    with pytest.raises(DeviceConfigurationError):
        can_layout("no-such-layout")


def test_the_how_to_pages_layout_is_a_valid_layout() -> None:
    """The TOML of docs/how-to/write-a-can-layout.md parses into the layout it describes."""
    page = (ROOT / "docs" / "how-to" / "write-a-can-layout.md").read_text()
    blocks = re.findall(r"```toml\n(.*?)```", page, flags=re.S)
    layouts = [CanFrameLayout.from_table(tomllib.loads(b)["can"]) for b in blocks
               if "[can]" in b]
    assert layouts and layouts[0] == can_layout("MM7.10")


#: A unit with no counter and no CRC: one frame per axis, int16 at 0.01 deg/s.
NO_COUNTER = CanFrameLayout.from_table({
    "crc": "none", "counter_bits": 0,
    "axes": [{"arbitration_id": 0x280 + i, "start_byte": 0, "length": 2,
              "byte_order": "little", "scale": 0.01} for i in range(3)]})


def _send_indices(indices: list[int], rate_hz: float, jitter_s: float = 0.0) -> list:
    """Send the samples ``indices`` of the NO_COUNTER unit, stamped when each fell due
    (+ ``jitter_s`` on every second one); returns the collected batches."""
    channel = f"nocounter-{uuid.uuid4().hex[:12]}"
    node = CanTransport("virtual", channel, preserve_timestamps=True)
    source = CanRateSource(CanTransport("virtual", channel), NO_COUNTER, model="test",
                           serial_number="T-1", sample_rate_hz=rate_hz,
                           silence_timeout_s=100.0)
    source.open()
    node.open()
    t0 = time.time() - 5.0
    try:
        for k, index in enumerate(indices):
            stamp = t0 + index / rate_hz + (jitter_s if k % 2 else 0.0)
            for frame in NO_COUNTER.from_reading(Reading((index / 100, 0.0, -index / 100),
                                                         index)):
                node.send(frame.arbitration_id, NO_COUNTER.encode(frame), stamp)
        return collect(source, len(indices))
    finally:
        node.close()
        source.close()


def test_without_a_counter_the_time_stamps_count_the_lost_samples() -> None:
    """No counter: 3 samples lost, an outage of 200, one of 1000, counted from the frames'
    time stamps and the nominal rate (100 Hz): exactly where the stamps keep the schedule
    and the unit's rate tolerance (1000 ppm) cannot add a sample (under 250 samples);
    the longer one is a range around the true count."""
    kept = [i for i in range(1500) if not 10 <= i < 13 and not 100 <= i < 300
            and not 400 <= i < 1400]
    got = _send_indices(kept, 100.0)
    np.testing.assert_allclose(got.rate[:, 0], np.asarray(kept) / 100, atol=1e-9)
    short, middle, long = got.gaps
    assert (short.missing_samples, short.low, short.high) == (3, 3, 3)
    assert (middle.missing_samples, middle.low, middle.high) == (200, 200, 200)
    assert long.missing_samples == 1000 and 997 <= long.low < 1000 < long.high <= 1003
    assert {g.method for g in got.gaps} == {"counter+elapsed"}
    np.testing.assert_array_equal(got.counter - got.counter[0], np.asarray(kept) - kept[0])


def test_without_a_counter_late_frames_make_a_count_uncertain() -> None:
    """Every second frame 2 ms late at 100 Hz (within the quarter period the time stamps
    are trusted to): the one lost sample counted exactly. 3.3 ms late (beyond it): each
    late step's count is a range (0 or 1 lost) holding the true count, and no sample is
    made up of two."""
    kept = [i for i in range(60) if i != 30]
    got = _send_indices(kept, 100.0, jitter_s=0.002)
    assert [(g.missing_samples, g.low, g.high) for g in got.gaps] == [(1, 1, 1)]
    got = _send_indices(kept, 100.0, jitter_s=0.0033)
    assert len(got.counter) == len(kept)
    assert all(g.low <= (1 if g.after_counter + 1 == 30 else 0) <= g.high for g in got.gaps)
    assert sum(g.low < g.high for g in got.gaps) >= 25


def test_a_simulated_unit_without_crc_counts_its_losses() -> None:
    """The shipped MM7.10 layout simulated (no CRC: a corrupted frame never reaches the
    station, as the CAN controller's CRC-15 drops it): every lost sample declared."""
    url = ("sim+can://STIM300?layout=MM7.10&rate=500&warp=5&history=100000&seed=4"
           "&drop=0.02&corrupt=0.02")
    with open_device(url) as dev:
        dev.source.open()
        got = collect(dev.source, 1500)
        core = dev.simulator.core
        offset = device_index(got, core, 16, atol=0.005)
        declared, lost = check_accounting(got, core, offset)
        assert declared == lost and len(lost) > 20 and got.crc_errors == 0
        assert (got.column("status") == 0).all()
