"""Whether a record resolves its figures: the link's step, a stuck output, a constant record.

For each graded axis, :func:`axis_resolution` counts the record's values (a block at a time
for a long record): how many distinct values, the share of the commonest, the longest run
of one value, and the smallest step between two values. The step grading works with
(``q``) is the larger of the link's (the run file's ``lsb_deg_s``, a float word's step
at the record's largest rate, a CSV's ``--lsb``) and the one read off the values.

* A figure whose upper confidence bound lies below its quantization floor
  (:mod:`station.model.quantization`) is **not resolved**: each verdict it would pass is
  indeterminate, with a one-line note (:func:`below_floor`). The bias' interval is
  compared by its width, since a stuck output holds its mean to within +-q/2 whatever
  its batch means say.
* A **stuck output** is flagged for review: one value holds at least
  :data:`STUCK_MODE_SHARE` of the samples (a Gaussian noise of sigma centred on a step
  puts 0.9 of its samples on it when sigma < q/3.3); or the record has too few distinct
  values for its noise: its sample-to-sample noise (rms of the first differences /
  sqrt(2), which a drift does not raise) is under :data:`STUCK_NOISE_LSB` LSB (the
  rounding then sets the short-tau figures: ``benchmarks/bench_resolution.py``); or one
  value holds a run longer
  than :data:`STUCK_RUN_FACTOR` times the longest the record's own share of that value
  makes likely (Schilling's expected longest run, log(n (1 - p)) / log(1 / p)), and at
  least :data:`STUCK_MIN_RUN` samples.
* A record of one value throughout is refused (:class:`ConstantRecordError`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from analysis.allan import blocks
from devices.resolution import RateResolution
from station.evaluation.decision import GradingError
from station.model.quantization import figure_floor

#: One value holding this share of the samples or more is a stuck output.
STUCK_MODE_SHARE = 0.9
#: A run of one value this many times longer than the record's value shares make
#: likely is a stuck output ...
STUCK_RUN_FACTOR = 3.0
#: ... when it is at least this many samples long.
STUCK_MIN_RUN = 10
#: A sample-to-sample noise under this many LSB is too little to move the word across
#: its steps: too few distinct values for the noise (a record of two values toggling at
#: random has 0.5 LSB; a Gaussian noise of 0.5 LSB rounded has 0.58).
STUCK_NOISE_LSB = 0.55
#: Distinct values counted exactly; beyond this many the count stops (a record that
#: varies this much is no stuck output by its count).
DISTINCT_CAP = 4096


class ConstantRecordError(GradingError):
    """A record that holds one value throughout: nothing to grade."""


@dataclass(frozen=True)
class ValueCensus:
    """The values of one axis' record.

    ``distinct`` is exact up to :data:`DISTINCT_CAP` (``distinct_capped``: at least that
    many); ``mode_value``/``mode_share`` the commonest value and its share of the samples
    (exact whenever the share is at least :data:`STUCK_MODE_SHARE`); ``step_deg_s`` the
    smallest difference between two distinct values (None: one value);
    ``longest_run``/``run_value`` the longest stretch of one value and that value;
    ``run_value_share`` the share of that value in the rest of the record.
    """

    n_samples: int
    distinct: int
    distinct_capped: bool
    mode_value: float
    mode_share: float
    step_deg_s: float | None
    longest_run: int
    run_value: float
    run_value_share: float
    largest_deg_s: float
    #: The sample-to-sample noise: rms of first differences / sqrt(2), deg/s (a drift
    #: does not count; white noise of sigma a sample gives sigma).
    short_noise_deg_s: float


def _block_runs(x: NDArray[np.float64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """(start, length) of each run of one value in ``x``."""
    edges = np.flatnonzero(x[1:] != x[:-1]) + 1
    starts = np.concatenate(([0], edges)).astype(np.int64)
    return starts, np.diff(np.concatenate((starts, [len(x)]))).astype(np.int64)


def value_census(x: NDArray[np.float64]) -> ValueCensus:
    """Count the values of a record's present samples ``x`` (deg/s, no NaN; a memmap is
    read a block at a time)."""
    n = len(x)
    counts: dict[float, int] | None = {}
    candidates: set[float] = set()
    step = math.inf
    largest = 0.0
    best_len, best_value = 0, math.nan
    run_value, run_len = math.nan, 0
    squares = 0.0
    for a, b in blocks.spans(0, n):
        block = np.asarray(x[a:b], dtype=np.float64)
        squares += float(np.sum(np.diff(block) ** 2))
        if a > 0:
            squares += (float(block[0]) - run_value) ** 2  # the step across the block edge
        values, block_counts = np.unique(block, return_counts=True)
        largest = max(largest, float(np.max(np.abs(values))))
        if len(values) > 1:
            step = min(step, float(np.min(np.diff(values))))
        top = int(np.argmax(block_counts))
        if block_counts[top] >= STUCK_MODE_SHARE * len(block):
            candidates.add(float(values[top]))
        if counts is not None and len(values) > DISTINCT_CAP:
            counts = None  # over the cap already: no Python dict of a block's every value
        if counts is not None:
            for v, c in zip(values.tolist(), block_counts.tolist(), strict=True):
                counts[v] = counts.get(v, 0) + c
            if len(counts) > DISTINCT_CAP:
                counts = None
        starts, lengths = _block_runs(block)
        first = float(block[0])
        if first == run_value:  # the run before this block goes on
            lengths[0] += run_len
        longest = int(np.argmax(lengths))  # the block's first longest run
        if lengths[longest] > best_len:
            best_len, best_value = int(lengths[longest]), float(block[starts[longest]])
        run_value, run_len = float(block[-1]), int(lengths[-1])
        blocks.release(x)
    if counts is not None:
        distinct, capped = len(counts), False
        mode_value = max(counts, key=lambda v: counts[v])
        mode_count = counts[mode_value]
        run_count = counts.get(best_value, best_len)
    else:  # many values: count the values that could hold most of them, and the run's
        distinct, capped = DISTINCT_CAP, True
        tally = {v: _count(x, v) for v in candidates | {best_value}}
        mode_value = max(tally, key=lambda v: tally[v])
        mode_count, run_count = tally[mode_value], tally[best_value]
    if counts is not None and len(counts) > 1:  # a step between values of two blocks
        values = np.array(sorted(counts))
        step = min(step, float(np.min(np.diff(values))))
    rest = n - best_len
    return ValueCensus(n, distinct, capped, float(mode_value), mode_count / n if n else 0.0,
                       None if math.isinf(step) else step, best_len, best_value,
                       (run_count - best_len) / rest if rest > 0 else 1.0, largest,
                       math.sqrt(squares / (2 * (n - 1))) if n > 1 else 0.0)


def _count(x: NDArray[np.float64], value: float) -> int:
    total = 0
    for a, b in blocks.spans(0, len(x)):
        total += int(np.count_nonzero(np.asarray(x[a:b]) == value))
        blocks.release(x)
    return total


def expected_longest_run(n: int, p: float) -> float:
    """The longest run of one value expected in ``n`` independent samples that take it
    with probability ``p`` (Schilling 1990, "The longest run of heads"), samples."""
    if p <= 0.0 or n < 2:
        return 1.0
    if p >= 1.0:
        return float(n)
    return max(1.0, math.log(n * (1.0 - p)) / math.log(1.0 / p))


@dataclass(frozen=True)
class AxisResolution:
    """How well one axis' record resolves its figures.

    Attributes
    ----------
    lsb_deg_s : float
        The step grading works with, deg/s (module docstring).
    lsb_source : str
        ``"link"`` (the run file's, a CSV's ``--lsb``), ``"values"`` (read off the
        values: the link's is not known or coarser), or ``"none"`` (neither: no floor).
    link_lsb_deg_s, values_lsb_deg_s : float or None
        The link's step (at the record's largest rate for a float word) and the values'.
    census : ValueCensus
    stuck : tuple of str
        Why the output looks stuck (empty: it does not).
    """

    lsb_deg_s: float
    lsb_source: str
    link_lsb_deg_s: float | None
    values_lsb_deg_s: float | None
    sample_rate_hz: float
    census: ValueCensus
    stuck: tuple[str, ...] = ()

    def as_json(self) -> dict[str, object]:
        """The ``resolution`` object of an axis in ``station grade --json``."""
        c = self.census
        return {
            "lsb_deg_s": self.lsb_deg_s if self.lsb_source != "none" else None,
            "lsb_source": self.lsb_source,
            "link_lsb_deg_s": self.link_lsb_deg_s,
            "values_lsb_deg_s": self.values_lsb_deg_s,
            "distinct_values": c.distinct,
            "distinct_values_capped": c.distinct_capped,
            "mode_value_deg_s": c.mode_value,
            "mode_share": c.mode_share,
            "longest_run_samples": c.longest_run,
            "longest_run_s": c.longest_run / self.sample_rate_hz,
            "stuck": bool(self.stuck),
            "stuck_reasons": list(self.stuck),
            "stuck_mode_share_limit": STUCK_MODE_SHARE,
            "noise_lsb": (c.short_noise_deg_s / self.lsb_deg_s if self.lsb_deg_s > 0
                          else None),
            "stuck_noise_lsb_limit": STUCK_NOISE_LSB,
        }


def check_not_constant(x: NDArray[np.float64], where: str) -> None:
    """Refuse a record whose present samples ``x`` are all one value.

    Raises
    ------
    ConstantRecordError
        One line: where, the value and the count.
    """
    n = len(x)
    if n == 0:
        return
    first = float(x[0])
    for a, b in blocks.spans(0, n):
        if np.any(np.asarray(x[a:b]) != first):
            blocks.release(x)
            return
        blocks.release(x)
    raise ConstantRecordError(
        f"{where}: all {n} samples are {first:g} deg/s: a constant output (a stuck, "
        f"unpowered or disconnected sensor) has no noise to measure")


def axis_resolution(x: NDArray[np.float64], sample_rate_hz: float,
                    link: RateResolution | None) -> AxisResolution:
    """The step, value census and stuck-output review of one axis' present samples
    ``x`` (deg/s), with the link's resolution ``link`` (None: not known)."""
    census = value_census(x)
    link_step = None if link is None else link.step_at(census.largest_deg_s) or None
    values_step = census.step_deg_s
    steps = [s for s in (link_step, values_step) if s]
    if not steps:
        lsb, source = 0.0, "none"
    else:
        lsb = max(steps)
        source = "link" if link_step is not None and lsb == link_step else "values"
    return AxisResolution(lsb, source, link_step, values_step, sample_rate_hz, census,
                          stuck_reasons(census, sample_rate_hz, lsb))


