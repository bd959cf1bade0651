"""Adapter for a CANopen rate gyro (or IMU): SDO configuration, NMT start, TPDO reception,
heartbeat supervision (canopen's ``RemoteNode`` over an injected python-can bus)."""

from __future__ import annotations

import queue
import time
from collections.abc import Callable
from pathlib import Path

import canopen

from devices.batching import BatchBuilder, BusClock
from devices.codecs.base import Reading
from devices.errors import DeviceDisconnectedError, DeviceProtocolError
from devices.gaps import CounterTracker
from devices.protocols import ACCEL_AXIS_NAMES, DeviceDescription, SampleBatch
from devices.resolution import CANOPEN_DEFAULT_SCALE_DEG_S
from devices.transports.can import CanTransport
from devices.transports.canopen import canopen_network

COUNTER_MODULUS = 65536
#: (TPDO number, mapped objects) the adapter writes over SDO.
TPDO_MAPPING: tuple[tuple[int, tuple[int, ...]], ...] = (
    (1, (0x2000, 0x2001)),            # rate X, rate Y
    (2, (0x2002, 0x2005, 0x2004)),    # rate Z, sample counter, temperature
)
#: (TPDO number, mapped objects) of an IMU's accelerometers, mapped with ``accel``: each
#: sample's TPDO3 and TPDO4 come before its TPDO2 (which closes the sample).
ACCEL_TPDO_MAPPING: tuple[tuple[int, tuple[int, ...]], ...] = (
    (3, (0x2007, 0x2008)),            # accel X, accel Y
    (4, (0x2009,)),                   # accel Z
)


