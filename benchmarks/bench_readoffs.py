"""Read-offs and tones, measured side by side in one run (run by hand, not in CI).

    python benchmarks/bench_readoffs.py --quick     # about two minutes
    python benchmarks/bench_readoffs.py             # more seeds per case

Four parts, each printing ratios against the truth the records were simulated with:

* ARW under strong quantization (white angle noise equal to the white rate noise at
  tau = 1 s): the read-off's error, ours against the rule used before (the first stretch
  whose local slope is within 0.15 of -1/2), and the coverage of our 95 % interval;
* ARW interval on white noise: the share of records whose +-1 sigma interval holds the
  truth (nominal 68.3 %);
* bias instability at the minimum (white + flicker + random walk, taus out to 2 clusters):
  mean error of the raw minimum / 0.664 and of ours against the true curve's minimum,
  and the coverage of our +-1 sigma and 95 % intervals;
* tones: records of coloured noise (white, quantization, flicker, random walk, an LSB
  rounding) in which a tone is reported (designed: under 1e-3 per record), and the share
  of sinusoids of a given amplitude found.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from analysis.allan.estimators import AllanResult, overlapping_allan_variance
from analysis.figures.readoffs import (
    ARW_SLOPE_TOLERANCE,
    arw_readoff,
    bias_instability_readoff,
    local_adev_slope,
)
from analysis.figures.tones import find_tones
from analysis.figures.zones import fit_outside_zones
from analysis.models.noise import (
    flicker_rate_noise,
    random_walk_rate_noise,
    white_angle_noise,
    white_rate_noise,
)
from analysis.units.conversions import (
    arw_deg_rt_h_to_deg_rt_s,
    q_deg_to_urad,
    q_urad_to_deg,
    rate_deg_h_to_deg_s,
    rrw_deg_h_1_5_to_deg_s_1_5,
)


def first_slope_stretch(result: AllanResult) -> float:
    """The ARW read-off as it was: the first stretch of local slope -1/2 +- 0.15, edf-weighted."""
    tau, adev = result.tau_s, np.sqrt(result.avar)
    near = np.abs(local_adev_slope(tau, adev) + 0.5) <= ARW_SLOPE_TOLERANCE
    first = int(np.argmax(near))
    stop = first + int(np.argmin(near[first:])) if not near[first:].all() else len(near)
    sel = slice(first, stop)
    log_n = np.average(np.log(adev[sel] * np.sqrt(tau[sel])), weights=result.edf[sel])
    return math.exp(log_n) * 60.0


def arw_under_quantization(seeds: int) -> None:
    fs, n_true, n = 100.0, 0.5, 360_000
    q_urad = q_deg_to_urad(arw_deg_rt_h_to_deg_rt_s(n_true) * math.sqrt(1.0 / 3.0))
    ours, before, covered = [], [], 0
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        x = (white_rate_noise(arw_deg_rt_h_to_deg_rt_s(n_true), n, fs, rng)
             + white_angle_noise(q_urad_to_deg(q_urad), n, fs, rng))
        r = overlapping_allan_variance(x, fs)
        fit, zones = fit_outside_zones(r)
        arw = arw_readoff(r, fit, zones=zones)
        low, high = arw.interval(0.95)
        covered += low <= n_true <= high
        ours.append(arw.value / n_true)
        before.append(first_slope_stretch(r) / n_true)
    print(
        f"ARW, quantization Q = {q_urad:.0f} urad crossing N = {n_true} deg/sqrt(h) at 1 s, 1 h at "
        "100 Hz, "
        f"{seeds} seeds: read-off/truth ours mean {np.mean(ours):.4f} (range "
        f"{min(ours):.3f}-{max(ours):.3f}), "
        f"before {np.mean(before):.4f} (range {min(before):.3f}-{max(before):.3f}); "
        f"95 % interval holds the truth in {covered}/{seeds}"
    )


def arw_coverage(seeds: int) -> None:
    hits = 0
    for seed in range(seeds):
        x = white_rate_noise(
            arw_deg_rt_h_to_deg_rt_s(0.05), 40_000, 10.0, np.random.default_rng(seed)
        )
        r = overlapping_allan_variance(x, 10.0)
        fit, zones = fit_outside_zones(r)
        low, high = arw_readoff(r, fit, zones=zones).interval()
        hits += low <= 0.05 <= high
    print(f"ARW interval, white noise 4000 s at 10 Hz, {seeds} seeds: +-1 sigma coverage "
          f"{hits / seeds:.3f} (nominal 0.683)")


def bias_instability_minimum(seeds: int, k_deg_h_1_5: float) -> None:
    fs, n = 10.0, 200_000
    m = np.unique(np.rint(np.geomspace(1, n // 2, 120)).astype(int))
    tau = np.geomspace(1, n / fs, 4000)
    nb, b, k = (
        arw_deg_rt_h_to_deg_rt_s(0.05),
        rate_deg_h_to_deg_s(0.5),
        rrw_deg_h_1_5_to_deg_s_1_5(k_deg_h_1_5),
    )
    truth = (
        math.sqrt(float(np.min(nb**2 / tau + (0.664 * b) ** 2 + k**2 * tau / 3))) / 0.664 * 3600.0
    )
    raw, ours, one, ninety_five = [], [], 0, 0
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        x = (
            white_rate_noise(nb, n, fs, rng)
            + flicker_rate_noise(b, n, fs, rng)
            + random_walk_rate_noise(k, n, fs, rng)
        )
        r = overlapping_allan_variance(x, fs, taus=m / fs)
        bi = bias_instability_readoff(r)
        raw.append(math.sqrt(float(r.avar.min())) / 0.664 * 3600.0 / truth)
        ours.append(bi.value / truth)
        low, high = bi.interval()
        one += low <= truth <= high
        low, high = bi.interval(0.95)
        ninety_five += low <= truth <= high
    print(
        f"bias instability, N 0.05 deg/sqrt(h) + B 0.5 deg/h + K {k_deg_h_1_5} deg/h^1.5, 5.6 h at "
        "10 Hz, "
        f"taus to 2 clusters, {seeds} seeds: read-off/true minimum raw {np.mean(raw):.3f} (sd "
        f"{np.std(raw):.3f}), "
        f"ours {np.mean(ours):.3f} (sd {np.std(ours):.3f}); ours' interval holds it "
        f"{one / seeds:.2f} "
        f"(+-1 sigma), {ninety_five / seeds:.2f} (95 %)"
    )


def coloured(seed: int, kind: str, n: int, fs: float) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = white_rate_noise(arw_deg_rt_h_to_deg_rt_s(2.0), n, fs, rng)
    extra = {
        "quantization": lambda: white_angle_noise(q_urad_to_deg(50.0), n, fs, rng),
        "flicker": lambda: flicker_rate_noise(rate_deg_h_to_deg_s(30.0), n, fs, rng),
        "random walk": lambda: random_walk_rate_noise(
            rrw_deg_h_1_5_to_deg_s_1_5(300.0), n, fs, rng
        ),
    }
    if kind in extra:
        x = x + extra[kind]()
    if kind == "LSB rounding":
        x = np.round((x + 0.3) / 0.05) * 0.05
    return x


def tones(seeds: int) -> None:
    fs, n = 100.0, 100_000
    for kind in ("white", "quantization", "flicker", "random walk", "LSB rounding"):
        fired = sum(bool(find_tones(coloured(seed, kind, n, fs), fs)) for seed in range(seeds))
        print(f"tones, {kind}, 1000 s at 100 Hz: {fired}/{seeds} records report a tone")
    t = np.arange(n) / fs
    for amplitude in (0.01, 0.02, 0.04):
        found = 0
        for seed in range(seeds // 4):
            rng = np.random.default_rng(1000 + seed)
            f = rng.uniform(1.0, 45.0)
            x = coloured(seed, "flicker", n, fs) + amplitude * np.sin(
                2 * np.pi * f * t + rng.uniform(0, 6.3)
            )
            found += any(abs(tone.freq_hz - f) < 0.1 for tone in find_tones(x, fs))
        print(
            f"tones, a sinusoid of {amplitude} deg/s (white noise 0.33 deg/s per sample) at 1-45 "
            "Hz: "
            f"found in {found}/{seeds // 4}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer seeds (about two minutes)")
    args = parser.parse_args()
    scale = 1 if args.quick else 4
    start = time.perf_counter()
    arw_under_quantization(5 * scale)
    arw_coverage(40 * scale)
    bias_instability_minimum(30 * scale, 2.0)
    bias_instability_minimum(30 * scale, 0.5)
    tones(40 * scale)
    print(f"# {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
