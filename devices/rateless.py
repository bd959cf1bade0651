"""Messages a device counts that carry no sample (an Xsens MTi-G's GNSS PVT messages).

An MTi's PacketCounter counts every MTData2 message it sends, and an MTi-G-710 sends its
GNSS PVT data at 4 Hz in messages of their own, with no rate of turn (the real captures
in ``../shared/real-captures/xsens-mtig710/``: one such message in 26). Taken as it
comes, the counter steps by 2 across each of them, which reads as a lost sample.
:class:`RatelessMessages` counts those messages and takes each sample's counter less
the steps they used, so that the station's counter counts samples: a step over such a
message is no gap, while a lost sample still shows. A codec opts in with a
``rateless_counter(frame)`` method (the counter of a frame that carries no sample).

A sample's message corrupted so that it reads as one without a rate (an 8-bit sum lets
some corruptions through) would hide a lost sample: where the device times say more
samples passed than the counters (less those steps) do, the messages taken for rateless
ones since the last sample were samples, as many as the difference, and their steps
count as lost samples again.

Limit: a message of this kind lost with the samples around it (an outage) is counted
as one more missing sample, and the later counters are one higher (no gap is hidden).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from devices.codecs.base import Reading
from devices.errors import NoRateError


class RatelessMessages:
    """Counter steps used by messages that carry no sample, and the refusal of a stream
    that never carries one.

    Parameters
    ----------
    codec : StreamCodec
        Its ``rateless_counter(frame)`` (if it has one) gives the counter of such a frame.
    modulus : int
        The counter's wrap.
    sample_rate_hz : float or None
        Nominal sample rate, Hz: with the readings' device times, it finds the rateless
        messages that were corrupted samples (None: not checked).
    """

    #: Messages with a counter and no sample, in a row and before the first sample,
    #: after which the stream is refused (an MTi-G-710 sends at most a few between two
    #: samples: its GNSS messages come at 4 Hz).
    refuse_after = 16

    def __init__(self, codec: Any, modulus: int, sample_rate_hz: float | None = None) -> None:
        self.codec = codec
        self.modulus = modulus
        self.sample_rate_hz = sample_rate_hz
        self._last_sample: tuple[int, float] | None = None  # (counter as taken, device s)
        self._counter_of = getattr(codec, "rateless_counter", None)
        #: Counter steps such messages used so far (modulo the wrap).
        self.skipped = 0
        #: Such messages since the last sample.
        self.in_a_row = 0
        self._had_sample = False
        self._last_raw: int | None = None

    def skip(self, frame: object) -> None:
        """A frame that made no reading: if it carries a counter, its step is no sample.

        Raises
        ------
        NoRateError
            :attr:`refuse_after` such messages in a row and no sample yet.
        """
        raw = None if self._counter_of is None else self._counter_of(frame)
        if raw is None or raw == self._last_raw:  # no counter, or the same message again
            return
        self._last_raw = raw
        self.skipped = (self.skipped + 1) % self.modulus
        self.in_a_row += 1
        if not self._had_sample and self.in_a_row >= self.refuse_after:
            self.refuse()

    def refuse_if_rateless(self) -> None:
        """Refuse a stream whose messages so far carried counters and never a sample
        (called when the adapter's silence limit runs out).

        Raises
        ------
        NoRateError
            Such messages came, and no sample.
        """
        if not self._had_sample and self.in_a_row:
            self.refuse()

    def refuse(self) -> None:
        """Raise the refusal, naming the item the codec needs."""
        item = getattr(self.codec, "rate_item", "a rate")
        hint = getattr(self.codec, "rate_item_hint", "")
        raise NoRateError(f"{self.codec.name}: {self.in_a_row} messages in a row carry no "
                          f"{item}, and none did yet" + (f": {hint}" if hint else ""))

    def sample(self, reading: Reading) -> Reading:
        """The reading with its counter less the steps rateless messages used."""
        self._last_raw = reading.counter
        self._had_sample = True
        counter = (reading.counter - self.skipped) % self.modulus
        undo = self._were_samples(counter, reading.device_time_s)
        if undo:
            self.skipped = (self.skipped - undo) % self.modulus
            counter = (reading.counter - self.skipped) % self.modulus
        self.in_a_row = 0
        if reading.device_time_s is not None:
            self._last_sample = (counter, reading.device_time_s)
        return reading if counter == reading.counter else replace(reading, counter=counter)

    def _were_samples(self, counter: int, device_time_s: float | None) -> int:
        """How many of the rateless messages since the last sample were samples: the
        device times' count of sample periods less the counter step, where that is
        1..(rateless messages since) (else 0: nothing to mend, or not explained)."""
        if not self.in_a_row or self._last_sample is None or device_time_s is None \
                or not self.sample_rate_hz:
            return 0
        last_counter, last_time_s = self._last_sample
        periods = round((device_time_s - last_time_s) * self.sample_rate_hz)
        short = periods - (counter - last_counter) % self.modulus
        return short if 0 < short <= self.in_a_row else 0
