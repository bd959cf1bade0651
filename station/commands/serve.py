"""``station serve``: the line's web page, read-only, over the results database and the run
files being recorded (docs/web.md).

Pages: the line overview (per model and lot: units graded, yield with its interval, grade
counts, the last graded units; filters by date range, model, lot, station, operator), a
figure's page (capability with intervals, individuals chart with the run rules, histogram
against the limits, trend over lots), a unit's page (its spec sheet, its gradings), the
runs in progress under ``--runs`` (as ``station watch`` reads them, refreshed in place).
Every page's data is JSON under ``/api/...`` with the keys of ``--json``; ``?units=rad``
switches the unit family as ``--output-units`` does.

It binds 127.0.0.1 unless ``--host`` says otherwise; on any other address it asks for an
access token (``--token-file``: a file holding it), given as ``Authorization: Bearer
TOKEN`` or ``?token=TOKEN``, and warns. Nothing it serves writes.
"""

from __future__ import annotations

import argparse
import errno
import ipaddress
import socket
import sys
from pathlib import Path

from station.commands import COMMAND_HELP
from station.commands.arguments import add_database_argument, print_warnings
from station.errors import UsageError

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8050
#: The fewest characters an access token may have.
MIN_TOKEN_CHARS = 16


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``serve`` sub-command."""
    p = sub.add_parser("serve", help=COMMAND_HELP["serve"], description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    add_database_argument(p)
    p.add_argument("--runs", type=Path, nargs="+", default=[], metavar="DIR",
                   help="folders of run files (.h5) being recorded, shown live")
    p.add_argument("--host", default=DEFAULT_HOST,
                   help=f"address to listen on (default {DEFAULT_HOST}: this machine only; "
                   "any other needs --token-file)")
    p.add_argument("--port", type=int, default=DEFAULT_PORT,
                   help=f"TCP port (default {DEFAULT_PORT})")
    p.add_argument("--token-file", type=Path, default=None, metavar="F",
                   help="file holding the access token every request must carry (required "
                   "with a --host other than a loopback address)")
    p.set_defaults(handler=run)


def is_loopback(host: str) -> bool:
    """Whether ``host`` is this machine only (``localhost``, ``127.x``, ``::1``)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def read_token(path: Path) -> str:
    """The access token in ``path`` (surrounding white space dropped).

    Raises
    ------
    UsageError
        The file cannot be read, or holds fewer than :data:`MIN_TOKEN_CHARS` characters.
    """
    try:
        token = path.read_text(encoding="utf-8").strip()
    except OSError as exc:
        raise UsageError(f"--token-file {path}: {exc.strerror or exc}") from exc
    if len(token) < MIN_TOKEN_CHARS or any(c.isspace() for c in token):
        raise UsageError(f"--token-file {path}: give a token of at least {MIN_TOKEN_CHARS} "
                         "characters without spaces (python -c 'import secrets; "
                         "print(secrets.token_urlsafe(32))')")
    return token


def run(args: argparse.Namespace) -> int:
    """Check the options, then serve until Ctrl-C."""
    import uvicorn

    from station.web import ServeConfig, create_app

    if not 0 < args.port < 65536:
        raise UsageError(f"--port {args.port}: give a port from 1 to 65535")
    for folder in args.runs:
        if not folder.is_dir():
            raise UsageError(f"--runs {folder}: no such folder")
    token = read_token(args.token_file) if args.token_file is not None else None
    if not is_loopback(args.host):
        if token is None:
            raise UsageError(f"--host {args.host} opens the page to the network: give "
                             "--token-file F (a file holding the access token)")
        print_warnings("serve", (f"listening on {args.host}, reachable from the network: "
                                 "every request needs the access token; put it behind the "
                                 "line's HTTPS reverse proxy (docs/web.md)",))
    listening = listen(args.host, args.port)
    app = create_app(ServeConfig(args.db, tuple(args.runs), token))
    print(f"station serve: http://{args.host}:{args.port}/ (Ctrl-C stops)", file=sys.stderr,
          flush=True)
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning"))
    server.run(sockets=[listening])
    return 0


def listen(host: str, port: int) -> socket.socket:
    """A TCP socket bound to ``host``:``port``, for the server to accept on.

    Raises
    ------
    UsageError
        The address is in use (another server on the port), cannot be had (a port below
        1024 without the right, an address not of this machine), or the host is unknown.
    """
    try:
        family, kind, proto, _, address = socket.getaddrinfo(
            host, port, type=socket.SOCK_STREAM)[0]
    except OSError as exc:
        raise UsageError(f"--host {host}: {exc.strerror or exc}") from exc
    sock = socket.socket(family, kind, proto)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind(address)
    except OSError as exc:
        sock.close()
        if exc.errno == errno.EADDRINUSE:
            raise UsageError(f"--port {port}: {host}:{port} is in use (another server): "
                             "give another --port") from exc
        raise UsageError(f"cannot listen on {host}:{port}: {exc.strerror or exc}") from exc
    return sock
