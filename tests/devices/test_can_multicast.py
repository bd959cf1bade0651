"""CAN and CANopen gyros in a process of their own, on python-can's ``udp_multicast`` bus.

Proves that a simulated node run in a child Python process (``interface=udp_multicast``
in its ``sim+`` URL) reaches the adapter across the process boundary with exactly the
samples it generated, its injected faults declared as gaps, its power loss reported
from the bus, and that the child never outlives the process that started it. Then the
hardware path: ``station devices serve`` runs a simulated gyro in another process and
a plain ``can://GROUP?interface=udp_multicast`` URL, the one a bench would use for any
python-can interface, records it.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

from devices.errors import DeviceConfigurationError, DeviceDisconnectedError
from devices.protocols import Simulated
from devices.sim.process import SimulatorProcess
from devices.urls import open_device
from station.cli import main
from tests.devices.helpers import (
    check_accounting,
    check_books,
    check_lost_share,
    collect,
    device_index,
    multicast_unavailable,
    serve,
)

MULTICAST = "interface=udp_multicast"
# A host with no IPv4 multicast route cannot run these; every other host runs them all.
pytestmark = pytest.mark.skipif(bool(multicast_unavailable()), reason=multicast_unavailable())
HALF_LSB_SHARED = 2.0**-14  # the shared layout's LSB is 2^-13 deg/s


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # A zombie (exited, not yet reaped by its parent) is not running either.
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def _wait_gone(pid: int, timeout_s: float = 10.0) -> bool:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if not _alive(pid):
            return True
        time.sleep(0.05)
    return False


@pytest.mark.slow
def test_raw_can_round_trip_across_processes() -> None:
    url = f"sim+can://STIM300?{MULTICAST}&layout=shared&rate=200&warp=2&history=100000&seed=5"
    with open_device(url) as dev:
        sim = dev.simulator
        assert isinstance(sim, SimulatorProcess) and sim.pid not in (None, os.getpid())
        dev.source.open()
        got = collect(dev.source, 500)
        core = sim.core
        offset = device_index(got, core, 256, atol=2 * HALF_LSB_SHARED)
        # No fault is injected: a loaded host may still starve the node's process (it
        # loses what fell due meanwhile, in its ledger) or this one (the kernel drops
        # datagrams a full socket cannot take): every loss declared, none invented.
        declared, _ = check_accounting(got, core, offset)
        check_lost_share(got, declared)
        np.testing.assert_allclose(got.rate, core.history(got.counter + offset),
                                   atol=HALF_LSB_SHARED + 1e-12, rtol=0)
        assert core.sample_rate_hz == dev.source.describe().sample_rate_hz == 200.0
        assert core.ledger.generated >= len(got.counter)
        pid = sim.pid
    assert pid is not None and _wait_gone(pid)


@pytest.mark.slow
def test_raw_can_faults_across_processes_are_exact_gaps() -> None:
    url = (f"sim+can://STIM300?{MULTICAST}&layout=shared&rate=200&warp=4&history=100000"
           "&seed=6&drop=0.03&corrupt=0.02&disconnect_every_s=2&disconnect_for_s=3")
    with open_device(url) as dev:  # an outage of 3 s at warp 4: 0.75 s wall > 0.5 s
        dev.source.open()
        got = collect(dev.source, 900, deadline_s=40)
        core = dev.simulator.core
        offset = device_index(got, core, 256, atol=2 * HALF_LSB_SHARED)
        declared, lost = check_accounting(got, core, offset)
        assert declared == lost and len(lost) >= 500
        assert got.crc_errors > 0
        assert {"disconnect", "reconnect"} <= set(got.event_kinds())


@pytest.mark.slow
def test_canopen_sync_node_across_processes() -> None:
    """SDO set-up, NMT start and SYNC-paced TPDOs between two processes."""
    url = (f"sim+canopen://STIM300/6?{MULTICAST}&tpdo=sync&rate=50&warp=2&history=100000"
           "&seed=13")
    with open_device(url) as dev:
        dev.source.open()
        got = collect(dev.source, 150)
        core = dev.simulator.core
        offset = device_index(got, core, 65536, atol=1e-6)
        declared, lost = check_accounting(got, core, offset)
        assert declared == lost == set()
        np.testing.assert_allclose(got.rate, core.history(got.counter + offset),
                                   atol=0.5e-6 + 1e-12, rtol=0)
        assert dev.source.describe().serial_number == "13"  # read over SDO from 0x1018:4


@pytest.mark.slow
def test_canopen_node_power_loss_is_reported() -> None:
    """SIGKILL of the node's process: its heartbeat stops, the adapter says so."""
    url = f"sim+canopen://STIM300/7?{MULTICAST}&rate=50&warp=1&seed=3"
    with open_device(url) as dev:
        dev.source.open()
        collect(dev.source, 50)
        dev.simulator.kill()
        reported = ""
        end = time.monotonic() + 10
        while not reported and time.monotonic() < end:
            try:
                batch = dev.source.read(0.1)
            except DeviceDisconnectedError as exc:
                reported = str(exc)
            else:
                reported = ";".join(e.detail for e in batch.events if e.kind == "disconnect")
        assert "heartbeat" in reported
        assert not _alive(dev.simulator.pid)


