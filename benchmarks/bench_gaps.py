"""Records with many short gaps: partial clusters against the unbroken record (by hand).

    python benchmarks/bench_gaps.py --quick     # 3 seeds, about 20 s
    python benchmarks/bench_gaps.py             # 20 seeds

The polled Modbus unit of issue 28: one hour, 6.8 % of the samples lost in runs of 1 to 3
(:func:`analysis.models.simulation.polled_loss`). At 18 Hz that is about 2200 gaps, the count the
unit showed (2169). Each seed simulates one hour of white rate noise (ARW 0.15 deg/rt h),
flicker (bias instability 3 deg/h) and rate random walk (K = 5 deg/h^1.5), analyses the
unbroken record and the same record with the gaps (:func:`analysis.allan.partial_clusters`, as
``station analyze`` and ``station grade`` do) and prints, per figure, the median ratio
gapped / unbroken and the share of seeds whose unbroken value lies inside the gapped
figure's 95 % interval (ADEV at 1, 10, 100, 1000 s; bias stability 10 s and 100 s; the
fitted N, B, K with their standard errors). The strict rule (:mod:`analysis.allan.gaps`, no
average straddles a gap) is shown beside: its longest tau and whether it has a 100 s bias
stability at all.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy import stats

from analysis.allan.gaps import gap_allan_variance, gap_summary
from analysis.allan.partial_clusters import partial_allan_variance, white_level
from analysis.figures.spec import bias_stability
from analysis.models.noise import flicker_rate_noise, random_walk_rate_noise, white_rate_noise
from analysis.models.simulation import polled_loss
from analysis.units.conversions import S_PER_H
from station.evaluation.analyze import analyze_record
from station.model.records import RateRecord

FS_HZ = 18.0
DURATION_S = 3600.0
MISSING_SHARE = 0.068
TAUS_S = (1.0, 10.0, 100.0, 1000.0)
Z95 = float(stats.norm.ppf(0.975))


def _rate(n: int, rng: np.random.Generator) -> np.ndarray:
    return (white_rate_noise(0.15 / 60.0, n, FS_HZ, rng)
            + flicker_rate_noise(3.0 / S_PER_H, n, FS_HZ, rng)
            + random_walk_rate_noise(5.0 / S_PER_H**1.5, n, FS_HZ, rng))


def _one(seed: int) -> dict[str, tuple[float, bool]]:
    """{figure: (gapped / unbroken, unbroken inside the gapped 95 % interval)}."""
    rng = np.random.default_rng(seed)
    n = int(DURATION_S * FS_HZ)
    x = _rate(n, rng)
    keep = polled_loss(n, missing_share=MISSING_SHARE, rng=rng)
    index = np.flatnonzero(keep)
    whole = analyze_record(RateRecord(x[:, None], FS_HZ, ("x",)))[0]
    gapped = analyze_record(RateRecord(x[index, None], FS_HZ, ("x",), sample_index=index))[0]
    out: dict[str, tuple[float, bool]] = {}
    taus = np.asarray(TAUS_S)
    ref = partial_allan_variance(x, FS_HZ, taus=taus, confidence=0.95)
    got = partial_allan_variance(np.where(keep, x, np.nan), FS_HZ, taus=taus, confidence=0.95)
    for i, tau in enumerate(TAUS_S):
        inside = bool(got.ci_low[i] <= ref.avar[i] <= got.ci_high[i])
        out[f"ADEV {tau:g} s"] = (float(np.sqrt(got.avar[i] / ref.avar[i])), inside)
    grid = np.where(keep, x, np.nan)
    for average_s in (10.0, 100.0):
        r = bias_stability(x, FS_HZ, average_s)
        g = bias_stability(grid, FS_HZ, average_s, white_level=white_level(gapped.allan))
        assert r.value_deg_h is not None and g.value_deg_h is not None and g.edf is not None
        low, high = (np.sqrt(g.value_deg_h**2 * g.edf / stats.chi2.ppf(q, g.edf))
                     for q in (0.975, 0.025))
        out[f"bias stability {average_s:g} s"] = (
            g.value_deg_h / r.value_deg_h, bool(low <= r.value_deg_h <= high))
    for term in ("N", "B", "K"):
        a, b = whole.fit.values[term], gapped.fit.values[term]
        se = gapped.fit.stderr[term]
        if a is None or b is None or se is None or a == 0:
            out[f"fit {term}"] = (float("nan"), False)  # not resolved in one of the two
            continue
        out[f"fit {term}"] = (b / a, bool(abs(b - a) <= Z95 * se))
    strict = gap_allan_variance(grid, FS_HZ)
    out["strict: longest tau s"] = (float(strict.tau_s[-1]), True)
    out["strict: bias stability 100 s"] = (
        float(bias_stability(grid, FS_HZ, 100.0, max_missing_share=0.0).value_deg_h is not None),
        True)
    out["gaps"] = (float(gap_summary(keep).count), True)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="3 seeds instead of 20")
    seeds = range(3 if parser.parse_args().quick else 20)
    start = time.perf_counter()
    rows = [_one(s) for s in seeds]
    print(f"{len(rows)} seeds, {DURATION_S:g} s at {FS_HZ:g} Hz, {MISSING_SHARE:.1%} missing "
          f"in runs of 1-3 samples ({np.median([r['gaps'][0] for r in rows]):.0f} gaps)")
    print(f"{'figure':32s} {'gapped/unbroken (median)':>25s} {'inside 95 % interval':>21s}")
    for name in rows[0]:
        if name == "gaps":
            continue
        kept = [r[name] for r in rows if np.isfinite(r[name][0])]
        if not kept:
            print(f"{name:32s} {'not resolved by the fit':>25s}")
            continue
        ratio = np.median([k[0] for k in kept])
        share = np.mean([k[1] for k in kept])
        print(f"{name:32s} {ratio:25.4f} {share:15.0%} of {len(kept)}")
    print(f"({time.perf_counter() - start:.1f} s)")


if __name__ == "__main__":
    main()
