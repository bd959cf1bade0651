"""When a byte-stream gyro sent its samples, as far as the station can prove it.

A serial protocol without time stamps (STIM300, KVH DSP-1750) gives the station only the
times at which its reads returned; a reader that falls behind (a loaded host) reads
frames late, and taking those late times for send times invents counter wraps.
:class:`StreamTiming` keeps two things instead:

* *proven silences*: a read that returned no byte after waiting its whole timeout, or a
  reopen attempt (the port missing, or opening it flushed its input), proves that
  nothing arrived from the last bytes until then. Bytes that come next arrived after the
  proof and by the end of the read that got them; the silence is taken to end midway
  (at most half a read timeout after the proof).
* a *send-time chain*: each reading was due one counter step after the one before it
  (nominal rate), never later than it could have arrived (the end of its read's wait,
  less one period per frame after it in the same read) and never earlier than the start
  of the read before its own less the device's output latency (it was not in the port
  when that read drained it).

The elapsed time before the first reading after a silence is the silence's end less the
previous reading's send time; between readings with no proven silence it is 0 (the
counter counts alone). :class:`devices.gaps.CounterTracker` picks the wrap count nearest
it.

It also keeps *bounds* of each reading's send time (:meth:`StreamTiming.send_bounds`),
from which the tracker knows whether a wrap count is certain: a reading was sent no
later than the end of the read that got it, less one (fastest) period per counter step
after it in that read; and no earlier than the moment the port was last seen drained
(the start of the previous read that got bytes, or the end of a proven silence), less
the host's delivery jitter and the device's latency, and one period per counter step
after the reading before it. A host that falls behind widens the window a read covers,
but the readings it holds fill that window: only the slack left can hide wraps.
Times are on the unit's clock (s).
"""

from __future__ import annotations

from devices.gaps import RATE_TOLERANCE


