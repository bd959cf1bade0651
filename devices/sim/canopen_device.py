"""A simulated CANopen rate gyro (or IMU): a canopen ``LocalNode`` built from the shipped
EDS.

The node answers SDO, follows NMT, sends heartbeats (0x1017) and, when OPERATIONAL,
transmits TPDO1 (rate X, Y) and TPDO2 (rate Z, sample counter, temperature) for each
sample (an IMU whose master enabled TPDO3 and TPDO4 sends its accelerations X, Y and Z
in them first, at the Accel scale 0x200A), with whatever mapping the master wrote over
SDO: on its own schedule when the TPDOs are event-driven (transmission type 254/255), or
one sample per SYNC (0x80) when they are synchronous (transmission type 1..240). A
disconnect unplugs it: no heartbeat, no PDO, while it keeps sampling (its counter runs
on).

canopen pitfall: a LocalNode's PDO payload is the PDO map's own copy; values are set
through ``node.tpdo[n][name].raw``, writing the SDO object would not change what is sent.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Mapping
from pathlib import Path

import canopen
from canopen.sdo import SdoArray, SdoRecord, SdoVariable

from devices.codecs.base import Reading
from devices.sim.faults import SimCore
from devices.sim.loop import DeviceLoop
from devices.transports.can import CanTransport
from devices.transports.canopen import canopen_network

#: The EDS shipped with the project.
GYRO_EDS = Path(__file__).resolve().parent.parent / "eds" / "gyro.eds"
_OPERATIONAL = "OPERATIONAL"


class CanopenGyroNode(DeviceLoop):
    """A LocalNode on its own bus connection, served from a background thread.

    Parameters
    ----------
    transport : CanTransport
        Its bus (a second ``virtual`` bus on the station's channel).
    core : SimCore
        Signal, schedule, faults and ledger.
    node_id : int
        CANopen node id.
    serial_number : int
        Identity object 0x1018:4.
    poll_s : float
        Wall-clock period of the device loop, s.
    """

    def __init__(self, transport: CanTransport, core: SimCore, *, node_id: int = 5,
                 serial_number: int = 1, poll_s: float = 0.002) -> None:
        super().__init__()
        self.transport = transport
        self.core = core
        self.node_id = node_id
        self.poll_s = poll_s
        self.node = canopen.LocalNode(node_id, str(GYRO_EDS))
        self._entry(0x1018, 4).raw = serial_number
        self.node.add_write_callback(self._on_write)
        self.network: canopen.Network | None = None
        self._remap = threading.Event()
        self._syncs: queue.SimpleQueue[float] = queue.SimpleQueue()
        self._scale = float(self._entry(0x2003).raw)
        self._accel_scale = float(self._entry(0x200A).raw)

    def _entry(self, index: int, subindex: int | None = None) -> SdoVariable:
        """The node's own object-dictionary variable at ``index`` (and ``subindex``)."""
        entry = self.node.sdo[index]
        if subindex is not None:
            assert isinstance(entry, SdoRecord | SdoArray)
            entry = entry[subindex]
        assert isinstance(entry, SdoVariable)
        return entry

    def _on_write(self, index: int, subindex: int, od: object, data: bytes) -> None:
        if 0x1800 <= index <= 0x1A03:
            self._remap.set()
        if index == 0x2006:
            self._remap.set()

    def _on_sync(self, can_id: int, data: bytearray, timestamp: float) -> None:
        self._syncs.put(timestamp)

    def _synchronous(self) -> bool:
        return 1 <= (self.node.tpdo[1].trans_type or 0) <= 240

    def start(self) -> CanopenGyroNode:
        """Connect, boot (boot-up message, PRE-OPERATIONAL) and start the device thread."""
        self.transport.open()
        self.network = canopen_network(self.transport)
        self.network.add_node(self.node)
        self.network.subscribe(0x80, self._on_sync)
        self.node.tpdo.read(from_od=True)
        self.node.nmt.send_command(0x81)  # reset: boot-up message
        self.node.nmt.send_command(0x80)  # PRE-OPERATIONAL, heartbeat per 0x1017
        self._start_loop("canopen-gyro")
        return self

    def stop(self) -> None:
        """Stop the thread, the heartbeat and the bus."""
        self._stop_loop()
        self.node.nmt.stop_heartbeat()
        if self.network is not None:
            self.network.disconnect()  # shuts the bus down too
        self.transport.bus = None

    def _apply_configuration(self) -> None:
        self._remap.clear()
        self.node.tpdo.read(from_od=False)  # the mapping the master wrote over SDO
        rate = float(self._entry(0x2006).raw)
        if rate > 0 and rate != self.core.sample_rate_hz:
            self.core.retime(rate)

    def _send(self, reading_index: int, values: Mapping[str, float], tpdo: int) -> None:
        pdo = self.node.tpdo[tpdo]
        if not pdo.enabled:
            return
        for var in pdo.map:
            if var.name in values:
                var.raw = int(values[var.name])
        # Dropped, or corrupted: the CAN controller's own CRC rejects a corrupted frame
        # on the wire, so the station never sees it either way.
        if self.core.fault_for(reading_index) is not None:
            return
        assert self.network is not None
        self.network.send_message(pdo.cob_id, bytes(pdo.data))

    def _sync_readings(self) -> list[Reading]:
        """One sample per SYNC received (none while unplugged: it hears no SYNC).

        The SYNCs waiting when the pass starts, all sampled at once: a thread the host
        starves (each SYNC slower to handle than the SYNC period) would otherwise take
        SYNCs as fast as they come and never get to send a PDO.
        """
        n = self._syncs.qsize()
        for _ in range(n):
            self._syncs.get_nowait()
        if n == 0 or self.core.link_down() or self.node.nmt.state != _OPERATIONAL:
            return []
        return self.core.next_readings(n)

    def _run(self) -> None:
        core = self.core
        unplugged = False
        while not self._stop.wait(self.poll_s):
            if self._remap.is_set():
                self._apply_configuration()
            # A node sends on its schedule: samples overdue by more than 50 ms of wall
            # time (a starved thread) are lost, never sent late.
            readings = (self._sync_readings() if self._synchronous()
                        else core.due(max_lag_s=0.05 * core.clock.warp))
            if core.link_down():
                if not unplugged:
                    unplugged = True
                    core.ledger.disconnects += 1
                    self.node.nmt.stop_heartbeat()
                core.lose(readings)
                continue
            if unplugged:
                unplugged = False
                self.node.nmt.start_heartbeat(int(self._entry(0x1017).raw))
            if self.node.nmt.state != _OPERATIONAL:
                core.lose(readings)
                continue
            for r in readings:
                values = {"Rate X": round(r.rate_deg_s[0] / self._scale),
                          "Rate Y": round(r.rate_deg_s[1] / self._scale),
                          "Rate Z": round(r.rate_deg_s[2] / self._scale),
                          "Sample counter": r.counter % 65536,
                          "Temperature": round((r.temperature_c or 0.0) * 100)}
                if r.accel_m_s2 is not None:
                    values |= {f"Accel {c}": round(a / self._accel_scale)
                               for c, a in zip("XYZ", r.accel_m_s2, strict=True)}
                for tpdo in (1, 3, 4, 2):  # TPDO2, with the counter, closes the sample
                    self._send(r.counter, values, tpdo)
