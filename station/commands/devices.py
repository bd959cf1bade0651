"""``station devices``: the device protocols and transports the station supports."""

from __future__ import annotations

import argparse
import json
from dataclasses import asdict

from devices.urls import SUPPORTED


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``devices`` sub-command."""
    p = sub.add_parser("devices", help="list supported device protocols and their simulations",
                       description=__doc__)
    p.add_argument("--json", action="store_true",
                   help='print [{"protocol", "transport", "sim_url"}, ...] as JSON')
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Print the supported protocols as a table or as JSON."""
    if args.json:
        print(json.dumps([{k: v for k, v in asdict(p).items() if k != "description"}
                          for p in SUPPORTED], indent=2))
        return 0
    width = max(len(p.protocol) for p in SUPPORTED)
    for p in SUPPORTED:
        print(f"{p.protocol:<{width}}  {p.transport:<11}  {p.description}")
        print(f"{'':<{width}}  {'':<11}  {p.sim_url}")
    return 0