class CanopenRateSource:
    """A rate source from a CANopen node described by an EDS.

    :meth:`open` waits for the node's heartbeat, writes over SDO the heartbeat time
    (0x1017), the output rate (0x2006) and the TPDO1/TPDO2 mapping with event-timer
    transmission, reads the rate scale (0x2003) and the serial number (0x1018:4), and
    starts the node with NMT. :meth:`read` pairs TPDO1 with the following TPDO2 (CAN
    keeps one sender's frames in order; TPDO2 holds the sample counter) and reports the
    node lost when no heartbeat came for ``heartbeat_timeout_s``.

    Parameters
    ----------
    transport : CanTransport
        The bus (opened by :meth:`open`).
    node_id : int
        CANopen node id.
    eds : str or Path
        The node's EDS file.
    sample_rate_hz : float
        Output rate to configure, Hz.
    model : str
        For :meth:`describe`.
    heartbeat_ms : int
        Producer heartbeat time to configure, ms (wall clock).
    heartbeat_timeout_s : float
        Node-loss limit, wall s (default three heartbeats).
    clock : callable
        Station clock, s.
    clock_scale : float
        Clock seconds per wall second (a simulation's time warp).
    sync : bool
        Synchronous TPDOs (transmission type 1) driven by a SYNC producer the adapter
        runs at the sample rate, instead of event-timer TPDOs (type 254).
    accel : bool
        An IMU: also map TPDO3/TPDO4 (:data:`ACCEL_TPDO_MAPPING`, accelerations times the
        Accel scale 0x200A in m/s^2 per LSB); a sample then needs all four TPDOs.
    """

    def __init__(self, transport: CanTransport, node_id: int, eds: str | Path, *,
                 sample_rate_hz: float, model: str = "CANopen gyro", heartbeat_ms: int = 50,
                 heartbeat_timeout_s: float | None = None,
                 clock: Callable[[], float] = time.monotonic, clock_scale: float = 1.0,
                 sync: bool = False, accel: bool = False) -> None:
        self.transport = transport
        self.accel = accel
        self.node_id = node_id
        self.eds = str(eds)
        self.sample_rate_hz = sample_rate_hz
        self.model = model
        self.heartbeat_ms = heartbeat_ms
        self.heartbeat_timeout_s = heartbeat_timeout_s or 3 * heartbeat_ms / 1000.0
        self.clock = clock
        self.clock_scale = clock_scale
        self.sync = sync
        self.network: canopen.Network | None = None
        self.node: canopen.RemoteNode | None = None
        self._serial = "unknown"
        self._scale = 1.0
        self._accel_scale = 1.0
        self._queue: queue.SimpleQueue[tuple[int, tuple[int, ...], float]] = queue.SimpleQueue()
        #: TPDO1 (and an IMU's TPDO3, TPDO4) values since the last TPDO2, by TPDO number.
        self._since: dict[int, list[tuple[int, ...]]] = {1: [], 3: [], 4: []}
        self._last_counter: int | None = None
        self._last_heartbeat = 0.0
        self._lost = False
        self._bus_clock = BusClock(clock, clock_scale)
        #: PDOs stamped before this (clock s) are not read (see :meth:`quiet_until_now`).
        self._not_before_s = -float("inf")
        self._builder = BatchBuilder(
            3, CounterTracker(COUNTER_MODULUS, sample_rate_hz,
                              timing_uncertainty_s=0.05 * clock_scale),
            has_device_time=False, has_temperature=True, n_accel_axes=3 if accel else 0)

    @property
    def mapping(self) -> tuple[tuple[int, tuple[int, ...]], ...]:
        """The TPDOs this adapter maps: a gyro's two, and an IMU's accelerometer two."""
        return TPDO_MAPPING + (ACCEL_TPDO_MAPPING if self.accel else ())

    def describe(self) -> DeviceDescription:
        return DeviceDescription(
            model=self.model, serial_number=self._serial, protocol="canopen",
            transport="canopen", axes=("x", "y", "z"), sample_rate_hz=self.sample_rate_hz,
            has_counter=True, counter_modulus=COUNTER_MODULUS, has_device_time=False,
            has_temperature=True,
            settings=(*self.transport.settings, ("node_id", str(self.node_id)),
                      ("eds", Path(self.eds).name)),
            accel_axes=ACCEL_AXIS_NAMES if self.accel else (),
            lsb_deg_s=abs(CANOPEN_DEFAULT_SCALE_DEG_S if self.node is None else self._scale))

    # -- connection --------------------------------------------------------------------
    def open(self) -> None:
        """Connect, configure over SDO and start the node (see the class docstring).

        Raises
        ------
        DeviceDisconnectedError
            No heartbeat from the node.
        DeviceProtocolError
            The node refused an SDO transfer.
        """
        self.transport.open()
        self.network = canopen_network(self.transport)
        node = canopen.RemoteNode(self.node_id, self.eds)
        self.network.add_node(node)
        self.node = node
        node.nmt.add_heartbeat_callback(self._on_heartbeat)
        node.sdo.RESPONSE_TIMEOUT = 0.5
        try:
            node.sdo.upload(0x1000, 0)  # presence: a node answers SDO with no heartbeat
        except canopen.SdoCommunicationError as exc:
            self.close()
            raise DeviceDisconnectedError(f"CANopen node {self.node_id} does not answer: "
                                          f"{exc}") from exc
        try:
            self._configure(node)
            node.nmt.wait_for_heartbeat(timeout=max(1.0, 4 * self.heartbeat_timeout_s))
        except (canopen.SdoAbortedError, canopen.SdoCommunicationError) as exc:
            self.close()
            raise DeviceProtocolError(f"CANopen node {self.node_id} SDO: {exc}") from exc
        except canopen.nmt.NmtError as exc:
            self.close()
            raise DeviceDisconnectedError(f"CANopen node {self.node_id}: {exc}") from exc
        node.nmt.state = "OPERATIONAL"
        if self.sync:
            self.network.sync.start(1.0 / (self.sample_rate_hz * self.clock_scale))
        self._last_heartbeat = time.monotonic()
        self._bus_clock.sync()
        self._builder.event("connect", self.clock())

    def _configure(self, node: canopen.RemoteNode) -> None:
        node.nmt.state = "PRE-OPERATIONAL"
        node.sdo[0x1017].raw = self.heartbeat_ms
        node.sdo[0x2006].raw = round(self.sample_rate_hz)
        self._scale = float(node.sdo[0x2003].raw)
        self._serial = str(node.sdo[0x1018][4].raw)
        if self.accel:
            self._accel_scale = float(node.sdo[0x200A].raw)
        node.tpdo.read()
        for number, objects in self.mapping:
            pdo = node.tpdo[number]
            pdo.clear()
            for index in objects:
                pdo.add_variable(index)
            pdo.trans_type = 1 if self.sync else 254
            pdo.event_timer = 0 if self.sync else max(1, round(1000.0 / self.sample_rate_hz))
            pdo.enabled = True
        node.tpdo.save()
        for number, _ in self.mapping:
            node.tpdo[number].add_callback(self._on_tpdo)

    def close(self) -> None:
        if self.network is not None:
            self.network.sync.stop()
            self.network.disconnect()
        self.network = self.node = None
        self.transport.bus = None

    # -- callbacks (notifier thread) ------------------------------------------------------
    def _on_heartbeat(self, state: int) -> None:
        self._last_heartbeat = time.monotonic()

    def _on_tpdo(self, pdo: canopen.pdo.PdoMap) -> None:
        number = ((pdo.cob_id or 0) - self.node_id) // 0x100  # 0x180 + node: TPDO1 .. 0x480: 4
        self._queue.put((number, tuple(int(v.raw) for v in pdo.map), pdo.timestamp or 0.0))

    # -- reading -------------------------------------------------------------------------
    def read(self, timeout_s: float = 0.1) -> SampleBatch:
        """Samples received since the last call (see :meth:`RateSource.read`)."""
        if self.network is None:
            self.open()
        # The PDOs there once the first came, not those that keep coming meanwhile: a
        # host too slow for the node's PDO rate still returns, and says so by its gaps.
        try:
            items = [self._queue.get(timeout=timeout_s)]
        except queue.Empty:
            items = []
        else:
            items += [self._queue.get_nowait() for _ in range(self._queue.qsize())]
        for item in items:
            if self._bus_clock(item[2]) >= self._not_before_s:
                self._take(*item)
        wall = time.monotonic()
        if wall - self._last_heartbeat > self.heartbeat_timeout_s:
            if not self._lost:
                self._lost = True
                self._builder.event("disconnect", self.clock(), detail="heartbeat lost")
                raise DeviceDisconnectedError(f"CANopen node {self.node_id}: no heartbeat for "
                                              f"{self.heartbeat_timeout_s} s")
        elif self._lost:
            self._lost = False
            self._builder.event("reconnect", self.clock(), detail="heartbeat back")
        return self._builder.take(self.clock())

    def quiet_until_now(self) -> None:
        """The station held a simulated node until now (the run starts): PDOs stamped
        before now are not read (see :meth:`devices.can_raw.CanRateSource.quiet_until_now`:
        the recorder's nodes start held, so there are none; less half a sample period,
        as there)."""
        self._not_before_s = self.clock() - 0.5 / self.sample_rate_hz

    def limit_rates(self, limit_deg_s: float | None) -> None:
        """Samples beyond this magnitude (deg/s, any axis) are bad samples."""
        self._builder.rate_limit_deg_s = limit_deg_s

    def limit_accel(self, limit_m_s2: float | None) -> None:
        """Samples whose acceleration exceeds this magnitude (m/s^2, any axis) are bad
        samples (the product profile's accelerometer range; None: no limit)."""
        self._builder.accel_limit_m_s2 = limit_m_s2

    def _take(self, number: int, values: tuple[int, ...], stamp: float) -> None:
        if number != 2:
            self._since.setdefault(number, []).append(values)
            return
        z, counter, temp = values
        since, self._since = self._since, {1: [], 3: [], 4: []}
        advance = (
            1 if self._last_counter is None else (counter - self._last_counter) % COUNTER_MODULUS
        )
        self._last_counter = counter
        needed = (1, 3, 4) if self.accel else (1,)
        if any(len(since[n]) != advance for n in needed):
            return  # ambiguous or incomplete sample: dropped, counted as a gap
        first = since[1][-1]
        accel = None
        if self.accel:
            a = self._accel_scale
            accel = (since[3][-1][0] * a, since[3][-1][1] * a, since[4][-1][0] * a)
        now = self.clock()
        sent = self._bus_clock(stamp)
        self._builder.add(Reading((first[0] * self._scale, first[1] * self._scale,
                                   z * self._scale), counter, 0, None, temp / 100.0, accel),
                          now, sent)