class StreamTiming:
    """Silence proofs and send-time estimates of one byte-stream device.

    Parameters
    ----------
    sample_rate_hz : float
        Nominal rate, Hz (per clock second).
    max_latency_s : float
        Longest a device holds a sample before sending it, clock s (a UART frame time,
        a USB adapter's latency timer; a simulator's loop period).
    """

    def __init__(self, sample_rate_hz: float, max_latency_s: float,
                 host_jitter_s: float = 0.0) -> None:
        if not (sample_rate_hz > 0 and max_latency_s >= 0 and host_jitter_s >= 0):
            raise ValueError("sample_rate_hz must be > 0, max_latency_s and host_jitter_s "
                             ">= 0")
        self.period_s = 1.0 / sample_rate_hz
        self.max_latency_s = max_latency_s
        self.host_jitter_s = host_jitter_s
        self._last_bytes_s: float | None = None
        self._quiet_until_s: float | None = None
        self._silence_end_s: float | None = None
        self._sent_s: float | None = None
        self._read_started_s: float | None = None
        self._prev_read_started_s: float | None = None
        #: Bytes not yet read arrived after this (s): the port was seen drained then.
        self._drained_s: float | None = None
        #: The same for the bytes the latest read got.
        self._bytes_after_s: float | None = None
        self._prev_bounds: tuple[float, float] | None = None

    def quiet_until(self, t_s: float) -> None:
        """Nothing arrived between the last bytes and ``t_s`` (an empty read's end, a
        reopen attempt)."""
        if self._drained_s is None or t_s > self._drained_s:
            self._drained_s = t_s
        if self._last_bytes_s is None:
            return  # nothing received yet: no reading to measure a silence from
        if self._quiet_until_s is None or t_s > self._quiet_until_s:
            self._quiet_until_s = t_s

    def send_bounds(self, steps: list[int], arrived_by_s: float
                    ) -> list[tuple[float, float] | None]:
        """Bounds of the elapsed time (s) before each reading of the latest read.

        Parameters
        ----------
        steps : list of int
            Counter steps (no wrap counted) from the reading before each one.
        arrived_by_s : float
            The read had returned these bytes by then (s).

        Returns
        -------
        list of (float, float) or None
            Per reading, the least and most time since the reading before it was sent
            (None for the first reading of the stream). The first reading of the read
            holds all the slack of the read's window (what its readings' steps do not
            fill); the others get their steps' time: a whole wrap hidden among them is
            counted in the first one's bounds.
        """
        fastest = 1.0 / (1.0 + RATE_TOLERANCE)
        his, t = [], arrived_by_s
        for step in reversed(steps):
            his.append(t)
            t -= step * self.period_s * fastest
        his.reverse()
        floor = (-float("inf") if self._bytes_after_s is None
                 else self._bytes_after_s - self.host_jitter_s - self.max_latency_s)
        out: list[tuple[float, float] | None] = []
        prev = self._prev_bounds
        for i, (step, hi) in enumerate(zip(steps, his, strict=True)):
            lo = floor if prev is None else max(floor, prev[0] + step * self.period_s * fastest)
            hi = max(hi, lo)
            if prev is None:
                out.append(None)
            elif i == 0:
                out.append((lo - prev[1], hi - prev[0]))
            else:
                # Readings of one read: whatever time their steps do not fill is slack
                # the first one's bounds hold already (its latest send time leaves room
                # for every reading after it): counted once, here the steps alone.
                out.append((step * self.period_s * fastest,
                            step * self.period_s * (1.0 + RATE_TOLERANCE)))
            prev = (lo, hi)
        self._prev_bounds = prev
        return out

    def read_done(self, started_s: float, wait_end_s: float, half_window_s: float,
                  got_bytes: bool, drained: bool = True) -> None:
        """Book one read: started at ``started_s``; its wait ended by ``wait_end_s``.

        ``half_window_s`` caps how long after the proof a silence is taken to last.
        ``drained``: the read took everything the port held when it started; False for
        a read that got as many bytes as the port hands over at once (a tty's line
        discipline: 4096), which may have left bytes that were there before it started
        (a backlog of a reader that fell behind).
        """
        # The start of the latest read before this one that drained the port.
        self._prev_read_started_s = self._read_started_s
        if drained or not got_bytes:
            self._read_started_s = started_s
        if not got_bytes:
            self.quiet_until(wait_end_s)
            return
        # The bytes got now arrived after the port was last seen drained; what this read
        # left arrived after it started (it took everything there by then), unless it
        # may have left a backlog: then the port was last seen drained where it was.
        self._bytes_after_s = self._drained_s
        if drained:
            self._drained_s = started_s
        quiet = self._quiet_until_s
        if quiet is not None:
            self._silence_end_s = quiet + min(max(0.0, wait_end_s - quiet) / 2.0,
                                              half_window_s)
            self._quiet_until_s = None
        self._last_bytes_s = wait_end_s

    def elapsed_before(self, latest_s: float) -> float:
        """Elapsed time (s) before the next reading, which arrived by ``latest_s``:
        from the previous reading's send time to the end of the silence proven in
        between, 0 without one."""
        end = self._silence_end_s
        if end is None or self._sent_s is None:
            return 0.0
        return max(0.0, min(end, latest_s) - self._sent_s)

    def sent(self, step: int, latest_s: float) -> float:
        """Record the send time of a reading ``step`` counter steps after the previous
        one that arrived by ``latest_s``; returns it (s)."""
        if self._silence_end_s is not None or self._sent_s is None:
            t = latest_s if self._silence_end_s is None else min(self._silence_end_s,
                                                                 latest_s)
            self._silence_end_s = None
        else:
            t = min(self._sent_s + step * self.period_s, latest_s)
            if self._prev_read_started_s is not None:
                t = max(t, min(latest_s, self._prev_read_started_s - self.max_latency_s))
        self._sent_s = t
        return t