def test_simulator_process_exits_with_its_parent() -> None:
    """A station killed mid-run leaves no simulated node behind on the bus."""
    script = textwrap.dedent(f"""
        import sys, time
        from devices.urls import open_device
        dev = open_device("sim+can://VG951?{MULTICAST}&rate=100")
        print(dev.simulator.pid, flush=True)
        time.sleep(60)
    """)
    parent = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        child_pid = int(parent.stdout.readline())
        assert _alive(child_pid)
        parent.send_signal(signal.SIGKILL)
        parent.wait(10)
        assert _wait_gone(child_pid), "the simulator process outlived its parent"
    finally:
        parent.kill()
        parent.communicate()


def test_a_node_that_cannot_start_is_a_clear_error() -> None:
    with pytest.raises(DeviceConfigurationError, match="NO-SUCH-MODEL"):
        open_device(f"sim+can://NO-SUCH-MODEL?{MULTICAST}")
    with pytest.raises(DeviceConfigurationError, match="udp_multicast"):
        open_device("sim+can://VG951?interface=socketcan")


@pytest.mark.slow
def test_served_gyro_is_recorded_by_a_hardware_url() -> None:
    """``station devices serve`` in one process, a hardware ``can://`` URL in this one."""
    proc, info = serve(f"sim+can://VG951?{MULTICAST}&layout=shared&rate=200&seed=4", 60)
    try:
        url = str(info["url"])
        assert info["pid"] not in (None, proc.pid, os.getpid())  # the node's own process
        assert url.startswith("can://239.255.") and "interface=udp_multicast" in url
        with open_device(url) as dev:
            assert not isinstance(dev, Simulated)  # a real-hardware URL: nothing simulated here
            dev.source.open()
            got = collect(dev.source, 200)  # 1 s at 200 Hz
            check_lost_share(got, check_books(got))  # (what a loaded host loses, declared)
            assert np.all(np.abs(got.rate) < 1.0)
            assert dev.source.describe().transport == "can"
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=20)
        assert proc.returncode == 0, err
        ledger = json.loads(out.strip().splitlines()[-1])["ledger"]
        assert ledger["generated"] >= len(got.counter) and ledger["dropped"] == 0
    finally:
        proc.kill()
        proc.communicate()


def test_serve_refuses_what_another_process_cannot_reach(
        capsys: pytest.CaptureFixture[str]) -> None:
    for url, why in (("sim+can://VG951?rate=100", "interface=udp_multicast"),
                     ("sim+can://VG951?rate=100&warp=1", "interface=udp_multicast"),
                     ("sim+serial://STIM300?warp=5", "real time"),
                     ("can://can0", "sim+")):
        assert main(["devices", "serve", url, "--seconds", "1"]) == 2
        assert why in capsys.readouterr().err


@pytest.mark.slow
def test_opt_in_hardware_check_passes_on_a_served_gyro() -> None:
    """The opt-in hardware test is live code: run it on a served CANopen gyro (for 1 s:
    its 200 samples at 200 Hz, the check's least, where a bench reads 5 s)."""
    proc, info = serve(f"sim+canopen://VG951/5?{MULTICAST}&rate=200&seed=9", 60)
    try:
        # One process, without the suite's addopts (two xdist workers) and the plugins
        # the check does not use (xdist, hypothesis, anyio: 4 s of a 6 s start).
        run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-o", "addopts=",
                              "-p", "no:xdist", "-p", "no:hypothesispytest", "-p", "no:anyio",
                              "-p", "no:cacheprovider", "tests/devices/test_hardware.py",
                              "--hardware-url", str(info["url"]), "--hardware-seconds", "1"],
                             capture_output=True, text=True, timeout=120,
                             cwd=os.path.dirname(os.path.dirname(os.path.dirname(__file__))))
        assert run.returncode == 0 and "1 passed" in run.stdout, run.stdout + run.stderr
    finally:
        proc.kill()
        proc.communicate()
