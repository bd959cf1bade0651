"""What the station knows about a gyro: the rate-source protocol and its records.

The recorder and every other consumer talk to a device only through :class:`RateSource`
(bluesky's small ``typing.Protocol`` capabilities). A source describes itself once
(:class:`DeviceDescription`) and then yields :class:`SampleBatch` es: rates in deg/s,
the device's own sample counter, device time and temperature where the protocol carries
them, status flags, the station receive time, and every gap detected with its exact
number of missing samples.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

#: How a gap's missing-sample count was obtained (written to the recorder's event log).
GapMethod = Literal["counter", "counter+elapsed", "device_time"]

EventKind = Literal["connect", "disconnect", "reconnect", "crc_error", "resync", "timeout",
                    "bad_sample"]

#: Accelerometer axis names of a three-axis IMU, in the column order of its accelerations:
#: not the gyros' names, so that no figure keyed by axis name stands for the other half's
#: (a CSV record's accel_* columns read the same; a bench's x, y, z match by last token).
ACCEL_AXIS_NAMES: tuple[str, ...] = ("accel_x", "accel_y", "accel_z")

#: :attr:`SampleBatch.device_status` (and the run file's ``device_status``) of a sample
#: that came with no status word (the protocol, or that message, carries none).
NO_DEVICE_STATUS = -1


@dataclass(frozen=True)
class DeviceDescription:
    """Static facts about a connected rate source.

    Attributes
    ----------
    model : str
        Product name (``"STIM300"``, ``"DSP-1750"``, a noise-model name for simulations).
    serial_number : str
        Unit serial number as the device or its URL reports it.
    protocol : str
        Protocol key (``"stim300"``, ``"kvh1750"``, ``"xbus"``, ``"can"``, ...).
    transport : str
        Transport key (``"serial"``, ``"can"``, ``"canopen"``, ``"modbus+tcp"``, ...).
    axes : tuple of str
        Axis names, in the column order of :attr:`SampleBatch.rate_deg_s`.
    rate_unit : str
        Always ``"deg/s"``: adapters convert from the wire unit.
    sample_rate_hz : float
        Nominal output data rate, Hz.
    has_counter : bool
        Whether the protocol carries a device sample counter.
    counter_modulus : int or None
        Samples per wrap of the device counter (128 for a KVH; a STIM300's counts its
        2000 Hz internal samples: 256 / (2000 / rate), 16 at 125 Hz), None if unbounded.
    has_device_time : bool
        Whether :attr:`SampleBatch.device_time_s` is filled.
    has_temperature : bool
        Whether :attr:`SampleBatch.temperature_c` is filled.
    temperature_unit, time_unit : str
        ``"degC"`` and ``"s"``.
    settings : tuple of (str, str)
        Transport settings as text (port, baud, bus, address) for the run metadata.
    accel_axes : tuple of str
        Accelerometer axis names, in the column order of :attr:`SampleBatch.accel_m_s2`;
        empty for a source that sends no accelerometer (a gyro, or an IMU whose protocol
        here carries only its gyros).
    accel_unit : str
        Always ``"m/s^2"``: adapters convert from the wire unit (g, mg, counts).
    lsb_deg_s, lsb_relative : float
        The step of the rate word on the link (:mod:`devices.resolution`): a fixed-point
        word's LSB, deg/s (STIM300 2^-14), or a floating-point word's step relative to its
        value (float32 2^-23); 0.0 where not known or not that kind of word.
    """

    model: str
    serial_number: str
    protocol: str
    transport: str
    axes: tuple[str, ...]
    sample_rate_hz: float
    has_counter: bool
    counter_modulus: int | None
    has_device_time: bool
    has_temperature: bool
    rate_unit: str = "deg/s"
    temperature_unit: str = "degC"
    time_unit: str = "s"
    settings: tuple[tuple[str, str], ...] = ()
    accel_axes: tuple[str, ...] = ()
    accel_unit: str = "m/s^2"
    lsb_deg_s: float = 0.0
    lsb_relative: float = 0.0

    @property
    def n_axes(self) -> int:
        """Number of rate axes."""
        return len(self.axes)


class MissingBounds:
    """The range of samples a gap may have lost, from ``missing_samples`` (the best count)
    and the optional ``missing_low``/``missing_high`` of the class it is mixed into."""

    missing_samples: int
    missing_low: int | None
    missing_high: int | None

    @property
    def low(self) -> int:
        """The fewest samples lost (``missing_samples`` when the count is exact)."""
        return self.missing_samples if self.missing_low is None else self.missing_low

    @property
    def high(self) -> int:
        """The most samples lost (``missing_samples`` when the count is exact)."""
        return self.missing_samples if self.missing_high is None else self.missing_high


@dataclass(frozen=True)
class Gap(MissingBounds):
    """Samples the device produced that never reached the station.

    Attributes
    ----------
    after_counter : int
        Unwrapped counter of the last sample received before the gap.
    missing_samples : int
        Number of samples lost: the best count (0 when only the timing leaves room for
        whole counter wraps lost unseen: ``missing_high`` says how many).
    method : GapMethod
        ``"counter"`` (counter difference alone), ``"counter+elapsed"`` (counter residue
        with the wrap count chosen from elapsed time and the nominal rate: long outages
        on a wrapping counter) or ``"device_time"``.
    receive_time_s : float
        Station time (s) at which the gap was detected.
    missing_low, missing_high : int or None
        The fewest and the most samples the evidence allows (they differ by whole
        counter wraps when the timing cannot decide the wrap count); None: exactly
        ``missing_samples``.
    """

    after_counter: int
    missing_samples: int
    method: GapMethod
    receive_time_s: float
    missing_low: int | None = None
    missing_high: int | None = None


@dataclass(frozen=True)
class DeviceEvent:
    """Something that happened on the link: a connect, a disconnect, CRC errors, a resync."""

    kind: EventKind
    receive_time_s: float
    count: int = 1
    detail: str = ""


def _empty_f64(*shape: int) -> NDArray[np.float64]:
    return np.empty(shape, dtype=np.float64)


@dataclass(frozen=True)
class SampleBatch:
    """Samples read from a rate source in one call (possibly none).

    Attributes
    ----------
    rate_deg_s : ndarray, shape (n, n_axes)
        Angular rate, deg/s.
    counter : ndarray of int64, shape (n,)
        Device sample counter, unwrapped (monotonic across wraps and gaps); its
        differences are 1 except across a gap listed in :attr:`gaps`.
    receive_time_s : ndarray of float64, shape (n,)
        Station time (s, the adapter's clock) at which each sample was received.
    status : ndarray of uint32, shape (n,)
        Validity by the protocol's own status bits, one convention for every protocol:
        0 where the device says the sample is good, non-zero where it flags the sample
        (or a part of it, the accelerations too) as not valid
        (:attr:`devices.codecs.base.Reading.status`).
    device_time_s : ndarray or None
        Device time stamp (s), None when the protocol has none.
    temperature_c : ndarray or None
        Sensor temperature (degC), None when the protocol has none.
    gaps : tuple of Gap
        Gaps detected before or inside this batch.
    events : tuple of DeviceEvent
        Link events since the previous batch (CRC errors, resyncs, reconnects).
    crc_errors : int
        Frames rejected for a bad CRC or checksum since the previous batch.
    accel_m_s2 : ndarray, shape (n, n_accel_axes), or None
        Specific force per accelerometer axis, m/s^2, one row per rate row (the same
        datagram, counter and times); None when the source sends no accelerometer.
    device_status : ndarray of int64, shape (n,), or None
        The device's status word of each sample exactly as sent, -1 where the sample
        came with none (:data:`NO_DEVICE_STATUS`); None: no sample of the batch came with
        one.
    """

    rate_deg_s: NDArray[np.float64]
    counter: NDArray[np.int64]
    receive_time_s: NDArray[np.float64]
    status: NDArray[np.uint32]
    device_time_s: NDArray[np.float64] | None = None
    temperature_c: NDArray[np.float64] | None = None
    gaps: tuple[Gap, ...] = ()
    events: tuple[DeviceEvent, ...] = ()
    crc_errors: int = 0
    units: tuple[tuple[str, str], ...] = field(
        default=(("rate_deg_s", "deg/s"), ("receive_time_s", "s"), ("device_time_s", "s"),
                 ("temperature_c", "degC"), ("counter", "1"), ("status", "1"),
                 ("accel_m_s2", "m/s^2"), ("device_status", "1")),
    )
    accel_m_s2: NDArray[np.float64] | None = None
    device_status: NDArray[np.int64] | None = None

    def __len__(self) -> int:
        return int(self.counter.shape[0])

    @property
    def missing_samples(self) -> int:
        """Total samples declared missing by this batch's gaps."""
        return sum(g.missing_samples for g in self.gaps)


@runtime_checkable
class RateSource(Protocol):
    """A gyro the station can record: the only device interface the station uses."""

    def open(self) -> None:
        """Connect to the device (and configure it where the protocol needs to)."""

    def close(self) -> None:
        """Release the transport; safe to call twice."""

    def describe(self) -> DeviceDescription:
        """Static facts: model, serial number, axes, units, rate, counter/time/temperature."""

    def read(self, timeout_s: float = 0.1) -> SampleBatch:
        """Samples received since the last call, waiting at most ``timeout_s`` (s) for some.

        Keep ``timeout_s`` below ``counter_modulus / sample_rate_hz``: a read that waits
        out a whole counter period could hide a wrap from the gap count (docs/devices.md).

        Raises
        ------
        DeviceDisconnectedError
            The link was lost; the next ``read`` tries to reconnect.
        DeviceTimeoutError
            Nothing valid arrived for longer than the adapter's silence limit.
        """


@runtime_checkable
class RateLimited(Protocol):
    """A rate source that screens its samples against a measurement range (what the
    recorder sets from the product profile): beyond it, a sample is a bad sample."""

    def limit_rates(self, limit_deg_s: float | None) -> None:
        """Set the range, deg/s on any axis (None: no limit)."""


@runtime_checkable
class AccelLimited(Protocol):
    """An IMU source that screens its accelerations against the accelerometer range
    (the product profile's ``accel_range_g``): beyond it, a sample is a bad sample."""

    def limit_accel(self, limit_m_s2: float | None) -> None:
        """Set the range, m/s^2 on any axis (None: the protocol's own range)."""


@runtime_checkable
class HeldQuiet(Protocol):
    """A rate source told that its device sent nothing until now (the station held it:
    a simulated unit before the run starts), which bounds the send times of what comes
    next."""

    def quiet_until_now(self) -> None:
        """Nothing was sent before this moment."""


@runtime_checkable
class PowerSwitch(Protocol):
    """A unit's supply that the station switches (a relay output, a bench supply's output)."""

    def open(self) -> None:
        """Connect to the switch."""

    def close(self) -> None:
        """Release the transport; safe to call twice (the output keeps its state)."""

    def set_power(self, on: bool) -> float:
        """Switch the output on or off and confirm it took the new state; returns when it
        switched, as well as the station can tell (s since the epoch: the middle of the
        command's exchange), the instant a turn-on time counts from.

        Raises
        ------
        DeviceDisconnectedError
            The switch cannot be reached.
        DeviceProtocolError
            It refused the command, or reads back another state.
        """

    def is_powered(self) -> bool:
        """Whether the output is on now."""

    def describe(self) -> str:
        """Where the switch is, for the run's records
        (``modbus+tcp 10.0.0.5:502 unit 1 coil 3``)."""


@runtime_checkable
class TemperatureChamber(Protocol):
    """A temperature chamber the station sets and reads (degC)."""

    def open(self) -> None:
        """Connect to the chamber's controller."""

    def close(self) -> None:
        """Release the transport; safe to call twice (the chamber keeps its set point)."""

    def set_temperature(self, temperature_c: float) -> None:
        """Command a new set point, degC, and confirm the controller holds it.

        Raises
        ------
        DeviceDisconnectedError
            The controller cannot be reached.
        DeviceProtocolError
            It refused the set point, or reads back another one.
        CodecError
            A set point outside the chamber's range.
        """

    def setpoint_c(self) -> float:
        """The set point the controller holds, degC."""

    def temperature_c(self) -> float:
        """The measured air temperature, degC."""

    def describe(self) -> str:
        """Where the chamber is, for the run's records."""


@runtime_checkable
class Simulated(Protocol):
    """A unit whose device is simulated (a ``sim+`` URL), as the recorder may use it: held
    until the recorder listens, ended on a sample index, and counted by the simulator
    itself. Real hardware offers none of this; the recorder asks ``isinstance(unit,
    Simulated)`` (an optional capability, as bluesky's ``Pausable``)."""

    def pause(self) -> None:
        """Hold sampling (nothing is generated, its time line stands)."""

    def resume(self, run_for_s: float | None = None) -> None:
        """Release the hold: sampling starts (again) now; with ``run_for_s``, it ends
        that long (s of its clock) after this release."""

    def clear_faults(self) -> None:
        """Turn the injected faults off (a clean end of a run)."""

    def finish_after(self, n_samples: int | None) -> int | None:
        """Generate no sample beyond the first ``n_samples`` (None: go on); its time line
        goes on, so that a counter sees no silence it cannot explain. Returns the count it
        ends on: fewer where :meth:`resume`'s ``run_for_s`` end comes first (None: no end)."""

    def samples_sent(self) -> int:
        """Samples the simulated device has generated so far (its own count).

        Raises
        ------
        DeviceError
            The simulator is gone (its process ended).
        """
