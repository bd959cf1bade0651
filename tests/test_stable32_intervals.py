"""Noise identification and confidence intervals against Stable32, on the reference records
allantools ships: GPS 1PPS (tests/gps, 241 218 phase points, Stable32 1.53) and a 5071A
caesium clock (tests/Cs5071A, 556 990 points), both against an H-maser, and PHASE.DAT
(tests/phasedat, Stable32 1.60 octave runs with intervals).

Intervals are compared as the ratio of the widths ``hi - lo`` of the +-1 sigma (0.683)
deviation intervals, ours over Stable32's.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest

from analysis.allan.confidence import chi2_interval, difference_edf_grid
from analysis.allan.deviations import deviation, total_edf
from analysis.allan.noise_id import MIN_ACF_POINTS
from tests.allantools_reference import STABLE32_KINDS, read_phase, read_stable32

GPS = ("gps", "gps_1pps_phase_data.txt.gz",
       ["stable32_ADEV_decade.txt", "stable32_OADEV_octave.txt", "stable32_MDEV_octave.txt",
        "stable32_TDEV_octave.txt", "stable32_HDEV_octave.txt", "stable32_OHDEV_octave.txt",
        "stable32_TOTDEV_octave.txt"])
CS = (
    "Cs5071A",
    "5071A_phase.txt.gz",
    [
        "adev_decade.txt",
        "oadev_decade.txt",
        "mdev_decade.txt",
        "tdev_decade.txt",
        "hdev_decade.txt",
        "ohdev_decade.txt",
        "totdev_decade.txt",
    ],
)
CASES = [(folder, data, name) for folder, data, names in (GPS, CS) for name in names]
#: Every tau of the Cs5071A total deviation lists alpha = 0, where Stable32's automatic
#: identification of the same record (every other statistic in tests/Cs5071A) gives 2 at
#: tau = 1 s: this run had its noise type fixed to white FM, so its intervals are compared
#: with ours for that type, not with our identification.
FIXED_TYPE = {("Cs5071A", "totdev_decade.txt")}


@cache
def _rate(path: Path) -> np.ndarray:
    return np.diff(read_phase(path))  # phase in s -> fractional frequency at 1 Hz


@cache
def _ours(root: Path, folder: str, data: str, name: str):
    sigma, rows = read_stable32(root / folder / name)
    kind = STABLE32_KINDS[sigma]
    return kind, rows, deviation(_rate(root / folder / data), 1.0, kind=kind, taus=rows[:, 0])


def _width_ratio(low, high, rows) -> np.ndarray:
    return (high - low) / (rows[:, 6] - rows[:, 4])


def _print_rounding(rows) -> np.ndarray:
    """Relative uncertainty of a printed width: both bounds carry 5 significant digits."""
    return 1e-4 * rows[:, 5] / (rows[:, 6] - rows[:, 4])


@pytest.mark.parametrize("folder,data,name", [c for c in CASES if (c[0], c[2]) not in FIXED_TYPE])
def test_noise_type_is_stable32s_where_the_lag1_method_applies(
    allantools_tests, folder, data, name
):
    """Riley and Greenhall's lag-1 autocorrelation method, as Stable32 runs it, gives
    Stable32's type at every tau with at least 30 decimated points (FIXED_TYPE runs, whose
    types were set by hand, are left out)."""
    _, rows, ours = _ours(allantools_tests, folder, data, name)
    n_points = len(_rate(allantools_tests / folder / data)) // rows[:, 0].astype(int) + 1
    enough = n_points >= MIN_ACF_POINTS
    assert enough.sum() >= 12
    np.testing.assert_array_equal(ours.noise_alpha[enough], rows[enough, 3].astype(int))


@pytest.mark.parametrize("folder,data,name", CASES)
def test_edf_for_stable32s_noise_type_gives_stable32s_interval(
    allantools_tests, folder, data, name
):
    """With the noise type Stable32 lists, our edf (computed from the structure function;
    NIST SP 1065 Table 7 for total) gives its interval within 2 % (plus what the printed
    digits leave open: 3 % more on the narrowest interval). Not compared: total
    deviation under flicker angle noise, where Stable32 takes the simple SP 1065 formula
    and we the overlapping Allan edf (see the next test), and at m = 1."""
    kind, rows, ours = _ours(allantools_tests, folder, data, name)
    n = len(_rate(allantools_tests / folder / data))
    m, alpha = rows[:, 0].astype(np.int64), rows[:, 3].astype(np.int64)[:, None]
    if kind == "totdev":
        edf = total_edf(n, m, alpha)[:, 0]
    else:
        order = 3 if kind in ("hdev", "ohdev") else 2
        edf = difference_edf_grid(n, m, alpha, order=order, modified=kind in ("mdev", "tdev"),
                                  overlapping=kind != "adev" and kind != "hdev")[:, 0]
    low, high = chi2_interval(ours.variance, edf)
    ratio = _width_ratio(np.sqrt(low), np.sqrt(high), rows)
    # not compared for total: flicker angle noise (next test), and m = 1, where total is the
    # overlapping Allan variance and we take its edf (white FM: 0.67 N, which a Monte Carlo
    # of white rate noise confirms) where Stable32 applies Table 7's 1.5 N
    compared = ~((kind == "totdev") & ((alpha[:, 0] == 1) | (m == 1)))
    assert np.all(np.abs(ratio - 1)[compared] <= 0.02 + _print_rounding(rows)[compared]), ratio


#: Taus where our automatic interval is not within a factor of 2 of Stable32's, and why.
#: GPS total deviation, flicker angle noise (both identify alpha = 1): Stable32 uses NIST
#: SP 1065's simple flicker-PM edf for the total variance, twice the overlapping Allan
#: edf that Stable32 itself (and we) give the overlapping Allan deviation at these taus;
#: a Monte Carlo of flicker phase noise finds the total variance's edf at or below the
#: overlapping Allan one (benchmarks/bench_deviations.py), so our wider interval stands.
#: GPS total deviation at AF 32768 and 65536 (7 and 3 rate averages): Stable32 reads
#: flicker PM (alpha 1) where its own overlapping Allan run of the same record reads white
#: FM at 32768; we read white FM (the B1 ratio) and rate random walk (B1 of 3 averages).
EXCEPTIONS = {("gps", "stable32_TOTDEV_octave.txt"): {1024, 4096, 32768, 65536}}


@pytest.mark.parametrize("folder,data,name", CASES)
def test_intervals_are_within_a_factor_of_two_of_stable32s(allantools_tests, folder, data, name):
    """Our whole chain (noise type identified per tau, then its edf) against Stable32's
    intervals, as the ratio of the interval widths: within [1/2, 2] at every tau, but for
    the few listed in EXCEPTIONS (each with its reason); for FIXED_TYPE runs, with the type
    Stable32 was given."""
    kind, rows, ours = _ours(allantools_tests, folder, data, name)
    if (folder, name) in FIXED_TYPE:
        n = len(_rate(allantools_tests / folder / data))
        edf = total_edf(n, rows[:, 0].astype(np.int64), rows[:, 3].astype(np.int64)[:, None])[:, 0]
        low, high = chi2_interval(ours.variance, edf)
        ratio = _width_ratio(np.sqrt(low), np.sqrt(high), rows)
    else:
        ratio = _width_ratio(ours.deviation_ci_low, ours.deviation_ci_high, rows)
    skip = np.isin(rows[:, 0].astype(int), sorted(EXCEPTIONS.get((folder, name), set())))
    assert np.all((ratio[~skip] >= 0.5) & (ratio[~skip] <= 2.0)), dict(
        zip(rows[:, 0].astype(int), ratio.round(2), strict=True)
    )
    # the exceptions are wider than Stable32's (ours errs on the safe side there)
    assert np.all(ratio[skip] > 1.0), ratio[skip]


@pytest.mark.parametrize("stat", ["adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev"])
def test_phasedat_intervals_match_stable32(allantools_tests, stat):
    """PHASE.DAT (white FM at every octave tau, Stable32 1.60 with intervals): within 12 %."""
    x = read_phase(allantools_tests / "phasedat" / "PHASE.DAT")
    _, rows = read_stable32(allantools_tests / "phasedat" / f"phase_dat_{stat}_octave.txt")
    ours = deviation(np.diff(x), 1.0, kind=stat, taus=rows[:, 0])
    np.testing.assert_array_equal(ours.noise_alpha, rows[:, 3].astype(int))
    ratio = _width_ratio(ours.deviation_ci_low, ours.deviation_ci_high, rows)
    # total at m = 1 is the overlapping Allan variance: its edf, 0.67 N for white FM, where
    # Stable32 applies Table 7's 1.5 N (sqrt(1.5 / 0.67) = 1.5 times wider)
    first = (stat == "totdev") & (rows[:, 0] == 1)
    np.testing.assert_allclose(ratio[~first], 1.0, atol=0.12)
    assert np.all((ratio[first] > 1.3) & (ratio[first] < 1.7))
