"""A simulated serial gyro on a pseudo-terminal pair (raw mode), a real tty for pyserial.

The device side writes encoded frames to the pty master; the station opens the slave by
a stable symlink (like ``/dev/serial/by-id/...``). A disconnect closes the master and
removes the link; the reconnect makes a new pty and points the link at it, as a USB
adapter that re-enumerates.
"""

from __future__ import annotations

import contextlib
import errno
import os
import select
import tempfile
import time
import tty
from typing import Any

from devices.codecs.base import StreamCodec
from devices.sim.faults import SimCore
from devices.sim.loop import DeviceLoop


class PtySerialDevice(DeviceLoop):
    """Serves a stream codec's frames on a pty from a background thread.

    Parameters
    ----------
    codec : StreamCodec
        The protocol (its encoder makes the bytes; its decoder reads host commands).
    core : SimCore
        Signal, schedule, faults and ledger.
    header : bytes
        Sync pattern the junk bytes must avoid (see :meth:`SimCore.wire`).
    poll_s : float
        Wall-clock period of the device loop, s.
    max_lag_wall_s : float
        Samples this thread is later than this (wall s, when not held up by the reader
        and not catching up; at most a quarter of a counter period) are booked lost
        instead of sent late (see :meth:`SimCore.due`).
    """

    def __init__(self, codec: StreamCodec[Any], core: SimCore, *, header: bytes = b"",
                 poll_s: float = 0.002, max_lag_wall_s: float = 0.05) -> None:
        super().__init__()
        self.codec = codec
        self.core = core
        self.header = header
        self.poll_s = poll_s
        self.max_lag_wall_s = max_lag_wall_s
        self._dir = tempfile.mkdtemp(prefix="gyro-sim-")
        self.port = os.path.join(self._dir, "tty")
        self._master: int | None = None
        self._slave: int | None = None
        self._commands = b""

    # -- pty management ------------------------------------------------------------
    def _attach(self) -> None:
        master, slave = os.openpty()
        tty.setraw(master)
        tty.setraw(slave)
        os.set_blocking(master, False)
        self._master, self._slave = master, slave
        tmp = self.port + ".new"
        os.symlink(os.ttyname(slave), tmp)
        os.replace(tmp, self.port)

    def _detach(self) -> None:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(self.port)
        for fd in (self._master, self._slave):
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._master = self._slave = None

    #: Shortest pause of the device thread (wall s) taken for starvation: at a high warp
    #: a quarter counter period is less than the host's scheduling quantum.
    min_starved_wall_s = 0.005

    @property
    def max_lag_s(self) -> float:
        """Lateness allowance of a starved device thread, simulated s (see
        :meth:`SimCore.due`): ``max_lag_wall_s``, and at most a quarter of a counter
        period, so that the samples it still sends after a stall cannot shift the stall's
        wrap count."""
        core = self.core
        return min(self.max_lag_wall_s * core.clock.warp,
                   self.codec.counter_modulus / core.sample_rate_hz / 4.0)

    @property
    def max_latency_s(self) -> float:
        """Longest this device holds a sample before writing it, simulated s (its loop
        period and lateness allowance), unless the reader holds it up."""
        return self.poll_s * self.core.clock.warp + self.max_lag_s

    @property
    def connected(self) -> bool:
        """Whether the pty exists now."""
        return self._master is not None

    # -- lifecycle -----------------------------------------------------------------
    def start(self) -> PtySerialDevice:
        """Create the pty and start the device thread; returns self."""
        self._attach()
        self._start_loop("pty-gyro")
        return self

    def stop(self) -> None:
        """Stop the thread, close the pty and remove the link directory."""
        self._stop_loop()
        self._detach()
        with contextlib.suppress(OSError):
            os.rmdir(self._dir)

    def __enter__(self) -> PtySerialDevice:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # -- device loop ---------------------------------------------------------------
    def _handle_commands(self) -> bytes:
        """Answer host commands (Xbus GoToConfig/GoToMeasurement); returns reply bytes."""
        assert self._master is not None
        try:
            self._commands += os.read(self._master, 4096)
        except (BlockingIOError, OSError):
            return b""
        result = self.codec.decode(self._commands)
        self._commands = result.rest
        reply = b""
        for frame in result.frames:
            answer = self.codec.answer(frame)
            if answer is None:
                continue
            frame_out, streaming = answer
            reply += self.codec.encode(frame_out)
            # The device's own configuration mode: independent of the operator's hold
            # (SimCore.pause), which a GoToMeasurement must not lift.
            if streaming:
                self.core.enter_measurement()
            else:
                self.core.enter_configuration()
        return reply

    def _write(self, data: bytes) -> bool:
        """Write everything (the reader's pace: lossless back-pressure); True if it waited."""
        view = memoryview(data)
        waited = False
        while view and not self._stop.is_set() and self._master is not None:
            try:
                n = os.write(self._master, view)
                view = view[n:]
            except BlockingIOError:
                waited = True
                select.select([], [self._master], [], 0.05)
            except OSError as exc:
                if exc.errno in (errno.EIO, errno.EBADF):
                    return waited
                raise
        return waited

    def _run(self) -> None:
        core = self.core
        behind = False
        # At most this many frames per write: a device that has fallen behind (its reader
        # slow, or the host too slow for its rate) catches up in small writes, back to
        # back, instead of going silent while it encodes a large batch (a silence the
        # reader would rightly take for lost samples).
        chunk = 64
        last_pass = time.monotonic()
        while not self._stop.wait(0.0 if behind else self.poll_s):
            # Starved: this thread did not run for longer than its allowance (a gyro
            # does not stop sampling: what it would have sent meanwhile is lost). Late
            # only because the reader held a write up, or because the host cannot run
            # it as fast as its rate (it runs flat out, catching up): nothing is lost.
            starved = time.monotonic() - last_pass > max(self.max_lag_s / core.clock.warp,
                                                         self.min_starved_wall_s)
            last_pass = time.monotonic()
            if core.link_down():
                if self.connected:
                    self._detach()
                    core.ledger.disconnects += 1
                core.lose(core.due())
                continue
            if not self.connected:
                self._attach()
            out = bytearray(self._handle_commands())
            readings = core.due(chunk, max_lag_s=self.max_lag_s if starved else None)
            behind = len(readings) == chunk
            if core.stalled():
                core.lose(readings)
                readings = []
            for reading in readings:
                out += core.wire(self.codec.encode(self.codec.from_reading(reading)),
                                 reading.counter, header=self.header)
            if out:
                self._write(bytes(out))
            last_pass = time.monotonic()
