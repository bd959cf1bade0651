"""Counting lost samples from a wrapping device counter, elapsed time and nominal rate.

A counter may advance by one per sample (a KVH DSP-1750's sequence number 0..127) or by a
fixed step per sample: a STIM300's 8-bit counter counts the unit's internal samples at
2000 Hz (TS1524 rev. 31, section 7.5.2.2.18), so at an output rate of 125 Hz it advances
by 16 a datagram and wraps after 16 datagrams (0.128 s at every rate). The tracker counts
in samples: ``counter_step`` counter units make one sample, ``modulus // counter_step``
samples one wrap, and the unwrapped counter it returns is in samples.

A wrapping counter alone cannot count an outage
longer than its period: :class:`CounterTracker` takes the counter residue as exact and
chooses the number of wraps from the elapsed time and the nominal rate: the device's own
time stamps where the protocol has them; else a send-time estimate (a bus's frame time
stamps: CAN, CANopen) or the adapter's own estimate (a byte stream's proven silence, see
:class:`devices.stream.StreamRateSource`). Each gap says how it was counted, and the
range of counts the evidence allows: the wrap counts whose step fits the bounds of the
elapsed time, at the nominal rate within :data:`RATE_TOLERANCE` (the best count is kept
inside them). Where one wrap count fits, the count is certain
(``missing_low == missing_high``).
"""

from __future__ import annotations

import math

from devices.protocols import Gap, GapMethod

#: Relative error of a device's sample rate the bounds allow (1000 ppm: a crystal's
#: tolerance and drift with margin; a simulation's ``drift_ppm`` stays inside it).
RATE_TOLERANCE = 1e-3
#: Where the timing bounds of a gap hold no wrap count (they contradict the counter), a
#: wrap count is still a candidate if its sample count is within this factor of the
#: bounds'; one further off is taken as no candidate (a polled 16-bit counter 0.5 s
#: late is not 45 min late).
CONTRADICTION_FACTOR = 2.0


