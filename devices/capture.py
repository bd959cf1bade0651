"""Capture files: what a transport exchanged with a gyro, one JSON line per exchange.

A capture is recorded once on the bench (:class:`RecordingByteTransport`,
:class:`RecordingCanTransport` wrap the real transport) and replayed in CI by
:mod:`devices.replay`. The file is JSON Lines: a header, then one step per line::

    {"capture": 1, "kind": "serial", "settings": {"port": "/dev/ttyUSB0", ...}, "started_unix_s":
    ...}
    {"t": 0.0, "dir": "open"}
    {"t": 0.0123, "dir": "read", "hex": "94a1..."}         bytes the device sent (one read)
    {"t": 0.0125, "dir": "write", "hex": "faff3000d1"}     bytes the host sent
    {"t": 0.84, "dir": "lost", "op": "read", "error": "..."}   the transport raised
                                                           DeviceDisconnectedError
    {"t": 0.01, "dir": "recv", "id": 384, "hex": "..."}    CAN: a frame received
    {"t": 0.02, "dir": "send", "id": 1536, "hex": "..."}   CAN: a frame sent

``t`` is seconds since the capture started (wall time; a received CAN frame's ``t`` is
its bus time stamp). Optional CAN flags ``"ext"``, ``"rtr"``, ``"err"`` (true) mark
extended-ID, remote and error frames.
"""

from __future__ import annotations

import json
import math
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any, Literal

import can

from devices.errors import DeviceDisconnectedError, DeviceError
from devices.transports.can import CanLink
from devices.transports.serial import ByteTransport

#: Version of the capture file format written by this module.
CAPTURE_VERSION = 1

CaptureKind = Literal["serial", "can"]


class CaptureFormatError(DeviceError, ValueError):
    """A capture file that cannot be read; the message names the file and line."""


@dataclass(frozen=True)
class Read:
    """Serial: bytes the device sent, as one ``read()`` returned them (``t``: s since
    the capture started, None in a hand-written script: due at once)."""

    data: bytes
    t: float | None = None


@dataclass(frozen=True)
class Write:
    """Serial: bytes the host wrote in one ``write()`` (``t``: s, or None)."""

    data: bytes
    t: float | None = None


@dataclass(frozen=True)
class Recv:
    """CAN: a frame the host received (``t``: its bus time stamp, s since the capture
    started, or None)."""

    arbitration_id: int
    data: bytes
    t: float | None = None
    extended: bool = False
    remote: bool = False
    error: bool = False


@dataclass(frozen=True)
class Send:
    """CAN: a frame the host sent (``t``: s, or None)."""

    arbitration_id: int
    data: bytes
    t: float | None = None


@dataclass(frozen=True)
class Open:
    """The host opened the transport successfully (``t``: when it tried, s, or None)."""

    t: float | None = None


@dataclass(frozen=True)
class Lost:
    """The transport raised DeviceDisconnectedError in ``op`` (``"open"``, ``"read"``,
    ``"write"``, ``"recv"``, ``"send"``) with ``message`` (``t``: s, or None)."""

    op: str
    message: str = ""
    t: float | None = None


Step = Read | Write | Recv | Send | Open | Lost

#: Step types and ``Lost.op`` values that each kind of capture may hold.
STEP_TYPES: dict[str, tuple[type, ...]] = {"serial": (Read, Write, Open, Lost),
                                           "can": (Recv, Send, Open, Lost)}
LOST_OPS: dict[str, tuple[str, ...]] = {"serial": ("open", "read", "write"),
                                        "can": ("open", "recv", "send")}


@dataclass(frozen=True)
class Capture:
    """A loaded capture file.

    Attributes
    ----------
    kind : {"serial", "can"}
        Which transport was recorded.
    settings : tuple of (str, str)
        The recorded transport's settings and any extra ones given to the recorder.
    steps : tuple of Step
        The exchanges in the order the host saw them.
    source : str
        The file it was read from ("" if built in memory).
    started_unix_s : float or None
        Wall-clock start of the capture (Unix time, s).
    """

    kind: CaptureKind
    settings: tuple[tuple[str, str], ...]
    steps: tuple[Step, ...]
    source: str = ""
    started_unix_s: float | None = None


