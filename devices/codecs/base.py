"""Shared shapes of the pure codecs: one reading, one decode result, the codec protocol."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Generic, Protocol, TypeVar

F = TypeVar("F")


@dataclass(frozen=True)
class Reading:
    """One sample as the station sees it, in physical units.

    Attributes
    ----------
    rate_deg_s : tuple of float
        Rate per axis, deg/s.
    counter : int
        Device sample counter as sent (wrapping).
    status : int
        Validity by the protocol's own status bits: 0 where the device says the sample
        is good, non-zero where it flags the sample (or a part of it) as not valid. The
        sense is the same for every protocol (docs/hdf5-layout.md), whatever the sense of
        the device's own word.
    device_time_s : float or None
        Device time stamp, s.
    temperature_c : float or None
        Sensor temperature, degC.
    accel_m_s2 : tuple of float or None
        Specific force per accelerometer axis, m/s^2 (None: the frame carries none, or
        the codec was told to leave the accelerometers out).
    device_status : int or None
        The device's status word exactly as sent (None: the protocol carries none).
    """

    rate_deg_s: tuple[float, ...]
    counter: int
    status: int = 0
    device_time_s: float | None = None
    temperature_c: float | None = None
    accel_m_s2: tuple[float, ...] | None = None
    device_status: int | None = None


@dataclass(frozen=True)
class DecodeResult(Generic[F]):
    """What a decoder made of a byte buffer.

    Attributes
    ----------
    frames : tuple
        Every frame whose CRC or checksum verified, in stream order.
    rest : bytes
        The unconsumed tail (a frame not yet complete); prepend it to the next bytes.
    crc_failures : int
        Candidate frames (a header at a position) whose CRC did not match.
    discarded_bytes : int
        Bytes skipped while resynchronizing (garbage and failed candidates).
    """

    frames: tuple[F, ...]
    rest: bytes
    crc_failures: int
    discarded_bytes: int


class StreamCodec(Protocol[F]):
    """A byte-stream protocol: decoder, its exact inverse, and the physical mapping."""

    #: Protocol key used in URLs and descriptions.
    name: str
    #: Wrap of the device counter.
    counter_modulus: int
    n_axes: int
    has_device_time: bool
    has_temperature: bool
    #: Accelerometer axes each reading carries (0: gyro-only frames, or accelerometers off).
    n_accel_axes: int
    #: Measurement range of the accelerometers, m/s^2 (None: unknown or none).
    accel_range_m_s2: float | None

    def decode(self, data: bytes) -> DecodeResult[F]:
        """Frames found in ``data``; never raises on any byte string."""

    def encode(self, frame: F) -> bytes:
        """Bytes of ``frame``: ``decode(encode(f)).frames == (f,)``."""

    def to_reading(self, frame: F) -> Reading | None:
        """Physical values of a frame (None: a frame that carries no reading, as an
        acknowledgement or a status message)."""

    def from_reading(self, reading: Reading) -> F:
        """The frame a device would send for ``reading`` (quantized to the protocol)."""

    def greeting(self) -> bytes:
        """Bytes the host sends after opening the port (commands), or ``b""``."""

    def acknowledges(self, frame: F) -> bool:
        """Whether ``frame`` is the device's answer that ends the greeting."""

    def answer(self, frame: F) -> tuple[F, bool] | None:
        """Device side: the reply to a host frame and whether to stream after it, or None."""


class StreamingOnPowerUp:
    """Handshake of a device that streams on power-up and takes no commands."""

    def greeting(self) -> bytes:
        """Nothing to send."""
        return b""

    def acknowledges(self, frame: object) -> bool:
        """No acknowledgement is awaited."""
        return False

    def answer(self, frame: object) -> None:
        """No command is answered."""
        return None


def scan_frames(
    data: bytes,
    header: bytes,
    frame_length: Callable[[bytes, int], int | None],
    parse: Callable[[bytes], F | None],
) -> DecodeResult[F]:
    """Resynchronizing scanner shared by the serial codecs.

    Looks for ``header`` at each position; ``frame_length(data, pos)`` gives the frame
    length at a candidate (None: not enough bytes yet to know; 0: not a frame), and
    ``parse(frame_bytes)`` returns the frame or None when its CRC fails. A failed
    candidate advances one byte, so a real frame that started inside it is still found.

    Parameters
    ----------
    data : bytes
        Bytes received (the previous call's ``rest`` first).
    header : bytes
        Synchronization pattern every frame starts with.
    frame_length, parse : callable
        Protocol-specific length and checked parse.

    Returns
    -------
    DecodeResult
    """
    data = bytes(data)
    frames: list[F] = []
    crc_failures = 0
    discarded = 0
    pos = 0
    n = len(data)
    while True:
        found = data.find(header, pos)
        if found < 0:
            # Keep a trailing partial header: it may complete with the next bytes.
            keep = 0
            for k in range(min(len(header) - 1, n - pos), 0, -1):
                if data.endswith(header[:k]):
                    keep = k
                    break
            discarded += n - pos - keep
            return DecodeResult(tuple(frames), data[n - keep:], crc_failures, discarded)
        discarded += found - pos
        pos = found
        length = frame_length(data, pos)
        if length is None or (length and pos + length > n):
            return DecodeResult(tuple(frames), data[pos:], crc_failures, discarded)
        frame = parse(data[pos:pos + length]) if length else None
        if frame is None:
            crc_failures += 1 if length else 0
            discarded += 1
            pos += 1
            continue
        frames.append(frame)
        pos += length
