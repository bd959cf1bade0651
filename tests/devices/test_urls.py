"""Device URLs: every query key of the Interface section, real-hardware URLs built without
opening anything, layouts and register maps from a profile TOML, and clear errors."""

from __future__ import annotations

import math
import time
from pathlib import Path
from urllib.parse import parse_qsl, urlsplit

import numpy as np
import pytest

from devices.can_raw import CanRateSource
from devices.canopen_node import CanopenRateSource
from devices.codecs.can_frame import CanSignal
from devices.errors import DeviceConfigurationError, DeviceDisconnectedError
from devices.modbus import ModbusRateSource
from devices.protocols import Simulated
from devices.sim.faults import FaultConfig
from devices.stream import StreamRateSource
from devices.urls import SimParams, can_layout, open_device, parse_sim_params, register_map
from tests.devices.helpers import check_books, collect


def test_every_interface_query_key_is_parsed() -> None:
    query = {"model": "VG951", "rate": "250", "warp": "20", "drop": "0.1", "corrupt": "0.2",
             "garbage": "0.3", "disconnect_every_s": "60", "disconnect_for_s": "5", "seed": "7",
             "stall_every_s": "9", "stall_for_s": "1", "drift_ppm": "-50"}
    params = parse_sim_params("", query)
    assert params == SimParams("VG951", 250.0, 20.0, 7, 0, FaultConfig(
        drop=0.1, corrupt=0.2, garbage=0.3, disconnect_every_s=60.0, disconnect_for_s=5.0,
        stall_every_s=9.0, stall_for_s=1.0, drift_ppm=-50.0, seed=8))
    assert parse_sim_params("STIM300", {}).model == "STIM300"  # host part = model
    assert math.isinf(parse_sim_params("", {}).faults.disconnect_every_s)


@pytest.mark.parametrize("query", [{"rate": "fast"}, {"drop": "1.5"}, {"warp": "0"},
                                   {"seed": "1.5"}])
def test_bad_sim_values_are_refused(query: dict[str, str]) -> None:
    with pytest.raises(DeviceConfigurationError):
        parse_sim_params("", query)


@pytest.mark.parametrize("url", ["ftp://x", "sim+serial://STIM300?protocol=nmea",
                                 "can://can0?layout=/no/such.toml", "sim+serial://NOPE",
                                 "replay://no/such/capture.jsonl", "sim+replay://x",
                                 "sim+canopen://VG951/5?capture=x.jsonl",
                                 "modbus+tcp://127.0.0.1:502/1?capture=x.jsonl"])
def test_bad_urls_are_refused_with_a_message(url: str) -> None:
    with pytest.raises((DeviceConfigurationError, ValueError)) as info:
        open_device(url).close()
    assert str(info.value)


def test_real_hardware_urls_build_adapters_without_opening() -> None:
    cases = {
        "serial:///dev/ttyUSB7?protocol=kvh1750&baud=460800&rate=1000": StreamRateSource,
        "can://can3?interface=socketcan&layout=per_axis&rate=200": CanRateSource,
        "canopen://can0/12?rate=100": CanopenRateSource,
        "modbus+tcp://10.0.0.7:1502/3?map=float32&rate=10": ModbusRateSource,
        "modbus+rtu:///dev/ttyS4?unit=2&baud=38400": ModbusRateSource,
    }
    for url, kind in cases.items():
        dev = open_device(url)
        assert isinstance(dev.source, kind) and not isinstance(dev, Simulated)
        dev.close()  # never opened: nothing to release
    desc = open_device(next(iter(cases))).source.describe()
    assert dict(desc.settings) == {"port": "/dev/ttyUSB7", "baudrate": "460800"}
    assert (desc.protocol, desc.sample_rate_hz, desc.counter_modulus) == ("kvh1750", 1000.0, 128)
    modbus = open_device("modbus+tcp://10.0.0.7:1502/3?map=float32").source.describe()
    assert ("host", "10.0.0.7") in modbus.settings and ("device_id", "3") in modbus.settings


def test_missing_serial_port_is_a_disconnect_not_a_crash() -> None:
    with open_device("serial:///dev/does-not-exist?protocol=stim300") as dev:
        with pytest.raises(DeviceDisconnectedError):
            dev.source.open()