class CounterTracker:
    """Unwraps a device counter and reports gaps with their missing-sample counts.

    Parameters
    ----------
    modulus : int
        Counter wrap, counter units (256, 128, 65536, ...).
    sample_rate_hz : float
        Nominal sample rate, Hz (in the clock's time base: a time-warped simulation
        runs its clock warped, so the nominal rate stays the device's).
    timing_uncertainty_s : float
        How far, s, the times given to :meth:`update` may be from when the device sent
        each sample, when the caller gives no bounds of its own (a bus's frame time
        stamps: the sender's latency). Device time stamps are exact.
    counter_step : int
        Counter units the device counter advances by per sample (1; a STIM300:
        2000 Hz / output rate). Must divide ``modulus``.

    Attributes
    ----------
    modulus : int
        Samples per counter wrap (``modulus // counter_step``): what the tracker counts in.
    counter_modulus : int
        The counter's own wrap, counter units.

    Notes
    -----
    The elapsed time decides the wrap count only when it spans at least half a counter
    period; below that the counter difference is the count. The bounds decide whether
    the count is certain.
    """

    def __init__(self, modulus: int, sample_rate_hz: float, *,
                 timing_uncertainty_s: float = 0.0, counter_step: int = 1) -> None:
        # (modulus 1: a unit that sends no counter; every step is then counted from the
        # elapsed time alone, raw CAN layouts without a counter)
        if modulus < 1 or not sample_rate_hz > 0 or timing_uncertainty_s < 0:
            raise ValueError("modulus must be >= 1, sample_rate_hz > 0 and "
                             "timing_uncertainty_s >= 0")
        if counter_step < 1 or modulus % counter_step or (
                modulus > 1 and modulus // counter_step < 2):
            raise ValueError(f"counter_step must divide the modulus {modulus} into at least "
                             f"2 samples, got {counter_step}")
        self.counter_modulus = modulus
        self.counter_step = counter_step
        self.modulus = modulus // counter_step
        self.sample_rate_hz = sample_rate_hz
        self.timing_uncertainty_s = timing_uncertainty_s
        self._last_raw: int | None = None
        self._last_unwrapped = 0
        self._last_time_s = 0.0
        self._last_device_time_s: float | None = None

    @property
    def last_counter(self) -> int | None:
        """Unwrapped counter of the latest sample (None before the first)."""
        return None if self._last_raw is None else self._last_unwrapped

    @property
    def last_time_s(self) -> float:
        """Time (s) given with the latest sample."""
        return self._last_time_s

    @property
    def last_raw(self) -> int | None:
        """The latest sample's counter as sent (None before the first)."""
        return self._last_raw

    def reset(self) -> None:
        """Forget the history (a new device, not a reconnect)."""
        self._last_raw = None

    def residue_step(self, raw: int) -> int:
        """Samples from the latest sample to one sent as ``raw``, no wrap counted
        (1..modulus; 1 before the first sample)."""
        if self._last_raw is None:
            return 1
        return self.samples_between(self._last_raw, raw)

    def samples_between(self, earlier: int, later: int) -> int:
        """Samples from a sample sent with counter ``earlier`` to one sent with ``later``,
        no wrap counted (1..modulus, samples).

        A counter difference that is not a whole number of steps (the unit was reset, or
        the counter's phase moved) rounds to the nearest sample, at least one.
        """
        return counter_samples(earlier, later, self.counter_modulus, self.counter_step)

    def update(self, raw: int, receive_time_s: float, device_time_s: float | None = None,
               *, elapsed_s: float | None = None,
               elapsed_range_s: tuple[float, float] | None = None) -> tuple[int, Gap | None]:
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
        elapsed_range_s : (float, float) or None
            Bounds of that time, s (the earliest and latest the two samples' send times
            allow); default: the estimate +- ``timing_uncertainty_s``.

        Returns
        -------
        (int, Gap or None)

        Notes
        -----
        With ``n = elapsed * sample_rate_hz`` samples expected, the counter residue is
        exact and the wrap count is the one whose step is nearest ``n``, a tie going
        to fewer wraps, never below zero; below ``n = modulus / 2`` the counter alone
        counts. The gap's bounds are the wrap counts whose step lies within the bounds
        of the elapsed time times the rate (+- :data:`RATE_TOLERANCE`); the chosen one
        is kept inside them. Where none fits, the timing contradicts the counter: the
        wrap counts on either side of the bounds are the range (see
        :data:`CONTRADICTION_FACTOR`: uncertain where both are candidates).
        """
        if self._last_raw is None:
            self._last_raw, self._last_unwrapped = raw, raw // self.counter_step
            self._last_time_s, self._last_device_time_s = receive_time_s, device_time_s
            return self._last_unwrapped, None
        step = self.residue_step(raw)
        method: GapMethod = "counter"
        if device_time_s is not None and self._last_device_time_s is not None and \
                not self._plausible(device_time_s - self._last_device_time_s,
                                    elapsed_range_s):
            # A device time the station's own timing rules out (a corrupted stamp a weak
            # checksum let through): the station's timing decides instead.
            device_time_s = None
        if device_time_s is not None and self._last_device_time_s is not None:
            elapsed = device_time_s - self._last_device_time_s
            elapsed_method: GapMethod = "device_time"
            # A device's own stamps are exact to well under a period.
            bounds = (elapsed - 0.25 / self.sample_rate_hz, elapsed + 0.25 / self.sample_rate_hz)
        else:
            elapsed = receive_time_s - self._last_time_s if elapsed_s is None else elapsed_s
            elapsed_method = "counter+elapsed"
            u = self.timing_uncertainty_s
            bounds = elapsed_range_s or (elapsed - u, elapsed + u)
        expected = elapsed * self.sample_rate_hz
        wraps = 0
        if expected >= self.modulus / 2:
            wraps = max(0, math.ceil((expected - step) / self.modulus - 0.5))
            method = elapsed_method
        fit = self._wrap_bounds(step, bounds)
        if fit is None:
            # The bounds contradict the counter (a host that delivered bytes late, a
            # clock paired off): the timing is wrong by at least the distance to the
            # nearest wrap count, so the neighbours on either side are the candidates.
            low, high = self._neighbours(step, bounds, wraps)
        else:
            low, high = fit
        wraps = min(max(wraps, low), high)
        if high > 0 and method == "counter":
            method = elapsed_method  # the timing is what bounds the count
        gap = None
        if step + high * self.modulus > 1:
            gap = Gap(self._last_unwrapped, step + wraps * self.modulus - 1, method,
                      receive_time_s, step + low * self.modulus - 1,
                      step + high * self.modulus - 1)
        self._last_raw = raw
        self._last_unwrapped += step + wraps * self.modulus
        self._last_time_s, self._last_device_time_s = receive_time_s, device_time_s
        return self._last_unwrapped, gap

    @staticmethod
    def _plausible(device_elapsed_s: float, bounds: tuple[float, float] | None) -> bool:
        """Whether a device-time step fits the station's bounds of the elapsed time
        (with 0.5 s of slack; no bounds: any step forward)."""
        if device_elapsed_s < 0:
            return False
        return bounds is None or bounds[0] - 0.5 <= device_elapsed_s <= bounds[1] + 0.5

    def _neighbours(self, step: int, bounds: tuple[float, float], estimate: int
                    ) -> tuple[int, int]:
        """The wrap counts on either side of ``bounds`` (s) that none fits: both, where
        each implies a sample count within :data:`CONTRADICTION_FACTOR` of the bounds'
        (the count is then uncertain); the one that does; else the estimate's."""
        lo_s, hi_s = bounds
        n_lo = max(0.0, lo_s) * self.sample_rate_hz
        n_hi = max(0.0, hi_s) * self.sample_rate_hz
        below = math.floor((n_hi - step) / self.modulus)
        near = [k for k in (below, below + 1)
                if k >= 0 and n_lo / CONTRADICTION_FACTOR - 1.0 <= step + k * self.modulus
                <= n_hi * CONTRADICTION_FACTOR + 1.0]
        return (min(near), max(near)) if near else (estimate, estimate)

    def _wrap_bounds(self, step: int, bounds: tuple[float, float]) -> tuple[int, int] | None:
        """The fewest and most wraps whose counter step fits ``bounds`` (s) of the elapsed
        time at the nominal rate +- RATE_TOLERANCE (half a sample of slack); None when
        none fits."""
        lo_s, hi_s = bounds
        n_lo = max(0.0, lo_s) * self.sample_rate_hz * (1.0 - RATE_TOLERANCE) - 0.5
        n_hi = max(0.0, hi_s) * self.sample_rate_hz * (1.0 + RATE_TOLERANCE) + 0.5
        k_lo = max(0, math.ceil((n_lo - step) / self.modulus))
        k_hi = math.floor((n_hi - step) / self.modulus)
        return None if k_hi < k_lo else (k_lo, k_hi)


def counter_samples(earlier: int, later: int, modulus: int, step: int = 1) -> int:
    """Samples between two counter values of a counter that wraps at ``modulus`` (counter
    units) and advances by ``step`` per sample, no wrap counted (1..modulus // step).

    A difference of zero is a whole wrap; one that is not a whole number of steps rounds
    to the nearest sample, at least one.
    """
    ticks = (later - earlier) % modulus
    if ticks == 0:
        return modulus // step
    return max(1, (2 * ticks + step) // (2 * step))
