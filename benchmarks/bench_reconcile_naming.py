"""How often reconcile names a hidden effect, on records from a generator independent of the
station's.

The station's simulator (:mod:`analysis.models.simulation`) makes every sample the exact mean of a
continuous process, and reconcile's Monte Carlo band comes from the same simulator. Here
the records come from textbook point-sampled recursions written in this file instead:
white noise, flicker noise by Kasdin's filter (:func:`analysis.models.noise.flicker_rate_noise`),
a discrete AR(1) for the Gauss-Markov process (``phi = exp(-dt/T)``), a cumulative sum for
the rate random walk, a sampled sine and more Kasdin flicker noise for a bias instability
larger than the model's (the Gauss-Markov process' rival explanation) and a rate ramp of
the random walk's variance (the walk's rival). The base model and
the effects' parameter ranges are those of ``tests/test_reconcile.py`` (``--ranges
narrow``: 1 h at 10 Hz, ARW 0.5 deg/sqrt(h), bias instability 2 deg/h), wider and weaker
ones (``wide``, default) or the weakest (``faint``), each effect's variance under a tenth of
the white noise's.

For every seed set and effect it prints how many seeds name exactly that effect (and what
else was named), then the negative controls (the base model alone) and how many name
anything. Seed sets are disjoint: develop on one, report the others::

    python -m benchmarks.bench_reconcile_naming --sets 2000 3000 4000 [--seeds 12]
"""

from __future__ import annotations

import argparse
import math
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from scipy import signal

from analysis.models.noise import flicker_rate_noise
from analysis.models.terms import AngleRandomWalk, BiasInstability, NoiseModel
from analysis.reconcile.discrepancy import ComparisonCache
from analysis.reconcile.loop import ReconcileOptions, reconcile

FS_HZ, DURATION_S = 10.0, 3600.0
N_SAMPLES = int(FS_HZ * DURATION_S)
ARW_DEG_RT_H, B_DEG_H = 0.5, 2.0
SIGMA_W_DEG_S = ARW_DEG_RT_H * 60.0 * math.sqrt(FS_HZ) / 3600.0  # white-noise std per sample
EFFECTS = ("gauss_markov", "rate_random_walk", "sinusoid", "bias_instability", "rate_ramp", "none")

_CACHE = ComparisonCache()


def base_model(b_deg_h: float = B_DEG_H) -> NoiseModel:
    """The model reconcile is given: ARW 0.5 deg/sqrt(h) and bias instability ``b_deg_h``."""
    return NoiseModel(
        terms=(AngleRandomWalk(N_deg_rt_h=ARW_DEG_RT_H), BiasInstability(B_deg_h=b_deg_h)),
        name="base",
    )


def base_rate(rng: np.random.Generator, b_deg_h: float = B_DEG_H) -> np.ndarray:
    """White rate noise plus Kasdin flicker noise, deg/s."""
    white = SIGMA_W_DEG_S * rng.standard_normal(N_SAMPLES)
    return white + flicker_rate_noise(b_deg_h / 3600.0, N_SAMPLES, FS_HZ, rng)


#: Parameter ranges: those of tests/test_reconcile.py ("narrow") or wider and weaker ("wide":
#: correlation times and periods log-uniform over 5-300 s and 10-600 s, amplitudes down to
#: half the narrow ones, random walks down to a third); (low, high) of sigma / sigma_w, tau,
#: variance ratio, amplitude, period, and the bias instability added in quadrature to the
#: model's (deg/h). Correlation times stop at a twelfth of the record: beyond it a
#: Gauss-Markov process and a random walk are one curve in an hour.
RANGES = {
    "narrow": {"gm_sigma": (0.22, 0.28), "gm_tau": (30.0, 120.0), "rw_ratio": (0.05, 0.08),
               "amp": (0.25, 0.3), "period": (60.0, 300.0), "bi_deg_h": (3.0, 4.0)},
    "wide": {"gm_sigma": (0.12, 0.3), "gm_tau": (5.0, 300.0), "rw_ratio": (0.02, 0.08),
             "amp": (0.12, 0.3), "period": (10.0, 600.0), "bi_deg_h": (2.0, 5.0)},
    "faint": {"gm_sigma": (0.05, 0.15), "gm_tau": (2.0, 60.0), "rw_ratio": (0.01, 0.04),
              "amp": (0.06, 0.15), "period": (10.0, 600.0), "bi_deg_h": (1.5, 3.0)},
}


def _log_uniform(rng: np.random.Generator, bounds: tuple[float, float]) -> float:
    return float(math.exp(rng.uniform(math.log(bounds[0]), math.log(bounds[1]))))


def effect_parameters(effect: str, rng: np.random.Generator, ranges: str = "narrow",
                      ) -> dict[str, float]:
    """The parameters of a Gauss-Markov process (``sigma`` deg/s, ``tau`` s), a rate random
    walk (``k`` deg/s^1.5) or a sinusoid (``amp`` deg/s, ``period`` s), drawn from
    ``RANGES[ranges]`` (the first draws :func:`hidden` takes for them)."""
    r = RANGES[ranges]
    if effect == "gauss_markov":
        return {"sigma": rng.uniform(*r["gm_sigma"]) * SIGMA_W_DEG_S,
                "tau": _log_uniform(rng, r["gm_tau"])}
    if effect == "rate_random_walk":
        return {"k": math.sqrt(6.0 * rng.uniform(*r["rw_ratio"]) / DURATION_S) * SIGMA_W_DEG_S}
    if effect == "sinusoid":
        return {"amp": rng.uniform(*r["amp"]) * SIGMA_W_DEG_S,
                "period": _log_uniform(rng, r["period"])}
    raise ValueError(f"no drawn parameters for {effect!r}")


