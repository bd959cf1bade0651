"""A simulated gyro broadcasting its rates in raw CAN frames on a python-can bus."""

from __future__ import annotations

import time

from devices.batching import BusClock
from devices.codecs.can_frame import CanFrameLayout, CanFrameValues
from devices.sim.e2e_p01_protect import Profile1Protector
from devices.sim.faults import SimCore
from devices.sim.loop import DeviceLoop
from devices.transports.can import CanTransport


class CanBroadcastDevice(DeviceLoop):
    """Sends each due sample as the layout's frames from a background thread.

    A "disconnect" is the node going silent (powered off, unplugged from the bus).

    Parameters
    ----------
    transport : CanTransport
        Its own bus connection (a second ``virtual`` bus on the same channel, opened
        with ``preserve_timestamps=True`` so frames carry the time they fell due).
    layout : CanFrameLayout
        The frame layout: its encoder places the values; the E2E Profile 1 counter and
        CRC are written by :class:`~devices.sim.e2e_p01_protect.Profile1Protector`, from
        the standard's steps, not by the codec.
    core : SimCore
        Signal, schedule, faults and ledger.
    poll_s : float
        Wall-clock period of the device loop, s.
    max_lag_wall_s : float
        Samples this thread is later than this (wall s) are lost, never sent late: a
        real node sends on its schedule.
    stamped : bool
        The bus keeps the time stamp each frame is sent with (python-can's ``virtual``
        bus with ``preserve_timestamps``): frames carry the time their sample fell due,
        so lateness cannot shift a gap's wrap count. Otherwise (the receiver's kernel
        stamps them) the allowance is at most a quarter of a counter period.
    """

    def __init__(self, transport: CanTransport, layout: CanFrameLayout, core: SimCore, *,
                 poll_s: float = 0.002, max_lag_wall_s: float = 0.05,
                 stamped: bool = False) -> None:
        super().__init__()
        self.transport = transport
        self.layout = layout
        self.core = core
        self.poll_s = poll_s
        self.max_lag_wall_s = max_lag_wall_s
        self.stamped = stamped
        self._protector = None if layout.crc == "none" else Profile1Protector(
            layout.data_id, layout.data_id_mode, layout.crc_byte, layout.counter_byte,
            (4 if layout.counter_nibble == "high" else 0) if layout.is_e2e_p01 else None)

    @property
    def max_lag_s(self) -> float:
        """Lateness allowance, simulated s (see :meth:`SimCore.due`)."""
        core = self.core
        lag = self.max_lag_wall_s * core.clock.warp
        if self.stamped:
            return lag
        return min(lag, self.layout.counter_modulus / core.sample_rate_hz / 4.0)


    def start(self) -> CanBroadcastDevice:
        self.transport.open()
        self._start_loop("can-gyro")
        return self

    def stop(self) -> None:
        self._stop_loop()
        self.transport.close()

    def _run(self) -> None:
        core = self.core
        silent = False
        # Wall time of the clock's instants from one pairing of the two clocks, never
        # from two readings a preempted thread takes 100 ms apart.
        stamps = BusClock(core.clock, core.clock.warp)
        next_sync = time.monotonic() + 10.0
        while not self._stop.wait(self.poll_s):
            readings = core.due(max_lag_s=self.max_lag_s)
            if core.link_down() or core.stalled():
                if not silent and core.link_down():
                    core.ledger.disconnects += 1
                silent = core.link_down()
                core.lose(readings)
                continue
            silent = False
            if time.monotonic() >= next_sync:
                stamps.sync()  # (the wall clock may be slewed: pair them again now and then)
                next_sync = time.monotonic() + 10.0
            for reading in readings:
                # Stamp each frame with the wall time it fell due: a real node sends on
                # schedule, this thread sends in bursts.
                stamp = stamps.wall(core.due_time(reading.counter))
                for frame in self.layout.from_reading(reading):
                    fault = core.fault_for(reading.counter)
                    # (without the E2E CRC only the CAN controller's own CRC-15 sees a
                    # corrupted frame: it never reaches the station)
                    if fault == "drop" or fault == "corrupt" and self._protector is None:
                        continue
                    self.transport.send(frame.arbitration_id,
                                        self._frame_data(frame, reading.counter, fault), stamp)

    def _frame_data(self, frame: CanFrameValues, sample_index: int, fault: str | None
                    ) -> bytes:
        """The data bytes of one frame of sample ``sample_index``, E2E protected, and a
        bit flipped after the protection for a ``corrupt`` fault."""
        data = bytearray(self.layout.encode(frame))
        if self._protector is not None:
            self._protector.protect(data, sample_index, frame.counter)
        if fault == "corrupt":
            data[self.layout.crc_byte ^ 1] ^= 0x01
        return bytes(data)


def broadcast_latency_s(layout: CanFrameLayout, sample_rate_hz: float, warp: float) -> float:
    """Longest a :class:`CanBroadcastDevice` (default loop) sends a frame after its sample
    fell due, simulated s: its loop period and lateness allowance."""
    return 0.002 * warp + min(0.05 * warp, layout.counter_modulus / sample_rate_hz / 4.0)
