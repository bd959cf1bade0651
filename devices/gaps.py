"""Counting lost samples from a wrapping device counter, elapsed time and nominal rate.

A wrapping counter (8-bit on a STIM300, 0..127 on a KVH) alone cannot count an outage
longer than its period: :class:`CounterTracker` takes the counter residue as exact and
chooses the number of wraps from the elapsed time and the nominal rate: the device's own
time stamps where the protocol has them; else a send-time estimate (a bus's frame time
stamps: CAN, CANopen) or the adapter's own estimate (a byte stream's proven silence, see
:class:`devices.stream.StreamRateSource`). Each gap says how it was counted.
"""

from __future__ import annotations

import math

from devices.protocols import Gap, GapMethod


class CounterTracker:
    """Unwraps a device counter and reports gaps with their exact missing-sample counts.

    Parameters
    ----------
    modulus : int
        Counter wrap (256, 128, 65536, ...).
    sample_rate_hz : float
        Nominal sample rate, Hz (in the clock's time base: a time-warped simulation
        runs its clock warped, so the nominal rate stays the device's).

    Notes
    -----
    The elapsed time decides the wrap count only when it spans at least half a counter
    period; below that the counter difference is exact, and so is any outage shorter
    than one period whatever the timing jitter.
    """

    def __init__(self, modulus: int, sample_rate_hz: float) -> None:
        if modulus < 2 or not sample_rate_hz > 0:
            raise ValueError("modulus must be >= 2 and sample_rate_hz > 0")
        self.modulus = modulus
        self.sample_rate_hz = sample_rate_hz
        self._last_raw: int | None = None
        self._last_unwrapped = 0
        self._last_time_s = 0.0
        self._last_device_time_s: float | None = None

    @property
    def last_counter(self) -> int | None:
        """Unwrapped counter of the latest sample (None before the first)."""
        return None if self._last_raw is None else self._last_unwrapped

    def reset(self) -> None:
        """Forget the history (a new device, not a reconnect)."""
        self._last_raw = None

    def update(self, raw: int, receive_time_s: float, device_time_s: float | None = None,
               *, elapsed_s: float | None = None) -> tuple[int, Gap | None]:
        """Unwrapped counter of a new sample, and the gap before it if any.

        Parameters
        ----------
        raw : int
            Counter as sent.
        receive_time_s : float
            Station time of reception (or best send-time estimate), s.
        device_time_s : float or None
            Device time stamp, s, where the protocol has one (it decides first).
        elapsed_s : float or None
            The caller's estimate of the time since the previous sample, s, in place of
            the difference of the receive times (a byte stream passes its proven
            silence, 0 while bytes kept coming: see :class:`devices.stream.StreamRateSource`).

        Returns
        -------
        (int, Gap or None)

        Notes
        -----
        With ``n = elapsed * sample_rate_hz`` samples expected, the counter residue is
        exact and the wrap count is the one whose step is nearest ``n``, a tie going
        to fewer wraps, never below zero; below ``n = modulus / 2`` the counter alone
        counts.
        """
        if self._last_raw is None:
            self._last_raw, self._last_unwrapped = raw, raw
            self._last_time_s, self._last_device_time_s = receive_time_s, device_time_s
            return raw, None
        step = (raw - self._last_raw) % self.modulus
        method: GapMethod = "counter"
        if device_time_s is not None and self._last_device_time_s is not None:
            elapsed = device_time_s - self._last_device_time_s
            elapsed_method: GapMethod = "device_time"
        else:
            elapsed = receive_time_s - self._last_time_s if elapsed_s is None else elapsed_s
            elapsed_method = "counter+elapsed"
        expected = elapsed * self.sample_rate_hz
        if expected >= self.modulus / 2:
            wraps = max(0, math.ceil((expected - step) / self.modulus - 0.5))
            step += wraps * self.modulus
            method = elapsed_method
        if step == 0:
            step = self.modulus  # the same counter again: one full wrap lost
        gap = None
        if step > 1:
            gap = Gap(self._last_unwrapped, step - 1, method, receive_time_s)
        self._last_raw = raw
        self._last_unwrapped += step
        self._last_time_s, self._last_device_time_s = receive_time_s, device_time_s
        return self._last_unwrapped, gap
