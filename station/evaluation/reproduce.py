"""Re-run the Monte Carlo of the weighted least-squares Allan fit paper (tables 1-6).

Lv, Liu, Lai, Huang, "Allan variance method for gyro noise analysis using weighted least
square algorithm", Optik 126 (2015): three gyros (SRS2000, VG951, CRG20) with only
quantization Q, angle random walk N and bias instability B, 0.1 s sampling, 4 h, 30 runs,
the cluster Allan variance at every m, and three fits (OLS on all values, OLS on values
under 40 % error, WLS by cluster count). We add our own methods beside them.

Our simulation: Q as white angle noise, N as white rate noise, B as flicker rate noise
from Kasdin's fractional-differencing filter (plateau 0.664 B). The paper does not say
how it simulated B; :class:`Lv2015Setup` holds the alternatives that
``benchmarks/lv2015_causes.py`` measures (a single first-order Gauss-Markov process, the
station's Gauss-Markov bank, another tau grid or estimator, fewer samples).
"""

from __future__ import annotations

import math
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass
from typing import Any, Literal

import numpy as np
from scipy import signal

from analysis.allan.curves import gauss_markov_avar
from analysis.allan.estimators import Estimator
from analysis.allan.variance import allan_variance
from analysis.fit.least_squares import FIT_METHODS, fit_every_method
from analysis.models.noise import flicker_rate_noise, white_angle_noise, white_rate_noise
from analysis.models.simulation import simulate
from analysis.models.terms import BiasInstability, NoiseModel
from analysis.units.conversions import arw_deg_rt_h_to_deg_rt_s, q_urad_to_deg, rate_deg_h_to_deg_s

SAMPLE_RATE_HZ = 10.0
DURATION_S = 4 * 3600.0
TERMS = "QNB"
BiasNoise = Literal["flicker", "markov", "bank"]