def stuck_reasons(c: ValueCensus, sample_rate_hz: float, lsb_deg_s: float
                  ) -> tuple[str, ...]:
    """Why a record's values look like a stuck output (module docstring); empty if not.
    ``lsb_deg_s``: the step the record is graded with (0: none known)."""
    out = []
    noise_lsb = c.short_noise_deg_s / lsb_deg_s if lsb_deg_s > 0 else math.inf
    if noise_lsb < STUCK_NOISE_LSB and c.mode_share < STUCK_MODE_SHARE:
        out.append(f"too few distinct values for its noise: {c.distinct} values, a "
                   f"sample-to-sample noise of {noise_lsb:.2f} LSB (review under "
                   f"{STUCK_NOISE_LSB:g}): the word's rounding, not the gyro, sets the "
                   f"short-tau figures")
    if c.mode_share >= STUCK_MODE_SHARE:
        out.append(f"stuck output: one value ({c.mode_value:.6g} deg/s) holds "
                   f"{c.mode_share:.2%} of the {c.n_samples} samples ({c.distinct}"
                   f"{'+' if c.distinct_capped else ''} distinct values; review from "
                   f"{STUCK_MODE_SHARE:.0%}): the noise is a fraction of an LSB a sample")
    expected = expected_longest_run(c.n_samples, c.run_value_share)
    if c.longest_run >= max(STUCK_MIN_RUN, STUCK_RUN_FACTOR * expected):
        out.append(f"stuck output: {c.run_value:.6g} deg/s held for {c.longest_run} samples "
                   f"({c.longest_run / sample_rate_hz:.4g} s) at a stretch, where that "
                   f"value's share of the rest makes {expected:.3g} the longest expected")
    return tuple(out)