def test_layout_and_register_map_from_a_profile(tmp_path: Path) -> None:
    profile = tmp_path / "gyro.toml"
    profile.write_text(
        "[can]\ncounter_byte = 6\ncounter_bits = 4\ncrc_byte = 7\n"
        "[[can.axes]]\narbitration_id = 0x300\nstart_byte = 0\nlength = 4\n"
        "byte_order = \"little\"\nscale = 1e-5\n"
        "[modbus]\naxes = [{address = 20, kind = \"float32\", word_order = \"little\"}]\n"
        "counter = {address = 22, kind = \"uint16\"}\n")
    layout = can_layout(str(profile))
    assert layout.axes == (CanSignal(0x300, 0, 4, True, "little", 1e-5),)
    assert register_map(str(profile)).span == (20, 3)
    with pytest.raises(DeviceConfigurationError):
        register_map(str(tmp_path / "none.toml"))


def test_time_warp() -> None:
    """warp=10: 1000 samples at 500 Hz (2 simulated s) arrive in about 0.2 wall s, and
    the station clock the adapter stamps them with runs warped too. A loaded host that
    stalls the simulator does not slow its time: what falls due meanwhile is lost
    (declared), and the counter runs on at ten simulated seconds per wall second."""
    with open_device("sim+serial://STIM300?protocol=stim300&rate=500&warp=10&seed=3") as dev:
        dev.source.open()
        start = time.monotonic()
        got = collect(dev.source, 1000)
        wall_s = time.monotonic() - start
        check_books(got)
        device_s = (got.counter[-1] - got.counter[0]) / 500.0  # losses included
        assert device_s / wall_s > 5.0, (device_s, wall_s)  # (10, less the first read's wait)
        t = got.column("receive_time_s")
        assert t[-1] - t[0] >= 1.5  # simulated seconds


def test_clock_drift() -> None:
    """drift_ppm=100000: the device runs 10 % fast against the station clock, while its
    own time stamps stay exactly one nominal period apart."""
    url = "sim+serial://STIM300?protocol=xbus&rate=500&warp=2&seed=3&drift_ppm=100000"
    with open_device(url) as dev:
        dev.source.open()
        got = collect(dev.source, 1200)
        t, counter = got.column("receive_time_s"), got.counter
        late = t > t[0] + 0.3  # skip what the port buffered before it was opened
        slope = np.polyfit(t[late], counter[late], 1)[0]
        assert slope == pytest.approx(550.0, rel=0.02)
        np.testing.assert_allclose(np.diff(got.column("device_time_s")), 1 / 500, atol=1e-4)


def test_a_simulated_unit_describes_its_product_not_a_model_file() -> None:
    """The run file, the database and the report headers show the model a unit describes."""
    cases = {"sim+serial://ADIS16405?model=profiles/models/mems-typical.toml&protocol=stim300":
             "ADIS16405",
             "sim+can://?model=profiles/models/VG951.toml": "VG951"}
    for url, model in cases.items():
        with open_device(url) as dev:
            assert dev.source.describe().model == model


def test_a_served_simulations_hardware_url_keeps_protocol_keys_only(tmp_path) -> None:
    """The URL another station records by names the protocol, not this side's
    simulation or capture file (that station would write into it)."""
    url = (f"sim+serial://STIM300?protocol=stim300&datagram=0x94&rate=250&seed=3&drop=0.1"
           f"&capture={tmp_path / 'c.jsonl'}")
    with open_device(url) as dev:
        query = dict(parse_qsl(urlsplit(dev.hardware_url).query))
    assert query == {"protocol": "stim300", "datagram": "0x94", "rate": "250"}


def test_simulated_units_without_a_seed_each_have_their_own_serial() -> None:
    """A unit without ``seed=`` draws one, and reports it as its serial number: two such
    units of one bench never both report SIM-0 (the results database would take one for
    the other); a given seed is the serial, as before."""
    url = "sim+modbus+tcp://VG951?rate=20"
    serials = []
    for _ in range(2):
        with open_device(url) as dev:
            serials.append(dev.source.describe().serial_number)
    assert serials[0] != serials[1] and all(s.startswith("SIM-") for s in serials)
    drawn = {parse_sim_params("", {}).serial_number for _ in range(50)}
    assert len(drawn) == 50 and "SIM-0" not in drawn
    assert parse_sim_params("", {"seed": "7"}).serial_number == "SIM-7"
    with open_device(f"{url}&seed=7") as dev:
        assert dev.source.describe().serial_number == "SIM-7"
