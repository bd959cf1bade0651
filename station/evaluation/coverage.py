"""How much of the profile's test a unit's record holds: missing time and a short record.

The run's length is the recorder's span, start to stop (:attr:`RunInfo.recorded_span_s`:
the requested duration of a run that reached it, on each unit's own clock); where the
run did not reach it (an interrupted run, a replay that ran out, a CSV record) it is the
record's own span on its sample grid. Against it:

* ``missing_share``: the share of that span without a sample (gaps, and samples never
  received at its start or end); above :data:`MISSING_REVIEW_SHARE` the unit is flagged
  for review;
* ``short``: the span is shorter than the profile's test (by more than one sample
  period): review;
* ``covered_share``: the time the samples present cover, as a share of the profile's
  test; below :data:`MIN_COVERED_SHARE` no passing grade is given: each axis that would
  have passed is **indeterminate** (its ``could_reach`` names the grade), since the
  figures' long taus and averages rest on too little of the test.
"""

from __future__ import annotations

from dataclasses import dataclass

from station.model.profiles import Profile
from station.model.records import RateRecord

#: A unit missing more than this share of the run's span is flagged for review.
MISSING_REVIEW_SHARE = 0.05
#: A unit whose samples cover less than this share of the profile's test gets no
#: passing grade (indeterminate at best).
MIN_COVERED_SHARE = 0.5


@dataclass(frozen=True)
class RecordCoverage:
    """The record of one unit against the run's span and the profile's test (times in s)."""

    span_s: float
    span_source: str
    present_s: float
    profile_duration_s: float
    sample_period_s: float

    @property
    def missing_s(self) -> float:
        """Time of the span without a sample, s."""
        return max(0.0, self.span_s - self.present_s)

    @property
    def missing_share(self) -> float:
        """Share of the span without a sample."""
        return self.missing_s / self.span_s if self.span_s > 0 else 1.0

    @property
    def covered_share(self) -> float:
        """Time the samples cover as a share of the profile's test."""
        return self.present_s / self.profile_duration_s

    @property
    def short(self) -> bool:
        """Whether the span is shorter than the profile's test (by more than a sample)."""
        return self.span_s < self.profile_duration_s - self.sample_period_s

    @property
    def insufficient(self) -> bool:
        """Whether the record covers too little of the test for a passing grade."""
        return self.covered_share < MIN_COVERED_SHARE

    @property
    def review(self) -> tuple[str, ...]:
        """Why the record needs review (empty: it does not)."""
        out = []
        if self.missing_share > MISSING_REVIEW_SHARE:
            out.append(f"{self.missing_share:.1%} of the run's {self.span_s:.0f} s has no "
                       f"sample ({self.missing_s:.0f} s missing; review above "
                       f"{MISSING_REVIEW_SHARE:.0%})")
        if self.short:
            out.append(f"record {self.span_s:.0f} s is shorter than the profile's test "
                       f"({self.profile_duration_s:.0f} s)")
        if self.insufficient:
            out.append(f"its samples cover {self.covered_share:.1%} of the profile's "
                       f"{self.profile_duration_s:.0f} s test, under the "
                       f"{MIN_COVERED_SHARE:.0%} a passing grade needs: indeterminate")
        return tuple(out)

    def as_json(self) -> dict[str, object]:
        """The ``coverage`` object of a unit in ``station grade --json``."""
        return {
            "span_s": self.span_s,
            "span_source": self.span_source,
            "present_s": self.present_s,
            "missing_s": self.missing_s,
            "missing_share": self.missing_share,
            "profile_duration_s": self.profile_duration_s,
            "covered_share": self.covered_share,
            "short": self.short,
            "insufficient": self.insufficient,
            "missing_review_share": MISSING_REVIEW_SHARE,
            "min_covered_share": MIN_COVERED_SHARE,
        }


def record_coverage(record: RateRecord, profile: Profile, recorded_span_s: float | None,
                    test_duration_s: float | None = None) -> RecordCoverage:
    """The coverage of a unit's whole ``record`` (warm-up included) for ``profile``;
    ``recorded_span_s``: the recorder's span (None, or shorter than the record's own
    span: the record's); ``test_duration_s``: the test it is held against (None: the
    profile's ``duration_s``; a test sequence's noise segment: its own span)."""
    fs = record.sample_rate_hz
    span, source = ((recorded_span_s, "recorder")
                    if recorded_span_s is not None and recorded_span_s >= record.duration_s
                    else (record.duration_s, "record"))
    test = profile.duration_s if test_duration_s is None else test_duration_s
    return RecordCoverage(span, source, record.n_samples / fs, test, 1.0 / fs)
