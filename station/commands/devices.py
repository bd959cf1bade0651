"""``station devices``: the device protocols and transports the station supports, and
``station devices serve URL``: a simulated gyro another station records as hardware."""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import threading
from dataclasses import asdict
from types import FrameType
from typing import TYPE_CHECKING

from devices.url_text import is_simulated, url_keys, with_keys
from station.commands import COMMAND_HELP
from station.errors import UsageError

if TYPE_CHECKING:
    from devices.opened import OpenedDevice


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``devices`` sub-command (and its ``serve`` action)."""
    p = sub.add_parser("devices", help=COMMAND_HELP["devices"], description=__doc__)
    p.add_argument("--json", action="store_true",
                   help='print [{"protocol", "transport", "hardware_url", "sim_url"}, ...] as JSON')
    p.set_defaults(handler=run)
    actions = p.add_subparsers(dest="action", metavar="ACTION")
    serve = actions.add_parser(
        "serve", help="run a simulated gyro until stopped; print the URL to record it by",
        description="Run a simulated gyro (a sim+ URL at warp 1) over a transport other "
        "processes reach: a pty (serial, Modbus RTU), a TCP port on 127.0.0.1 (Modbus "
        "TCP) or python-can's udp_multicast bus (CAN and CANopen: add "
        "interface=udp_multicast). Prints the hardware URL another station opens it by, "
        "then runs until Ctrl-C, SIGTERM or --seconds; prints its ledger at the end.")
    serve.add_argument("url", help="simulated device URL, e.g. "
                       "'sim+can://VG951?interface=udp_multicast&rate=500'")
    serve.add_argument("--seconds", type=float, default=None,
                       help="stop after this many seconds (default: until stopped)")
    serve.add_argument("--json", action="store_true", dest="serve_json",
                       help='print {"url", "sim_url", "pid"} and at the end the ledger as JSON')
    serve.set_defaults(handler=run_serve)


def run(args: argparse.Namespace) -> int:
    """Print the supported protocols as a table or as JSON."""
    # here: the table of protocols imports every transport's library (python-can, pyserial,
    # pymodbus, canopen), which ``station devices --help`` does not need
    from devices.urls import SUPPORTED

    if args.json:
        print(json.dumps([{k: v for k, v in asdict(p).items() if k != "description"}
                          for p in SUPPORTED], indent=2))
        return 0
    width = max(len(p.protocol) for p in SUPPORTED)
    pad = " " * (width + 15)
    for p in SUPPORTED:
        print(f"{p.protocol:<{width}}  {p.transport:<11}  {p.description}")
        print(f"{pad}hardware:  {p.hardware_url}")
        print(f"{pad}simulated: {p.sim_url}")
        profile, url = ready_url(p.sim_url)
        print(f"{pad}record:    station record --check --profile {profile} --unit '{url}'")
    print("\nrecord: checks the simulated unit against a shipped profile whose rate it has "
          "(drop --check, add --duration, to record it).")
    print("Names in capitals (PROFILE.toml, FILE.eds) and the port or address are yours to fill "
          "in; docs/devices.md lists every key.")
    return 0


def ready_url(sim_url: str) -> tuple[str, str]:
    """A shipped profile and ``sim_url`` at the rate it expects (``station record --profile
    P --unit URL`` accepts the pair): the profile the URL's host names, else one whose rate
    the URL has, else the first shipped profile."""
    from devices.codecs.stim300_sheet import OFFERED_RATES_HZ
    from station.model.profiles import available_profiles, load_profile

    profiles = [load_profile(name) for name in available_profiles()]
    profiles = [p for p in profiles if p.sample_rate_hz is not None]
    host = sim_url.split("://", 1)[1].split("?", 1)[0].split("/", 1)[0]
    rate = url_keys(sim_url).get("rate")
    chosen = next((p for p in profiles if p.name == host), None) or next(
        (p for p in profiles if rate is not None and float(rate) == p.sample_rate_hz),
        profiles[0],
    )
    keys = {"rate": f"{chosen.sample_rate_hz:g}"}
    if (url_keys(sim_url).get("protocol") == "stim300" and host == "STIM300"
            and chosen.sample_rate_hz not in OFFERED_RATES_HZ):
        # no STIM300 sends at the profile's rate (TS1524 Table 5-11): the simulated unit
        # borrows the datagram layout with a counter of datagrams, as another model's would
        keys["counter"] = "datagram"
    return chosen.name, with_keys(sim_url, keys)


def _unreachable_reason(opened: OpenedDevice) -> str:
    if opened.time_warp != 1.0:
        return ("a served simulation runs in real time (the station that records it keeps "
                "wall time): remove warp= or set warp=1")
    return ("this simulation lives inside this process (python-can's virtual bus): add "
            "interface=udp_multicast to serve a CAN or CANopen gyro")


def run_serve(args: argparse.Namespace) -> int:
    """Serve the simulated device until stopped; returns 0 (2 for a URL that cannot be
    served)."""
    from devices.opened import SimulatedDevice
    from devices.urls import open_device

    if not is_simulated(args.url):
        raise UsageError(f"serve takes a simulated device URL (sim+...), not {args.url!r}")
    stop = threading.Event()

    def on_term(signum: int, frame: FrameType | None) -> None:
        stop.set()

    previous = signal.signal(signal.SIGTERM, on_term)
    opened = open_device(args.url)
    try:
        if not isinstance(opened, SimulatedDevice) or opened.hardware_url is None:
            raise UsageError(f"cannot serve {args.url!r}: {_unreachable_reason(opened)}")
        # the process that runs the simulated device: a child (CAN and CANopen on
        # udp_multicast) or this one
        pid = getattr(opened.simulator, "pid", None) or os.getpid()
        if args.serve_json:
            print(json.dumps({"url": opened.hardware_url, "sim_url": args.url, "pid": pid}),
                  flush=True)
        else:
            print(f"serving {args.url}\nrecord it by: {opened.hardware_url}\n"
                  "(Ctrl-C to stop)", flush=True)
        try:
            stop.wait(args.seconds)
        except KeyboardInterrupt:
            pass
        ledger = opened.ledger
        counts = {
            "generated": ledger.generated, "delivered": ledger.delivered,
            "dropped": ledger.dropped, "corrupted": ledger.corrupted,
            "lost_in_outage": ledger.lost_in_outage, "disconnects": ledger.disconnects}
        if args.serve_json:
            print(json.dumps({"ledger": counts}), flush=True)
        else:
            print(f"stopped: {counts['generated']} samples generated, "
                  f"{counts['lost_in_outage']} lost in outages; frames delivered "
                  f"{counts['delivered']}, dropped {counts['dropped']}, corrupted "
                  f"{counts['corrupted']}; {counts['disconnects']} disconnects",
                  file=sys.stderr)
    finally:
        opened.close()
        signal.signal(signal.SIGTERM, previous)
    return 0