@dataclass(frozen=True)
class BelowFloor:
    """A figure under its quantization floor: why (one line), and the floor (its unit)."""

    why: str
    floor: float


def below_floor(name: str, unit: str, unit_factor: float, value: float | None,
                low: float | None, high: float | None, resolution: AxisResolution, *,
                tau_s: float | None, record_s: float, confidence: float) -> BelowFloor | None:
    """Whether figure ``name`` (``value`` with its interval ``low``..``high``, in ``unit``
    of ``unit_factor`` canonical units) lies under its quantization floor (module
    docstring); None where it does not, or has no floor."""
    if resolution.lsb_source == "none" or value is None:
        return None
    floor = figure_floor(name, resolution.lsb_deg_s, resolution.sample_rate_hz, tau_s,
                         record_s=record_s, confidence=confidence)
    if floor is None:
        return None
    floor_unit = floor / unit_factor
    lsb, rate = resolution.lsb_deg_s, resolution.sample_rate_hz
    if name == "bias":
        width = high - low if high is not None and low is not None else 0.0
        if width >= floor_unit:
            return None
        return BelowFloor(f"not resolved: its interval, {width:.3g} {unit} wide, is narrower "
                          f"than the rounding of LSB {lsb:.3g} deg/s allows "
                          f"({floor_unit:.3g} {unit})", floor_unit)
    top = high if high is not None else value
    if top >= floor_unit:
        return None
    return BelowFloor(f"not resolved: upper bound {top:.3g} {unit} is below the quantization "
                      f"floor {floor_unit:.3g} {unit} of LSB {lsb:.3g} deg/s at {rate:g} Hz",
                      floor_unit)