def step_to_json(step: Step) -> dict[str, Any]:
    """The JSON object of one step (the inverse of the parsing in :func:`load_capture`)."""
    out: dict[str, Any] = {} if step.t is None else {"t": round(step.t, 6)}
    if isinstance(step, (Read, Write)):
        out |= {"dir": "read" if isinstance(step, Read) else "write", "hex": step.data.hex()}
    elif isinstance(step, (Recv, Send)):
        out |= {"dir": "recv" if isinstance(step, Recv) else "send",
                "id": step.arbitration_id, "hex": step.data.hex()}
        if isinstance(step, Recv):
            flags = {"ext": step.extended, "rtr": step.remote, "err": step.error}
            out |= {k: True for k, v in flags.items() if v}
    elif isinstance(step, Open):
        out["dir"] = "open"
    else:
        out |= {"dir": "lost", "op": step.op, "error": step.message}
    return out


def _step_from_json(obj: Any, kind: str) -> Step:
    """One step of a ``kind`` capture; ValueError (with the reason) if it is not one."""
    if not isinstance(obj, dict):
        raise ValueError("a step must be a JSON object")
    t = obj.get("t")
    if t is not None and (isinstance(t, bool) or not isinstance(t, (int, float))
                          or not math.isfinite(t)):
        raise ValueError(f"'t' must be a number of seconds, got {t!r}")
    t = None if t is None else float(t)
    direction = obj.get("dir")

    def data() -> bytes:
        text = obj.get("hex")
        if not isinstance(text, str):
            raise ValueError("'hex' (the bytes, as hex digits) is missing")
        try:
            return bytes.fromhex(text)
        except ValueError as exc:
            raise ValueError(f"'hex' is not hex digits: {text[:40]!r}") from exc

    def frame_id() -> int:
        value = obj.get("id")
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 2**29:
            raise ValueError(f"'id' must be a CAN arbitration ID (0..2^29-1), got {value!r}")
        return value

    step: Step
    if direction == "open":
        step = Open(t)
    elif direction == "lost":
        op = obj.get("op")
        if op not in LOST_OPS[kind]:
            raise ValueError(f"'op' of a {kind} 'lost' step must be one of "
                             f"{', '.join(LOST_OPS[kind])}, got {op!r}")
        step = Lost(op, str(obj.get("error", "")), t)
    elif direction in ("read", "write") and kind == "serial":
        step = (Read if direction == "read" else Write)(data(), t)
    elif direction == "recv" and kind == "can":
        step = Recv(frame_id(), data(), t, extended=bool(obj.get("ext", False)),
                    remote=bool(obj.get("rtr", False)), error=bool(obj.get("err", False)))
    elif direction == "send" and kind == "can":
        step = Send(frame_id(), data(), t)
    else:
        raise ValueError(f"'dir' {direction!r} is not a step of a {kind} capture")
    return step


def load_capture(path: str | Path) -> Capture:
    """Read a capture file written by a recording transport (or by hand).

    Parameters
    ----------
    path : str or Path
        The JSON Lines file; blank lines are skipped.

    Raises
    ------
    CaptureFormatError
        The file cannot be read, its header is not a capture header of a known version
        and kind, or a line is not a valid step (bad JSON, as in a line cut short; a
        step of the other kind; bad hex). The message says ``FILE:LINE: why``.
    """
    name = str(path)
    try:
        with open(path, encoding="utf-8") as fh:
            lines = fh.read().splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise CaptureFormatError(f"{name}: cannot read the capture: {exc}") from exc
    header: dict[str, Any] | None = None
    steps: list[Step] = []
    for lineno, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            obj = json.loads(line)
        except json.JSONDecodeError as exc:
            raise CaptureFormatError(f"{name}:{lineno}: not a JSON line (cut short or "
                                     f"garbled): {exc.msg} at column {exc.colno}") from exc
        try:
            if header is None:
                header = _header(obj)
            else:
                steps.append(_step_from_json(obj, header["kind"]))
        except ValueError as exc:
            raise CaptureFormatError(f"{name}:{lineno}: {exc}") from exc
    if header is None:
        raise CaptureFormatError(f"{name}: empty file, no capture header")
    return Capture(header["kind"], header["settings"], tuple(steps), name,
                   header["started_unix_s"])


