"""How often a record can tell a bias instability from a slow Gauss-Markov process, and what
asking costs (issue 28, item 1: "B against a slow Gauss-Markov").

Records of white noise plus either a bias instability (flicker) or a Gauss-Markov process
whose correlation time is a sizeable part of the record, from the station's simulator
(:mod:`analysis.models.simulation`). Each is read as ``station analyze`` reads it (the ``logwls``
reading, :func:`station.evaluation.analyze.analyze_record`), and the GMWM's wavelet
information criterion (:func:`analysis.gmwm.selection.select_model`) ranks the model of
that reading with ``bi`` against the same with ``gm`` in its place. Printed per case: the
readings the selection kept, how many records put the two models within
:data:`analysis.figures.ambiguity.AMBIGUITY_MARGIN` of each other (the record cannot tell them
apart), how many prefer each beyond it, and the seconds the ranking takes per axis (what
carrying the Gauss-Markov reading beside every bias-instability reading would add to an
analysis). Then what the sheet now does (:mod:`analysis.figures.bias_or_markov`): in how many
records the printed reading lists a Gauss-Markov alternative (``terms`` ending in ``+GM``),
split by whether the printed reading holds B, K or neither, and the median seconds of the
whole analysis per axis.

    python -m benchmarks.bench_bias_or_markov            # seeds 28900-28909, 1 h and 6 h
    python -m benchmarks.bench_bias_or_markov --seeds 20 --first 29500
    python -m benchmarks.bench_bias_or_markov --seeds 10 --first 31000   # fresh seeds
"""

from __future__ import annotations

import argparse
import time
from collections import Counter

import numpy as np

from analysis.errors import AnalysisError
from analysis.figures.ambiguity import AMBIGUITY_MARGIN, GMWM_TERM
from analysis.gmwm.selection import select_model
from analysis.gmwm.wavelet import haar_wavelet_variance
from analysis.models.simulation import simulate
from analysis.models.terms import AngleRandomWalk, BiasInstability, GaussMarkov, NoiseModel
from station.evaluation.analyze import analyze_record
from station.model.records import RateRecord

RATE_HZ = 10.0
#: (name, model, hours): white noise 0.5 deg/sqrt(h) with B 2 deg/h or a Gauss-Markov
#: process of 3 deg/h whose correlation time is a sixth of the record.
CASES = (
    ("N + B, 1 h", (AngleRandomWalk(N_deg_rt_h=0.5), BiasInstability(B_deg_h=2.0)), 1.0),
    ("N + GM 600 s, 1 h", (AngleRandomWalk(N_deg_rt_h=0.5),
                           GaussMarkov(sigma_deg_h=3.0, tau_s=600.0)), 1.0),
    ("N + B, 6 h", (AngleRandomWalk(N_deg_rt_h=0.5), BiasInstability(B_deg_h=2.0)), 6.0),
    ("N + GM 3600 s, 6 h", (AngleRandomWalk(N_deg_rt_h=0.5),
                            GaussMarkov(sigma_deg_h=3.0, tau_s=3600.0)), 6.0),
)


def _gmwm_model(terms: str) -> str:
    return "+".join(GMWM_TERM[t] for t in terms if t in GMWM_TERM)


def main() -> None:
    """Simulate, read, rank and print (module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--first", type=int, default=28900)
    args = parser.parse_args()
    for name, terms, hours in CASES:
        readings: Counter[str] = Counter()
        verdicts: Counter[str] = Counter()
        listed: Counter[str] = Counter()
        seconds, analysis_s = [], []
        for seed in range(args.first, args.first + args.seeds):
            rate = simulate(NoiseModel(terms), hours * 3600.0, RATE_HZ, seed=seed).rate_deg_s
            start = time.perf_counter()
            fit = analyze_record(RateRecord(rate, RATE_HZ, ("x",)))[0].fit
            analysis_s.append(time.perf_counter() - start)
            readings[fit.terms] += 1
            holds = "B" if "B" in fit.terms else "K" if "K" in fit.terms else "neither"
            has_gm = any(a.gauss_markov is not None for a in fit.alternatives)
            listed[f"{holds}: {'GM listed' if has_gm else 'no GM'}"] += 1
            # the reading's model with a bias instability, and with a Gauss-Markov in its place
            base = "".join(t for t in fit.terms if t != "B") + "B"
            flicker = _gmwm_model("".join(t for t in "QNBKR" if t in base))
            markov = flicker.replace("bi", "gm")
            start = time.perf_counter()
            try:
                wv = haar_wavelet_variance(rate[:, 0], RATE_HZ)
                ranking = select_model(wv, [flicker, markov]).ranking
            except (AnalysisError, np.linalg.LinAlgError):
                verdicts["not fitted"] += 1
                continue
            seconds.append(time.perf_counter() - start)
            crit = {r.model: r.criterion for r in ranking}
            if markov not in crit or flicker not in crit:  # more parameters than scales
                verdicts["not fitted"] += 1
                continue
            delta = crit[markov] - crit[flicker]  # > 0: the bias instability is preferred
            verdicts["within the margin" if abs(delta) <= AMBIGUITY_MARGIN
                     else "B preferred" if delta > 0 else "GM preferred"] += 1
        print(f"{name:<20} readings {dict(readings)}; B against GM: {dict(verdicts)}; "
              f"ranking {np.median(seconds):.2f} s per axis (median)", flush=True)
        gm_total = sum(n for k, n in listed.items() if k.endswith("GM listed"))
        print(f"{'':<20} sheet: GM alternative listed in {gm_total} of {args.seeds} "
              f"(printed reading holds {dict(sorted(listed.items()))}); analysis "
              f"{np.median(analysis_s):.2f} s per axis (median)", flush=True)


if __name__ == "__main__":
    main()
