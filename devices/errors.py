"""Exceptions raised by the devices layer.

Each one also inherits the builtin that fits (python-can's ``CanTimeoutError(CanError,
TimeoutError)`` pattern), so callers that only know the builtins still catch it.
"""

from __future__ import annotations


class DeviceError(Exception):
    """Base class of every error the devices package raises on purpose."""


class CodecError(DeviceError, ValueError):
    """A frame or reading cannot be encoded or decoded; the message says why."""


class CrcError(CodecError):
    """A frame's CRC or checksum does not match its contents."""


class FrameError(CodecError):
    """Bytes that do not form a frame of the protocol (bad length, header, layout)."""


class DeviceTimeoutError(DeviceError, TimeoutError):
    """The device sent nothing valid for longer than the allowed silence."""


class DeviceDisconnectedError(DeviceError, ConnectionError):
    """The transport to the device is lost (port gone, bus down, node silent)."""


class DeviceConfigurationError(DeviceError, ValueError):
    """The device or its settings do not fit (unknown protocol, bad URL, bad profile)."""


class DeviceProtocolError(DeviceError):
    """The device answered, but not as the protocol says (bad ack, SDO abort)."""


class ExposedBusWarning(UserWarning):
    """A simulated or served bus opened beyond this host (``bind=all``): anyone on the
    network can send it frames."""


class NoRateError(DeviceConfigurationError):
    """The device streams, but no message carries the rate the station reads (an Xsens
    MTi not configured to output its RateOfTurn): retrying cannot help."""