def _header(obj: Any) -> dict[str, Any]:
    if not isinstance(obj, dict) or "capture" not in obj:
        raise ValueError('the first line must be a capture header {"capture": 1, "kind": ...}')
    if obj["capture"] != CAPTURE_VERSION:
        raise ValueError(f"capture format version {obj['capture']!r} is not supported "
                         f"(this station reads version {CAPTURE_VERSION})")
    kind = obj.get("kind")
    if kind not in STEP_TYPES:
        raise ValueError(f"capture kind must be 'serial' or 'can', got {kind!r}")
    settings = obj.get("settings", {})
    if not isinstance(settings, dict):
        raise ValueError("capture 'settings' must be a JSON object")
    started = obj.get("started_unix_s")
    return {"kind": kind, "settings": tuple((str(k), str(v)) for k, v in settings.items()),
            "started_unix_s": float(started) if isinstance(started, (int, float)) else None}


class _CaptureWriter:
    """Appends steps to a capture file, one flushed line each (a crash loses at most the
    line being written). The file stays open between :meth:`add` and :meth:`release`."""

    def __init__(self, path: str | Path, kind: CaptureKind,
                 settings: tuple[tuple[str, str], ...]) -> None:
        self.path = Path(path)
        self._t0 = time.monotonic()
        self.started_unix_s = time.time()
        self._lock = threading.Lock()
        self._fh: IO[str] | None = None
        header = {"capture": CAPTURE_VERSION, "kind": kind, "settings": dict(settings),
                  "started_unix_s": self.started_unix_s}
        self.path.write_text(json.dumps(header) + "\n", encoding="utf-8")

    def now(self) -> float:
        """Seconds since the capture started (wall time, monotonic)."""
        return time.monotonic() - self._t0

    def add(self, step: Step) -> None:
        line = json.dumps(step_to_json(step), separators=(",", ":")) + "\n"
        with self._lock:
            if self._fh is None:
                self._fh = open(self.path, "a", encoding="utf-8")  # kept open: see release()
            self._fh.write(line)
            self._fh.flush()

    def release(self) -> None:
        """Close the file (the next :meth:`add` reopens it for appending)."""
        with self._lock:
            fh, self._fh = self._fh, None
            if fh is not None:
                fh.close()


class _Recorder:
    """What both recording transports share: the capture file, settings, open, close."""

    kind: CaptureKind

    def __init__(self, inner: Any, path: str | Path, *,
                 settings: Mapping[str, str] | None = None) -> None:
        self.inner = inner
        self._t_call = 0.0  # when the latest call to inner began, s since the start
        extra = tuple((str(k), str(v)) for k, v in (settings or {}).items())
        self._writer = _CaptureWriter(path, self.kind, (*inner.settings, *extra))

    @property
    def path(self) -> Path:
        """The capture file."""
        return self._writer.path

    @property
    def settings(self) -> tuple[tuple[str, str], ...]:
        """The inner transport's settings."""
        return tuple(self.inner.settings)

    def open(self) -> None:
        """Open ``inner``; records ``open``, or ``lost`` if it raised."""
        self._call("open", self.inner.open)
        self._writer.add(Open(self._t_call))

    def close(self) -> None:
        """Close ``inner`` and the capture file (reopened, appending, by :meth:`open`)."""
        try:
            self.inner.close()
        finally:
            self._writer.release()

    def _call(self, op: str, fn: Any, *args: Any) -> Any:
        """``fn(*args)``; a DeviceDisconnectedError is recorded (time of the call) and
        raised again."""
        self._t_call = self._writer.now()
        try:
            return fn(*args)
        except DeviceDisconnectedError as exc:
            self._writer.add(Lost(op, str(exc), self._t_call))
            raise


