"""Replaying recorded exchanges to an adapter: PyMeasure's ``expected_protocol`` for
byte streams and raw CAN (docs/devices.md, "Capture and replay").

``read()``/``recv()`` return what the device sent, in order; ``write()``/``send()``
must be what the host sent (else :class:`ReplayMismatchError`); :func:`expected_exchanges`
also fails (:class:`UnusedExchangesError`) if steps are left unused. A *replay clock*
(``transport.clock()``: recorded s since the capture started) times the steps: passed to
the adapter as ``clock=``, it makes the adapter's gap counts and silence limits those of
the recorded session, however fast the replay runs. After the last step, a read or recv
that would wait, and ``open()``, raise :class:`EndOfReplayError` (a DeviceDisconnectedError:
the recording ends like a pulled cable); a zero-timeout poll returns nothing.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import can

from devices.capture import (
    LOST_OPS,
    STEP_TYPES,
    Capture,
    CaptureFormatError,
    CaptureKind,
    Lost,
    Open,
    Read,
    RecordingByteTransport,
    RecordingCanTransport,
    Recv,
    Send,
    Step,
    Write,
    load_capture,
)
from devices.errors import DeviceDisconnectedError, DeviceError

__all__ = [
    "Capture", "CaptureFormatError", "EndOfReplayError", "Lost", "Open", "Read", "Recv",
    "RecordingByteTransport", "RecordingCanTransport", "ReplayByteTransport",
    "ReplayCanTransport", "ReplayError", "ReplayMismatchError", "Send",
    "UnusedExchangesError", "Write", "expected_exchanges", "load_capture",
    "recording_transport", "replay_transport",
]


class ReplayError(DeviceError):
    """Base class of the replay errors."""


class ReplayMismatchError(ReplayError, AssertionError):
    """The host wrote or sent what the script does not expect (or read where it expects
    another step); the message shows the step number, expected and actual bytes in hex."""


class UnusedExchangesError(ReplayError, AssertionError):
    """Steps of the script were never used; ``unused`` holds their indices."""

    def __init__(self, message: str, unused: tuple[int, ...] = ()) -> None:
        super().__init__(message)
        self.unused = unused


class EndOfReplayError(ReplayError, DeviceDisconnectedError):
    """Every step was replayed: the recording ends like a pulled cable (read and open)."""


_HEX_SHOWN = 48


def _hex(data: bytes) -> str:
    if not data:
        return "(no bytes)"
    more = len(data) - _HEX_SHOWN
    return data[:_HEX_SHOWN].hex(" ") + (f" ... (+{more} bytes)" if more > 0 else "")


def _describe(step: Step, done: int = 0) -> str:
    """A step as a message shows it (``done``: bytes of a write already matched)."""
    if isinstance(step, Read):
        return f"read {_hex(step.data)}"
    if isinstance(step, Write):
        part = f" ({done} of {len(step.data)} bytes written)" if done else ""
        return f"write {_hex(step.data[done:])}{part}"
    if isinstance(step, (Recv, Send)):
        name = "recv" if isinstance(step, Recv) else "send"
        return f"{name} id 0x{step.arbitration_id:X} [{_hex(step.data)}]"
    if isinstance(step, Open):
        return "open()"
    return f"a lost link in {step.op}()"


class _Script:
    """Steps, what is used of them, the replay clock, and the checks shared by the
    byte-stream and CAN replays."""

    kind: CaptureKind
    #: Longest real sleep (wall s) of a read that waits for the host's next command.
    idle_sleep_s = 0.002

    def __init__(self, steps: Iterable[Step], *, settings: Iterable[tuple[str, str]] = (),
                 source: str = "", realtime: bool = False) -> None:
        self.steps: tuple[Step, ...] = tuple(steps)
        for i, step in enumerate(self.steps):
            if not isinstance(step, STEP_TYPES[self.kind]):
                raise TypeError(f"step {i}: a {type(step).__name__} is not a step of a "
                                f"{self.kind} replay")
            if isinstance(step, Lost) and step.op not in LOST_OPS[self.kind]:
                raise ValueError(f"step {i}: a {self.kind} link is not lost in {step.op}()")
            if isinstance(step, Write) and not step.data:
                raise ValueError(f"step {i}: a write of no bytes cannot be matched")
        self.source = source
        self.realtime = realtime
        self._settings = (*tuple(settings), ("replay", source or "script"))
        self._done = [False] * len(self.steps)
        self._written: dict[int, int] = {}  # bytes matched of a partly written step
        self._first = 0
        self._now = 0.0
        self._wall_origin: float | None = None  # time.monotonic() at replay time 0
        self._unix_origin = time.time()  # time.time() at replay time 0
        self._is_open = False
        self.failures: list[ReplayMismatchError] = []

    @property
    def settings(self) -> tuple[tuple[str, str], ...]:
        """The recorded settings and ``("replay", FILE)``."""
        return self._settings

    def clock(self) -> float:
        """The replay clock: recorded seconds since the capture started, where the
        replay stands (pass it to the adapter as ``clock=``)."""
        return self._now

    def close(self) -> None:
        """Close (a no-op on the script; reads raise until :meth:`open`)."""
        self._is_open = False

    def open(self) -> None:
        """Open: replays a recorded failed open (DeviceDisconnectedError) or uses a
        recorded open; EndOfReplayError when every step was used."""
        if self._wall_origin is None:
            self._wall_origin = time.monotonic() - self._now
            self._unix_origin = time.time() - self._now
        i = self._pending()
        if i is None:
            self._is_open = False
            raise self._end()
        step = self.steps[i]
        if isinstance(step, Lost) and step.op == "open":
            self._consume(i)
            self._is_open = False
            raise DeviceDisconnectedError(step.message or "replay: the recorded open failed")
        if isinstance(step, Open):
            self._consume(i)
        self._is_open = True

    def check_used_up(self) -> None:
        """Raise if the host went off the script: its first mismatch again (also one it
        caught), else :class:`UnusedExchangesError` listing the steps never used."""
        if self.failures:
            first = self.failures[0]
            raise ReplayMismatchError(f"{first} (raised earlier and caught)") from first
        unused = tuple(i for i, done in enumerate(self._done) if not done)
        if unused:
            shown = "; ".join(f"step {i}: {_describe(self.steps[i], self._written.get(i, 0))}"
                              for i in unused[:5])
            more = f"; and {len(unused) - 5} more" if len(unused) > 5 else ""
            raise UnusedExchangesError(f"{len(unused)} of {len(self.steps)} recorded "
                                       f"exchanges never used{self._of()}: {shown}{more}",
                                       unused)

    # -- helpers of the subclasses ---------------------------------------------------
    def _output(self, timeout_s: float, op: str) -> Step | None:
        """The device's next output (a Read or Recv step, used now) once it is due within
        ``timeout_s``; None after an empty wait; a recorded lost link raises."""
        self._check_open(f"{op}()")
        i = self._pending()
        if i is None:
            if timeout_s <= 0:  # a poll: nothing there now (CanRateSource drains by polls)
                return None
            raise self._end()
        step = self.steps[i]
        if isinstance(step, (Write, Send)):  # the device waits for the host's command
            self._idle(timeout_s)
            return None
        if not (isinstance(step, (Read, Recv)) or (isinstance(step, Lost) and step.op == op)):
            raise self._fail(i, f"the recording expects {_describe(step)}, the host "
                                f"called {op}()")
        if not self._due(i, timeout_s):
            return None
        if isinstance(step, Lost):
            raise self._lost(i)
        self._consume(i)
        return step

    def _of(self) -> str:
        return f" of {self.source}" if self.source else ""

    def _pending(self) -> int | None:
        """Index of the first step not used yet."""
        while self._first < len(self.steps) and self._done[self._first]:
            self._first += 1
        return self._first if self._first < len(self.steps) else None

    def _next_host_step(self, start: int, skip: type) -> int | None:
        """First unused step from ``start`` on that is not a ``skip`` (the device's
        output, which does not hold up the host's commands)."""
        for j in range(start, len(self.steps)):
            if not self._done[j] and not isinstance(self.steps[j], skip):
                return j
        return None

    def _consume(self, i: int) -> None:
        self._done[i] = True
        self._written.pop(i, None)
        t = self.steps[i].t
        if t is not None and t > self._now:
            self._now = t

    def _due(self, i: int, timeout_s: float) -> bool:
        """Whether step ``i`` falls due within ``timeout_s`` (s); if not, the replay clock
        moves on by the timeout (an empty wait)."""
        t = self.steps[i].t
        if t is None or t <= self._now + timeout_s:
            self._sleep_until(self._now if t is None else t)
            return True
        self._now += timeout_s
        self._sleep_until(self._now)
        return False

    def _idle(self, timeout_s: float) -> None:
        """A read while the device waits for the host's command: nothing comes."""
        self._now += timeout_s
        if self.realtime:
            self._sleep_until(self._now)
        else:
            time.sleep(min(timeout_s, self.idle_sleep_s))

    def _sleep_until(self, t: float) -> None:
        if self.realtime and self._wall_origin is not None:
            delay = self._wall_origin + t - time.monotonic()
            if delay > 0:
                time.sleep(delay)

    def _check_open(self, call: str) -> None:
        if not self._is_open:
            raise DeviceDisconnectedError(f"replay{self._of()}: {call} while not open")

    def _end(self) -> EndOfReplayError:
        return EndOfReplayError(f"end of the recording{self._of()}: all {len(self.steps)} "
                                f"steps replayed")

    def _fail(self, i: int | None, message: str) -> ReplayMismatchError:
        at = "after the last step" if i is None else f"step {i}"
        error = ReplayMismatchError(f"replay{self._of()}, {at}: {message}")
        self.failures.append(error)
        return error

    def _lost(self, i: int) -> DeviceDisconnectedError:
        self._consume(i)
        step = self.steps[i]
        assert isinstance(step, Lost)
        return DeviceDisconnectedError(step.message or f"replay: link lost in {step.op}()")


class ReplayByteTransport(_Script):
    """A :class:`~devices.transports.serial.ByteTransport` that plays a serial script.

    ``read(timeout_s)`` returns the next recorded chunk once it is due on the replay
    clock; an empty read waits (replay clock) its whole timeout, as the real one does. If
    the next step is a write, the device is waiting for a command: the read returns
    b"" after at most ``idle_sleep_s`` of wall time. ``write(data)`` is matched as a byte
    stream against the next write steps (one write may cover several steps, or part of
    one); read steps still pending do not hold it up (the device had sent those bytes
    already: later reads return them). A recorded ``lost`` step raises
    DeviceDisconnectedError from the same call; after the last step, ``read()`` (with a
    timeout > 0) and ``open()`` raise :class:`EndOfReplayError` at once.

    Parameters
    ----------
    steps : iterable of Read, Write, Open, Lost
        The script (``Capture.steps`` or hand-written).
    settings : iterable of (str, str)
        Settings to report (a capture's), with ``("replay", source)`` appended.
    source : str
        The capture file, for messages.
    realtime : bool
        Also wait the recorded times in wall seconds (a live view); by default the
        replay runs as fast as the adapter reads.

    A step that is not a serial step raises TypeError; a write of no bytes, ValueError.
    """

    kind: CaptureKind = "serial"

    def read(self, timeout_s: float) -> bytes:
        """The next recorded chunk, or b"" after waiting ``timeout_s`` (replay-clock s).

        Raises DeviceDisconnectedError (not open; a recorded lost link), EndOfReplayError
        (after the last step), ReplayMismatchError (the recording expects an open()).
        """
        step = self._output(timeout_s, "read")
        return step.data if isinstance(step, Read) else b""

    def write(self, data: bytes) -> None:
        """Match ``data`` against the next write steps.

        Raises ReplayMismatchError (a byte differs, or no write is recorded here),
        DeviceDisconnectedError (not open; the recording lost the link in this write).
        """
        self._check_open("write()")
        data = bytes(data)
        plan: list[tuple[int, Write, int]] = []
        pos, start = 0, self._first
        while pos < len(data):
            j = self._next_host_step(start, Read)
            if j is None:
                raise self._fail(j, f"the host wrote {_hex(data[pos:])}, the recording "
                                    f"has no write left")
            step = self.steps[j]
            if isinstance(step, Lost) and step.op == "write" and pos == 0:
                raise self._lost(j)
            if not isinstance(step, Write):
                raise self._fail(j, f"the host wrote {_hex(data[pos:])}, the recording "
                                    f"expects {_describe(step)}")
            done = self._written.get(j, 0)
            expected = step.data[done:]
            n = min(len(expected), len(data) - pos)
            if data[pos:pos + n] != expected[:n]:
                after = f" (after {pos} matching bytes of this write)" if pos else ""
                raise self._fail(j, f"expected write {_hex(expected)}, the host wrote "
                                    f"{_hex(data[pos:])}{after}")
            plan.append((j, step, done + n))
            pos += n
            start = j + 1
        for j, matched, upto in plan:
            if upto == len(matched.data):
                self._consume(j)
            else:
                self._written[j] = upto


class ReplayCanTransport(_Script):
    """A CAN transport (what :class:`~devices.can_raw.CanRateSource` uses) that plays a
    CAN script.

    ``recv(timeout_s)`` returns the next recorded frame once due on the replay clock, as
    a :class:`can.Message` stamped ``time.time()`` of the replay's start plus its recorded
    ``t`` (the adapter maps bus stamps to its clock with :class:`BusClock`), else None
    after moving the replay clock on by the timeout. ``send()`` must match the next send
    step's ID and data (pending received frames do not hold it up). Lost steps and the
    end of the script behave as in :class:`ReplayByteTransport`.

    Parameters
    ----------
    steps : iterable of Recv, Send, Open, Lost
        The script.
    settings, source, realtime
        As for :class:`ReplayByteTransport`.
    """

    kind: CaptureKind = "can"
    interface = "replay"

    @property
    def channel(self) -> str:
        """The capture file (or ``"script"``)."""
        return self.source or "script"

    def recv(self, timeout_s: float) -> can.Message | None:
        """The next recorded frame, or None after ``timeout_s`` (replay-clock s); raises
        as :meth:`ReplayByteTransport.read` does."""
        step = self._output(timeout_s, "recv")
        if not isinstance(step, Recv):
            return None
        stamp = self._unix_origin + (self._now if step.t is None else step.t)
        return can.Message(arbitration_id=step.arbitration_id, data=step.data,
                           is_extended_id=step.extended, is_remote_frame=step.remote,
                           is_error_frame=step.error, timestamp=stamp)

    def send(self, arbitration_id: int, data: bytes, timestamp: float = 0.0) -> None:
        """Match a frame against the next send step (``timestamp`` is not compared);
        ReplayMismatchError if its ID or data differ or no send is recorded here."""
        self._check_open("send()")
        data = bytes(data)
        j = self._next_host_step(self._first, Recv)
        step = None if j is None else self.steps[j]
        if j is not None and isinstance(step, Lost) and step.op == "send":
            raise self._lost(j)
        if j is None or not (isinstance(step, Send) and step.arbitration_id == arbitration_id
                             and step.data == data):
            expects = "has no send left" if step is None else f"expects {_describe(step)}"
            raise self._fail(j, f"the host sent id 0x{arbitration_id:X} [{_hex(data)}], "
                                f"the recording {expects}")
        self._consume(j)


ReplayTransport = ReplayByteTransport | ReplayCanTransport


def replay_transport(capture: Capture, *, realtime: bool = False) -> ReplayTransport:
    """The replay transport of a loaded capture: a :class:`ReplayByteTransport` for a
    serial capture, a :class:`ReplayCanTransport` for a CAN one.

    Build the adapter with ``clock=transport.clock`` (``clock_scale=1``): its gap and
    silence times are then the recording's. ``realtime`` paces it at the recorded times.
    """
    cls = ReplayByteTransport if capture.kind == "serial" else ReplayCanTransport
    return cls(capture.steps, settings=capture.settings, source=capture.source,
               realtime=realtime)


def recording_transport(inner: Any, path: str | Path, *,
                        settings: Mapping[str, str] | None = None
                        ) -> RecordingByteTransport | RecordingCanTransport:
    """Wrap ``inner`` so that it records a capture file at ``path`` (created now).

    A transport with ``recv``/``send`` (:class:`~devices.transports.can.CanTransport`)
    gets a :class:`RecordingCanTransport`, one with ``read``/``write``
    (:class:`~devices.transports.serial.SerialTransport`, any ByteTransport) a
    :class:`RecordingByteTransport`. ``settings`` go into the header (e.g. the device
    URL's protocol and rate, so that the file says how to replay it). Any other
    transport raises TypeError: CANopen (the python-can bus used directly) and Modbus
    are not recorded.
    """
    if all(hasattr(inner, name) for name in ("open", "close", "recv", "send", "settings")):
        return RecordingCanTransport(inner, path, settings=settings)
    if all(hasattr(inner, name) for name in ("open", "close", "read", "write", "settings")):
        return RecordingByteTransport(inner, path, settings=settings)
    raise TypeError(f"cannot record a {type(inner).__name__}: only byte-stream (serial) and "
                    f"raw CAN transports are recorded, not CANopen or Modbus")


@contextmanager
def expected_exchanges(script: Capture | Iterable[Step], *, realtime: bool = False
                       ) -> Iterator[ReplayTransport]:
    """A replay transport for the block; on a clean exit, every step must have been used.

    Parameters
    ----------
    script : Capture or iterable of steps
        A loaded capture, or hand-written steps: ``Read``/``Write`` (serial) or
        ``Recv``/``Send`` (CAN), with ``Open``/``Lost`` as needed.
    realtime : bool
        Pace the replay at the recorded times (s); default as fast as the host reads.

    Yields
    ------
    ReplayByteTransport or ReplayCanTransport
        Not opened: the adapter opens it.

    Raises
    ------
    ReplayMismatchError
        From the block, as it happens; at exit, if the block caught one.
    UnusedExchangesError
        At exit, if steps were never used (how many, and the first few in hex).
    """
    if not isinstance(script, Capture):
        steps = tuple(script)
        kind: CaptureKind = "can" if any(isinstance(s, (Recv, Send)) for s in steps) else "serial"
        script = Capture(kind, (), steps)
    transport = replay_transport(script, realtime=realtime)
    yield transport
    transport.check_used_up()
