"""A simulated gyro broadcasting its rates in raw CAN frames on a python-can bus."""

from __future__ import annotations

import time

from devices.codecs.can_frame import CanFrameLayout
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
        The frame layout (its encoder makes the frames).
    core : SimCore
        Signal, schedule, faults and ledger.
    poll_s : float
        Wall-clock period of the device loop, s.
    """

    def __init__(self, transport: CanTransport, layout: CanFrameLayout, core: SimCore, *,
                 poll_s: float = 0.002) -> None:
        super().__init__()
        self.transport = transport
        self.layout = layout
        self.core = core
        self.poll_s = poll_s

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
        while not self._stop.wait(self.poll_s):
            readings = core.due()
            if core.link_down() or core.stalled():
                if not silent and core.link_down():
                    core.ledger.disconnects += 1
                silent = core.link_down()
                core.lose(readings)
                continue
            silent = False
            wall, now = time.time(), core.clock()
            for reading in readings:
                # Stamp each frame with the wall time it fell due: a real node sends on
                # schedule, this thread sends in bursts.
                stamp = wall - (now - core.due_time(reading.counter)) / core.clock.warp
                for frame in self.layout.from_reading(reading):
                    fault = core.fault_for(reading.counter)
                    if fault == "drop":
                        continue
                    data = bytearray(self.layout.encode(frame))
                    if fault == "corrupt":
                        data[self.layout.crc_byte ^ 1] ^= 0x01
                    self.transport.send(frame.arbitration_id, bytes(data), stamp)