class RecordingByteTransport(_Recorder):
    """A :class:`ByteTransport` that records everything ``inner`` exchanges.

    It behaves exactly as ``inner`` (same results, same exceptions, same settings) and
    appends each non-empty chunk read, each write, each open and each
    DeviceDisconnectedError to the capture file as it happens, one flushed line each.
    Empty reads are not recorded: a replay rebuilds silences from the time stamps.

    Parameters
    ----------
    inner : ByteTransport
        The real transport (a :class:`~devices.transports.serial.SerialTransport`).
    path : str or Path
        Capture file, created (or truncated) now; the header is written at once.
    settings : mapping of str to str, optional
        Extra settings for the header (``{"protocol": "stim300", "rate": "2000"}``), so
        that the file says how to replay it.
    """

    kind: CaptureKind = "serial"

    def __init__(self, inner: ByteTransport, path: str | Path, *,
                 settings: Mapping[str, str] | None = None) -> None:
        super().__init__(inner, path, settings=settings)

    def read(self, timeout_s: float) -> bytes:
        """``inner.read(timeout_s)`` (wall s); a non-empty chunk is recorded (``t``: when
        it returned)."""
        data: bytes = self._call("read", self.inner.read, timeout_s)
        if data:
            self._writer.add(Read(bytes(data), self._writer.now()))
        return data

    def write(self, data: bytes) -> None:
        """``inner.write(data)``, recorded (``t``: when it was called)."""
        self._call("write", self.inner.write, data)
        self._writer.add(Write(bytes(data), self._t_call))


class RecordingCanTransport(_Recorder):
    """A CAN transport that records every frame ``inner`` receives and sends.

    It behaves as ``inner`` for what :class:`~devices.can_raw.CanRateSource` uses
    (``open``, ``close``, ``recv``, ``send``, ``settings``, ``interface``, ``channel``).
    It has no ``bus``: a CANopen adapter, which drives the python-can bus directly,
    cannot be recorded through it (its frames would bypass the capture).

    Parameters
    ----------
    inner : CanTransport
        The real transport.
    path : str or Path
        Capture file, created (or truncated) now.
    settings : mapping of str to str, optional
        Extra settings for the header (``{"layout": "shared", "rate": "1000"}``).

    Notes
    -----
    A received frame's ``t`` is its bus time stamp (``msg.timestamp``, wall clock) less
    the capture's start, so that a replay gives the adapter the same frame times.
    """

    kind: CaptureKind = "can"

    def __init__(self, inner: CanLink, path: str | Path, *,
                 settings: Mapping[str, str] | None = None) -> None:
        super().__init__(inner, path, settings=settings)

    @property
    def interface(self) -> str:
        """The inner transport's python-can interface."""
        return str(self.inner.interface)

    @property
    def channel(self) -> str:
        """The inner transport's channel."""
        return str(self.inner.channel)

    def recv(self, timeout_s: float) -> can.Message | None:
        """``inner.recv(timeout_s)`` (wall s); a frame is recorded with its bus stamp."""
        msg: can.Message | None = self._call("recv", self.inner.recv, timeout_s)
        if msg is not None:
            t = (msg.timestamp - self._writer.started_unix_s if msg.timestamp
                 else self._writer.now())
            self._writer.add(Recv(msg.arbitration_id, bytes(msg.data), t,
                                  extended=msg.is_extended_id, remote=msg.is_remote_frame,
                                  error=msg.is_error_frame))
        return msg

    def send(self, arbitration_id: int, data: bytes, timestamp: float = 0.0) -> None:
        """``inner.send(...)``, recorded (``t``: when it was called)."""
        self._call("send", self.inner.send, arbitration_id, data, timestamp)
        self._writer.add(Send(arbitration_id, bytes(data), self._t_call))