@dataclass(frozen=True)
class Lv2015Setup:
    """How the Monte Carlo simulates and analyses each run (the defaults are the paper's).

    Attributes
    ----------
    duration_s, sample_rate_hz : float
        Record length (s) and rate (Hz): 4 h at 10 Hz in the paper.
    estimator : {"clusters", "overlapping"}
        Allan estimator; the paper's eq. 1-2 are the cluster one.
    max_clusters_m : int
        The largest m keeps at least this many clusters: 2 is the paper's every m up to
        N/2; 9 stops at N/9 (Zhang 2015 eq. 20).
    bias_noise : {"flicker", "markov", "bank"}
        B as Kasdin flicker noise, as one first-order Gauss-Markov process whose Allan
        deviation peaks at 0.664 B (``markov_correlation_s``), or as the station's bank of
        Gauss-Markov processes (:func:`analysis.models.noise.flicker_bank`).
    markov_correlation_s : float
        Correlation time of the single Gauss-Markov process (s).
    """

    duration_s: float = DURATION_S
    sample_rate_hz: float = SAMPLE_RATE_HZ
    estimator: Estimator = "clusters"
    max_clusters_m: int = 2
    bias_noise: BiasNoise = "flicker"
    markov_correlation_s: float = 100.0

    @property
    def n_samples(self) -> int:
        """Samples per run."""
        return int(round(self.duration_s * self.sample_rate_hz))

    def m_values(self) -> np.ndarray:
        """Every m from 1 up to the last with ``max_clusters_m`` clusters."""
        return np.arange(1, self.n_samples // self.max_clusters_m + 1)
PAPER_METHODS = {"ols": "Traditional least square (all data)",
                 "ols40": "Traditional least square (40% error)",
                 "wls": "Weighted least square"}


@dataclass(frozen=True)
class PaperGyro:
    """A gyro of the paper: true Q (urad), N (deg/sqrt(h)), B (deg/h) and its published table.

    ``published[method][term] = (mean, error_percent, std)``; ``None`` where the paper
    prints '-' (a negative estimate).
    """

    name: str
    table: str
    true: dict[str, float]
    published: dict[str, dict[str, tuple[float, float, float] | None]]


# Published values, Lv 2015 tables 1-6 (true values from tables 1, 3, 5; results from
# tables 2, 4, 6). Table 2's OLS-40% N standard deviation is printed "7.130 - 05": read as
# 7.130e-05.
PAPER_GYROS = (
    PaperGyro("SRS2000", "tables 1-2", {"Q": 6.870e-03, "N": 8.587e-05, "B": 6.773e-03}, {
        "ols": {"Q": (8.651e-03, 25.9, 8.971e-03), "N": None, "B": (9.312e-03, 37.5, 1.021e-02)},
        "ols40": {"Q": (7.249e-03, 5.5, 3.804e-03), "N": (7.398e-05, 13.8, 7.130e-05),
                  "B": (7.306e-03, 7.9, 4.984e-03)},
        "wls": {"Q": (6.920e-03, 0.7, 8.662e-04), "N": (8.389e-05, 2.3, 1.664e-05),
                "B": (7.007e-03, 3.5, 1.783e-03)},
    }),
    PaperGyro("VG951", "tables 3-4", {"Q": 7.555e-02, "N": 7.636e-03, "B": 1.246e-01}, {
        "ols": {"Q": (1.170e-01, 54.9, 1.123e-01), "N": (7.450e-03, 2.4, 2.071e-03),
                "B": (1.650e-01, 32.4, 1.299e-01)},
        "ols40": {"Q": (8.571e-02, 13.4, 6.844e-02), "N": (7.595e-03, 0.5, 1.261e-03),
                  "B": (1.358e-01, 8.9, 8.583e-02)},
        "wls": {"Q": (7.862e-02, 4.1, 4.392e-02), "N": (7.620e-03, 0.2, 8.279e-04),
                "B": (1.346e-01, 8.0, 8.912e-02)},
    }),
    PaperGyro("CRG20", "tables 5-6", {"Q": 1.868e01, "N": 1.492, "B": 2.079e01}, {
        "ols": {"Q": (2.657e01, 42.1, 2.038e01), "N": (1.449, 2.8, 3.755e-01),
                "B": (3.016e01, 45.1, 2.352e01)},
        "ols40": {"Q": (1.915e01, 2.5, 1.081e01), "N": (1.489, 0.2, 2.017e-01),
                  "B": (2.183e01, 5.0, 1.810e01)},
        "wls": {"Q": (1.895e01, 1.4, 9.626), "N": (1.490, 0.1, 1.812e-01),
                "B": (2.077e01, 0.1, 1.306e01)},
    }),
)


def _bias_instability(b_deg_s: float, setup: Lv2015Setup, rng: np.random.Generator) -> np.ndarray:
    n, fs = setup.n_samples, setup.sample_rate_hz
    if setup.bias_noise == "flicker":
        return flicker_rate_noise(b_deg_s, n, fs, rng)
    if setup.bias_noise == "markov":
        # one exponentially correlated rate whose Allan deviation peaks at 0.664 B
        t = setup.markov_correlation_s
        peak = float(np.max(gauss_markov_avar(np.geomspace(0.01, 100, 2001) * t, 1.0, t)))
        sigma = 0.664 * b_deg_s / math.sqrt(peak)
        a = math.exp(-1.0 / (fs * t))
        drive = sigma * math.sqrt(1.0 - a * a) * rng.standard_normal(n)
        state = sigma * rng.standard_normal()
        return signal.lfilter([1.0], [1.0, -a], drive, zi=[a * state])[0]
    if setup.bias_noise == "bank":
        model = NoiseModel((BiasInstability(B_deg_h=b_deg_s * 3600.0),))
        seed = int(rng.integers(2**63))
        return simulate(model, setup.duration_s, fs, seed=seed).rate_deg_s[:, 0]
    raise ValueError(f"unknown bias noise {setup.bias_noise!r}; use flicker, markov or bank")


def simulate_paper_gyro(true: dict[str, float], rng: np.random.Generator,
                        setup: Lv2015Setup | None = None) -> np.ndarray:
    """One simulated static run (deg/s) with the paper gyro's Q (urad), N (deg/sqrt(h)), B
    (deg/h)."""
    setup = setup or Lv2015Setup()
    n, fs = setup.n_samples, setup.sample_rate_hz
    return (white_angle_noise(q_urad_to_deg(true["Q"]), n, fs, rng)
            + white_rate_noise(arw_deg_rt_h_to_deg_rt_s(true["N"]), n, fs, rng)
            + _bias_instability(rate_deg_h_to_deg_s(true["B"]), setup, rng))


def _one_run(task: tuple[int, np.random.SeedSequence, Lv2015Setup]) -> tuple[int, dict[str, list]]:
    """Simulate one run of one gyro and fit it with every method: {method: [[Q,N,B],[stderrs]]}."""
    gyro_index, seed_seq, setup = task
    gyro = PAPER_GYROS[gyro_index]
    rate = simulate_paper_gyro(gyro.true, np.random.default_rng(seed_seq), setup)
    allan = allan_variance(rate, setup.sample_rate_hz, estimator=setup.estimator,
                           taus=setup.m_values() / setup.sample_rate_hz)
    out: dict[str, list] = {}
    for method, fit in fit_every_method(allan, terms=TERMS).items():
        values = [math.nan if fit.values[t] is None else fit.values[t] for t in TERMS]
        errors = [math.nan if fit.stderr[t] is None else fit.stderr[t] for t in TERMS]
        out[method] = [values, errors]
    return gyro_index, out


def _stats(true: float, values: np.ndarray, stderrs: np.ndarray) -> dict[str, float | int | None]:
    ok = np.isfinite(values)
    negative = int((~ok).sum())
    if not ok.any():
        return {"mean": None, "error_percent": None, "std": None, "negative": negative,
                "rms_error_percent": None, "mean_stderr": None, "coverage": None}
    v = values[ok]
    mean = float(v.mean())
    se = stderrs[ok]
    has_se = np.isfinite(se)
    return {
        "mean": mean,
        "error_percent": abs(mean - true) / true * 100.0,
        "std": float(v.std(ddof=1)) if len(v) > 1 else 0.0,
        "negative": negative,
        "rms_error_percent": float(np.sqrt(np.mean((v - true) ** 2))) / true * 100.0,
        "mean_stderr": float(np.mean(se[has_se])) if has_se.any() else None,
        # the share of runs whose value +- its own standard error holds the truth (68 % if honest)
        "coverage": float(np.mean(np.abs(v[has_se] - true) <= se[has_se]))
        if has_se.any()
        else None,
    }


def reproduce_lv2015(runs: int = 30, seed: int = 1, *, workers: int = 2, progress=None,
                     setup: Lv2015Setup | None = None, gyros: tuple[str, ...] | None = None
                     ) -> dict[str, object]:
    """Run the Monte Carlo and return the table as a JSON-ready dict.

    ``{"runs", "seed", "sample_rate_hz", "duration_s", "setup", "gyros": [{"name", "table",
    "true", "methods": [{"method", "paper_label", "Q": stats, "N": stats, "B": stats,
    "paper": {"Q": {"mean", "error_percent", "std"} or None, ...} or None}]}]}`` where
    stats are ``mean``, ``error_percent`` (of the mean), ``std``, ``negative`` (count of
    negative estimates, left out of the mean), ``rms_error_percent``, ``mean_stderr`` (the
    fit's own standard error, averaged: compare it with ``std``) and ``coverage`` (share
    of runs whose estimate +- its standard error holds the true value; 0.68 when honest).
    ``progress(done, total)`` is called after each run; ``gyros`` limits the study to
    the named gyros.
    """
    if runs < 2:
        raise ValueError("runs must be at least 2 to give a standard deviation")
    setup = setup or Lv2015Setup()
    chosen = [g for g, gyro in enumerate(PAPER_GYROS) if gyros is None or gyro.name in gyros]
    seeds = np.random.SeedSequence(seed).spawn(len(PAPER_GYROS) * runs)
    tasks = [(g, seeds[g * runs + r], setup) for g in chosen for r in range(runs)]
    collected: dict[int, dict[str, list]] = {g: {m: [] for m in FIT_METHODS} for g in chosen}
    done = 0
    if workers > 1:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            results = pool.map(_one_run, tasks, chunksize=max(1, len(tasks) // (8 * workers)))
            for g, out in results:
                for m in FIT_METHODS:
                    collected[g][m].append(out[m])
                done += 1
                if progress:
                    progress(done, len(tasks))
    else:
        for task in tasks:
            g, out = _one_run(task)
            for m in FIT_METHODS:
                collected[g][m].append(out[m])
            done += 1
            if progress:
                progress(done, len(tasks))
    table = []
    for g in chosen:
        gyro = PAPER_GYROS[g]
        methods = []
        for m in FIT_METHODS:
            arr = np.array(collected[g][m], dtype=float)  # runs x 2 x 3
            entry: dict[str, object] = {"method": m, "paper_label": PAPER_METHODS.get(m)}
            for i, term in enumerate(TERMS):
                entry[term] = _stats(gyro.true[term], arr[:, 0, i], arr[:, 1, i])
            pub = gyro.published.get(m)
            entry["paper"] = None if pub is None else {
                t: None if (cell := pub[t]) is None
                else dict(zip(("mean", "error_percent", "std"), cell, strict=True))
                for t in TERMS
            }
            methods.append(entry)
        table.append(
            {"name": gyro.name, "table": gyro.table, "true": gyro.true, "methods": methods}
        )
    return {"runs": runs, "seed": seed, "sample_rate_hz": setup.sample_rate_hz,
            "duration_s": setup.duration_s, "terms": TERMS, "setup": asdict(setup), "gyros": table}


def format_reproduction(table: dict[str, Any]) -> str:
    """The paper's table layout, ours beside the published values, as plain text."""
    units = {"Q": "Q [urad]", "N": "N [deg/sqrt(h)]", "B": "B [deg/h]"}
    setup = table.get("setup", {})
    grid = ("every m" if setup.get("max_clusters_m", 2) == 2 else
            f"every m up to N/{setup['max_clusters_m']}")
    lines = [
        f"Lv 2015 Monte Carlo: {table['runs']} runs, seed {table['seed']}, "
        f"{table['duration_s'] / 3600:g} h at {table['sample_rate_hz']:g} Hz, "
        f"{setup.get('estimator', 'clusters')} AVAR at {grid}, B as "
        f"{setup.get('bias_noise', 'flicker')} noise",
        "std: over the runs; [se: the fit's own standard error averaged over the runs, and the "
        "share of runs whose estimate +- se holds the true value, 68 % when honest]",
    ]

    for gyro in table["gyros"]:
        lines.append("")
        true = gyro["true"]
        lines.append(f"{gyro['name']} (paper {gyro['table']}): true " +
                     ", ".join(f"{units[t]} = {true[t]:.4g}" for t in "QNB"))
        lines.append(f"{'method':<8} {'':<6} " + "".join(f"{units[t]:>36}" for t in "QNB"))
        for m in gyro["methods"]:
            for who, stats in (("ours", {t: m[t] for t in "QNB"}), ("paper", m["paper"])):
                if stats is None:
                    continue
                row_mean, row_std = [], []
                for t in "QNB":
                    s = stats[t]
                    if s is None or s.get("mean") is None:
                        row_mean.append(f"{'-':>36}")
                        row_std.append(f"{'-':>36}")
                        continue
                    neg = f" neg {s['negative']:2d}" if "negative" in s else "       "
                    row_mean.append(f"{s['mean']:>17.4e} ({s['error_percent']:5.1f}%){neg}")
                    sd = f"{s['std']:.4e}"
                    if "mean_stderr" in s:
                        sd += (" [se n/a]" if s["mean_stderr"] is None else
                               f" [se {s['mean_stderr']:.2e} {100 * s['coverage']:3.0f}%]")
                    row_std.append(f"{sd:>36}")
                lines.append(f"{m['method']:<8} {who:<6} mean" + "".join(row_mean))
                lines.append(f"{'':<8} {'':<6} std " + "".join(row_std))
    return "\n".join(lines)
