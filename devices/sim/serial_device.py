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
import tempfile
import tty
from collections.abc import Callable
from typing import Any

from devices.codecs.base import Reading, StreamCodec
from devices.sim.faults import SimCore
from devices.sim.loop import DeviceLoop
from devices.sim.mti import MtiMessages


class PtySerialDevice(DeviceLoop):
    """Serves a stream codec's frames on a pty from a background thread.

    Parameters
    ----------
    codec : StreamCodec
        The protocol (its encoder makes the bytes; its decoder reads host commands).
    message : callable or None
        Reading -> the bytes the unit sends, in place of the codec's encoder: a unit's
        messages laid out from the manufacturer's document on their own
        (:class:`devices.sim.kvh_unit.KvhMessageWriter`).
    core : SimCore
        Signal, schedule, faults and ledger.
    header : bytes
        Sync pattern the junk bytes must avoid (see :meth:`SimCore.wire`).
    poll_s : float
        Wall-clock period of the device loop, s.
    max_lag_wall_s : float
        Samples this thread is later than this (wall s; at most a quarter of a counter
        period) are booked lost instead of sent late (see :meth:`SimCore.due`), and so
        are frames the port cannot take when they are due: a real gyro sends on time,
        whatever the host does.
    mti : MtiMessages or None
        An Xsens MTi's messages, written from the protocol document instead of by the
        codec's encoder (and its GNSS-only messages between the samples).
    """

    def __init__(self, codec: StreamCodec[Any], core: SimCore, *, header: bytes = b"",
                 poll_s: float = 0.002, max_lag_wall_s: float = 0.05,
                 message: Callable[[Reading], bytes] | None = None,
                 mti: MtiMessages | None = None) -> None:
        super().__init__()
        self.codec = codec
        self.message = message or (lambda reading: codec.encode(codec.from_reading(reading)))
        self.mti = mti
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

    @property
    def max_lag_s(self) -> float:
        """Lateness allowance of a starved device thread, simulated s (see
        :meth:`SimCore.due`): ``max_lag_wall_s``, and at most a quarter of a counter
        period, so that the samples it still sends after a stall cannot shift the stall's
        wrap count."""
        core = self.core
        wrap = self.codec.counter_modulus // getattr(self.codec, "counter_step", 1)
        return min(self.max_lag_wall_s * core.clock.warp, wrap / core.sample_rate_hz / 4.0)

    @property
    def max_latency_s(self) -> float:
        """Longest this device holds a sample before writing it, simulated s (its loop
        period and lateness allowance)."""
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

    def _frames(self, readings: list[Reading]) -> list[tuple[bytes, int, bool]]:
        """The readings as they go on the wire (maybe dropped, corrupted, after garbage):
        (bytes, sample index, booked delivered) each, for :meth:`_write`."""
        core, frames = self.core, []
        for reading in readings:
            if self.mti is None:
                message = self.message(reading)
            else:
                message = self.mti.imu(reading)
                gnss = self.mti.gnss_due(reading)
                if gnss:  # no sample: never booked, sent as a reply is (index -1)
                    frames.append((gnss, -1, False))
            before = core.ledger.delivered
            wire = core.wire(message, reading.counter, header=self.header)
            frames.append((wire, reading.counter, core.ledger.delivered > before))
        return frames

    def _write(self, frames: list[tuple[bytes, int, bool]]) -> None:
        """Write the frames now, as a UART sends: what the port cannot take (the reader
        not reading, the port closed) is lost, never sent late.

        ``frames``: (bytes on the wire, sample index, booked delivered) in order; a frame
        not written whole is booked lost (the bytes of one cut short reach the station,
        which resynchronizes after them).
        """
        # Frames overdue by more than this device's latency (its thread was starved
        # between taking them due and writing them) are lost, not written late: a late
        # write would look to the station like a longer gap than the counter steps.
        # Sample i covers [due_time(i), due_time(i + 1)): it is ready, and is sent, at the
        # end of its period (at 10 Hz a whole 0.1 s after due_time(i), more than the
        # latency allowance: a frame is late only past its own period's end).
        overdue = self.core.clock() - self.max_latency_s
        on_time: list[tuple[bytes, int, bool]] = []
        late: list[tuple[bytes, int, bool]] = []
        for item in frames:
            in_time = item[1] < 0 or self.core.due_time(item[1] + 1) >= overdue  # replies: -1
            (on_time if in_time else late).append(item)
        self.core.overrun([index for _, index, delivered in late if delivered])
        frames = on_time
        data = b"".join(f for f, _, _ in frames)
        written = 0
        if data and self._master is not None:
            try:
                written = os.write(self._master, data)
            except BlockingIOError:
                written = 0
            except OSError as exc:
                if exc.errno not in (errno.EIO, errno.EBADF):
                    raise
        end = 0
        lost = []
        for frame, index, delivered in frames:
            end += len(frame)
            if end > written and delivered:
                lost.append(index)
        self.core.overrun(lost)

    def _run(self) -> None:
        core = self.core
        # At most this many frames per pass: a device whose thread the host could not
        # run for a while sends what is still due (within its lateness allowance, the
        # rest is lost as a starved gyro loses it) in small writes, back to back.
        chunk = 64
        behind = False
        while not self._stop.wait(0.0 if behind else self.poll_s):
            if core.link_down():
                if self.connected:
                    self._detach()
                    core.ledger.disconnects += 1
                core.lose(core.due())
                continue
            if not self.connected:
                self._attach()
            replies = self._handle_commands()
            # A gyro sends on time or not at all: samples overdue by more than the
            # lateness allowance are lost, whatever held this thread up.
            readings = core.due(chunk, max_lag_s=self.max_lag_s)
            behind = len(readings) == chunk
            if core.stalled():
                core.lose(readings)
                readings = []
            frames = [(replies, -1, False)] if replies else []
            frames += self._frames(readings)
            if frames:
                self._write(frames)