def hidden(effect: str, rng: np.random.Generator, ranges: str = "narrow") -> np.ndarray:
    """The effect's rate (deg/s), parameters drawn from ``RANGES[ranges]``."""
    r = RANGES[ranges]
    t = np.arange(N_SAMPLES) / FS_HZ
    if effect == "gauss_markov":
        p = effect_parameters(effect, rng, ranges)
        sigma, tau = p["sigma"], p["tau"]
        phi = math.exp(-1.0 / (FS_HZ * tau))
        e = sigma * math.sqrt(1 - phi**2) * rng.standard_normal(N_SAMPLES)
        x0 = sigma * rng.standard_normal()
        out, _ = signal.lfilter([1.0], [1.0, -phi], e, zi=[phi * x0])
        return out
    if effect == "rate_random_walk":
        k = effect_parameters(effect, rng, ranges)["k"]
        return np.cumsum(k / math.sqrt(FS_HZ) * rng.standard_normal(N_SAMPLES))
    if effect == "sinusoid":
        p = effect_parameters(effect, rng, ranges)
        amp, period = p["amp"], p["period"]
        phase = rng.uniform(0, 2 * math.pi)
        return amp * np.sin(2 * math.pi * t / period + phase)
    if effect == "rate_ramp":
        # the random walk's rival: a ramp whose variance over the record, (R L)^2 / 12, is the
        # walk's expected K^2 L / 6, of either sign
        slope = math.sqrt(12.0 * rng.uniform(*r["rw_ratio"])) * SIGMA_W_DEG_S / DURATION_S
        return float(rng.choice([-1.0, 1.0])) * slope * (t - DURATION_S / 2.0)
    if effect == "bias_instability":
        return flicker_rate_noise(rng.uniform(*r["bi_deg_h"]) / 3600.0, N_SAMPLES, FS_HZ, rng)
    return np.zeros(N_SAMPLES)


def one(
    task: tuple[str, int, str, float, bool],
) -> tuple[str, int, list[str], list[tuple[str, str, float]]]:
    effect, seed, ranges, b_deg_h, use_gmwm = task
    rng = np.random.default_rng(seed)
    rate = base_rate(rng, b_deg_h) + hidden(effect, rng, ranges)
    res = reconcile(
        rate, FS_HZ, base_model(b_deg_h), cache=_CACHE, options=ReconcileOptions(gmwm=use_gmwm)
    )
    named = [e.name for e in res.effects] + [f"{e.name}(excess)" for e in res.excess]
    alternatives = [(e.name, a.name, a.score) for e in res.effects for a in e.alternatives]
    return effect, seed, named, alternatives


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--sets", type=int, nargs="+", default=[3000, 4000], help="first seed of each set"
    )
    parser.add_argument(
        "--seeds", type=int, default=12, help="seeds per set and effect (default 12)"
    )
    parser.add_argument("--effects", nargs="+", default=list(EFFECTS), choices=EFFECTS)
    parser.add_argument("--ranges", choices=sorted(RANGES), default="wide",
                        help="effect parameter ranges (default wide; narrow: those of the tests)")
    parser.add_argument("--bi", type=float, default=B_DEG_H,
                        help=f"bias instability of the base model, deg/h (default {B_DEG_H:g})")
    parser.add_argument("--no-gmwm", action="store_true", help="name by the Allan curve alone")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    start = time.perf_counter()
    tasks = [(effect, base + i, args.ranges, args.bi, not args.no_gmwm) for base in args.sets
             for effect in args.effects for i in range(args.seeds)]
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        results = list(pool.map(one, tasks))
    print(
        f"reconcile naming ({'Allan curve alone' if args.no_gmwm else 'with the GMWM'}) on an "
        "independent "
        f"generator ({args.ranges} ranges, base B {args.bi:g} deg/h): "
        f"{args.seeds} seeds per set, "
        f"{time.perf_counter() - start:.0f} s"
    )
    for base in args.sets:
        for effect in args.effects:
            rows = [r for r in results if r[0] == effect and base <= r[1] < base + args.seeds]
            if effect == "none":
                hits = sum(1 for r in rows if not r[2])
                what = "named nothing"
            else:
                hits = sum(1 for r in rows if r[2] == [effect])
                what = f"named exactly {effect}"
            others = Counter(
                "+".join(r[2]) or "nothing"
                for r in rows
                if (r[2] != [effect] if effect != "none" else r[2])
            )
            alts = Counter(f"{n}~{a}" for r in rows for n, a, _ in r[3])
            print(
                f"seeds {base}-{base + args.seeds - 1} {effect:<17} {hits:>2}/{len(rows)} {what}; "
                f"otherwise {dict(others) or '-'}; alternatives reported {dict(alts) or '-'}"
            )


if __name__ == "__main__":
    main()
