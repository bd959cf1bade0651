"""The reconcile proof at a larger scale: more seeds, longer records (issue 9).

For each hidden effect of ``tests/test_reconcile.py`` (same draws, scaled to the record
length), ``--seeds`` runs: how often the workflow names exactly that effect, the error of
its main parameter, and the gap before and after; then ``--controls`` negative controls
(data exactly from the model) and their false-alarm rate. Bias-step runs count only when
the realization is hidden and holds a detectable step (see the test), and say how many
did. Run from the repository root::

    python -m benchmarks.bench_reconcile [--seeds 20] [--controls 100] [--hours 2]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from analysis.reconcile.discrepancy import ComparisonCache
from tests.test_reconcile import (
    BASE,
    HIDDEN,
    HIDDEN_VARIANCE_RATIO,
    SIGMA_W_DEG_H,
    hidden_variance_ratio,
    realized_steps,
    reconcile_run,
)


def _main_error(name: str, effect, result, seed: int, duration_s: float) -> float:
    """Relative error of the main parameter (bias steps: worst located step against its hidden
    one)."""
    found = result.effects[0]
    if name != "bias_steps":
        key = HIDDEN[name].key
        return found.params[key] / getattr(effect, key) - 1.0
    times, sizes = realized_steps(effect, seed, duration_s)
    errors = [s / sizes[int(np.argmin(np.abs(times - t)))] - 1.0 for t, s in found.events]
    return max(errors, key=abs)


def bench_hidden(seeds: int, duration_s: float) -> None:
    print(f"hidden effects, {duration_s / 3600:g} h at 10 Hz, base model {BASE.term_names}")
    print(f"{'effect':<18}{'runs':>5}{'named':>7}{'|err| med':>10}{'|err| max':>10}{'G before':>10}"
          f"{'G after':>9}{'min ratio':>10}{'s/run':>7}")
    for name, spec in HIDDEN.items():
        cache = ComparisonCache()
        named, errors, before, after, ratios, used = 0, [], [], [], [], 0
        start = time.perf_counter()
        for seed in range(1000, 1000 + seeds):
            effect = spec.draw(np.random.default_rng(seed), duration_s)
            if hidden_variance_ratio(effect, seed, duration_s) >= HIDDEN_VARIANCE_RATIO:
                continue
            if name == "bias_steps":
                _, sizes = realized_steps(effect, seed, duration_s)
                if not sizes.size or np.max(np.abs(sizes)) < 0.5 * SIGMA_W_DEG_H:
                    continue
            used += 1
            res = reconcile_run(BASE.with_term(effect), seed, cache, duration_s=duration_s)
            if [e.name for e in res.effects] == [name] and not res.excess:
                named += 1
                errors.append(abs(_main_error(name, effect, res, seed, duration_s)))
                before.append(res.gap_before)
                after.append(res.gap_after)
                ratios.append(res.gap_before / res.gap_after)
        took = (time.perf_counter() - start) / max(used, 1)
        if not errors:
            print(f"{name:<18}{used:>5}{named:>7}")
            continue
        print(f"{name:<18}{used:>5}{named:>7}{np.median(errors):>10.3f}{np.max(errors):>10.3f}"
              f"{np.median(before):>10.2f}{np.median(after):>9.2f}{np.min(ratios):>10.1f}{took:>7.1f}")


def bench_controls(controls: int, duration_s: float) -> None:
    cache = ComparisonCache()
    alarms = []
    for seed in range(5000, 5000 + controls):
        res = reconcile_run(BASE, seed, cache, duration_s=duration_s)
        if res.effects or res.excess:
            alarms.append((seed, [e.name for e in (*res.effects, *res.excess)]))
    print(f"negative controls: {len(alarms)} of {controls} report an effect "
          f"({100 * len(alarms) / controls:.1f} %): {alarms}")


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--seeds", type=int, default=20, help="seeds per hidden effect (default 20)"
    )
    parser.add_argument("--controls", type=int, default=100, help="negative controls (default 100)")
    parser.add_argument("--hours", type=float, default=2.0, help="record length in h (default 2)")
    args = parser.parse_args()
    duration_s = args.hours * 3600.0
    bench_hidden(args.seeds, duration_s)
    bench_controls(args.controls, duration_s)


if __name__ == "__main__":
    main()
