"""Model versus measurement: time-series evidence that confirms (and refines) a named effect.

The Allan curve says how much variance sits at which tau; some effects leave a sharper
mark on the time series itself, and the reconcile workflow names them only when it is
there:

* **sinusoid**: a periodogram peak near the fitted period. Block means of the rate
  (at least 16 per period) are detrended; the peak power in ``[f0/1.5, 1.5 f0]`` over
  the background level (a quadratic in log-log fitted to the log periodogram over
  ``[f0/4, 4 f0]`` less the peak band, so that the knee of a Gauss-Markov spectrum is
  followed, plus Euler's gamma, the mean log of an Exp(1) variable) is, for a
  Gaussian background, an Exp(1) ordinate, so
  ``p = 1 - (1 - exp(-r))^M`` over the ``M`` frequencies of the peak band (S1). The
  period, amplitude and phase are then fitted by nonlinear least squares to the block
  means (started on the line's own lobe: the periodogram's largest value within a bin of
  the peak, 16 trial frequencies per bin, and the phase by linear least squares there),
  the amplitude corrected for the block averaging by ``sinc(pi f T_b)``. A line whose
  frequency wanders over the record (a MEMS resonance) holds more power than any
  one sinusoid: when the line the Welch test of :mod:`analysis.figures.tones` finds within the
  peak band carries more than ``AMPLITUDE_AGREEMENT`` times the fitted sinusoid's
  amplitude, the sinusoid of equal power at the line's mean frequency is taken (its
  Allan variance is the line's at taus beyond a few periods).
* **bias steps**: a change-point test on block means. Steps are the one candidate that
  is not Gaussian: a step of size s moves the difference of block means two apart,
  ``d_j = y_(j+2) - y_j``, by the whole s, while every Gaussian process (white noise,
  flicker, Gauss-Markov, random walk) leaves the ``d_j`` normal. A ``d_j`` beyond
  ``t sigma`` (sigma from the median absolute deviation, t the Bonferroni bound for a
  family-wise level ``alpha`` over every block length and j) is a change point (S2);
  non-maximum suppression over +-2 blocks keeps one per step. The rate is the number of
  steps per hour and the size their root mean square.
* **temperature-driven bias**: the least-squares slope of the rate on the measured
  temperature, against the slopes of the model's simulated runs on the same temperature
  (the Monte Carlo null of :mod:`analysis.reconcile.discrepancy`): confirmed when it lies more than
  ``Z_CONFIRM`` null standard deviations from the null mean (S3). The temperature profile
  (warm-up exponential plus a cycle) is fitted to the channel for the model term.
* **rate ramp**: the same test on the slope of the rate against time (S4).

:class:`RoundEvidence` applies them to the candidates of one round of the reconcile loop,
on the rate less the model's deterministic terms and the events already located, and
adds two agreement checks: a periodogram line (a trend) names a sinusoid (a ramp) only
if its amplitude (slope) is within a factor ``AMPLITUDE_AGREEMENT`` (``RAMP_AGREEMENT``)
of the one the Allan curve asks for, since a line too weak to explain the curve is not
what the curve shows (a random walk's record has a trend, a Gauss-Markov spectrum a
knee); a Gauss-Markov fit whose correlation time reaches a quarter of the record is
refused as indistinguishable from a rate random walk. A rate ramp is refused when the
trend follows the temperature channel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from analysis.distributions import normal_isf
from analysis.figures.tones import Tone, find_tones
from analysis.models.simulation import simulate
from analysis.models.terms import (
    BiasSteps,
    GaussMarkov,
    NoiseModel,
    NoiseTerm,
    RateRamp,
    Sinusoid,
    TemperatureBias,
)
from analysis.reconcile.candidates import MIN_CYCLES, CandidateFit
from analysis.reconcile.discrepancy import (
    Comparison,
    ComparisonCache,
    MeasuredCurve,
    block_means,
    regression_slopes,
)
from analysis.reconcile.line_test import LineDetection, strongest_line
from analysis.reconcile.process_test import detect_process
from analysis.units import conversions as units

#: Null standard deviations a regression slope must clear (S3, S4): p about 6e-5 if normal.
Z_CONFIRM = 4.0
#: Family-wise level of the periodogram and change-point tests (S1, S2).
ALPHA_CONFIRM = 1e-3
#: Number of blocks of the change-point test's block lengths.
STEP_BLOCK_COUNTS = (400, 160, 64)


@dataclass(frozen=True)
class Evidence:
    """What the time series says about one effect.

    Attributes
    ----------
    confirmed : bool
        Whether the test is significant.
    statistic : str
        The test and its value, for the report.
    values, stderr : dict
        Parameters it measures (term keys with units) and their standard errors.
    """

    confirmed: bool
    statistic: str
    values: dict[str, float]
    stderr: dict[str, float]


def periodogram_peak(rate: NDArray[np.float64], sample_rate_hz: float, period_s: float,
                     *, alpha: float = ALPHA_CONFIRM) -> Evidence:
    """Test for a periodogram peak near ``period_s`` and fit the sinusoid there (S1)."""
    from scipy import optimize
    block = max(1, int(period_s * sample_rate_hz / 16))
    y = block_means(rate, block)
    dt = block / sample_rate_hz
    n = len(y)
    t = np.asarray((np.arange(n) + 0.5) * dt, dtype=np.float64)
    resid = y - np.polyval(np.polyfit(t, y, 1), t)
    power = np.abs(np.fft.rfft(resid)) ** 2
    freq = np.fft.rfftfreq(n, dt)
    f0 = 1.0 / period_s
    peak_band = (freq >= f0 / 1.5) & (freq <= f0 * 1.5) & (freq > 0)
    background = (freq >= f0 / 4) & (freq <= f0 * 4) & ~peak_band & (freq > 0)
    if peak_band.sum() < 1 or background.sum() < 5:
        return Evidence(False, "periodogram: record too short around this period", {}, {})
    # background: a power law fitted to the log periodogram around the band; the log of an
    # Exp(1) ordinate has mean -gamma (Euler), so the level is exp(fit + gamma)
    coef = np.polyfit(np.log(freq[background]), np.log(power[background]), 2)
    i_peak = int(np.flatnonzero(peak_band)[np.argmax(power[peak_band])])
    level = math.exp(float(np.polyval(coef, math.log(freq[i_peak]))) + np.euler_gamma)
    ratio = float(power[i_peak]) / level
    m = int(peak_band.sum())
    p = float(-np.expm1(m * np.log1p(-math.exp(-ratio)))) if ratio < 700 else 0.0
    f_start = _finest_peak(resid, t, freq[i_peak], 1.0 / (n * dt))

    def sine(
        tt: NDArray[np.float64], a: float, b: float, f: float, c: float, s: float
    ) -> NDArray[np.float64]:
        return a * np.sin(2 * np.pi * f * tt) + b * np.cos(2 * np.pi * f * tt) + c + s * tt

    try:
        popt, pcov = optimize.curve_fit(sine, t, y, p0=_linear_start(t, y, f_start))
    except (RuntimeError, optimize.OptimizeWarning):
        return Evidence(
            False, f"periodogram peak ratio {ratio:.1f}, p = {p:.2g}; sine fit failed", {}, {}
        )
    a, b, f = popt[0], popt[1], abs(popt[2])
    sinc = math.sin(math.pi * f * dt) / (math.pi * f * dt)
    amp = math.hypot(a, b) / sinc
    var = np.diag(pcov)
    amp_err = math.sqrt(max((a**2 * var[0] + b**2 * var[1]) / max(a**2 + b**2, 1e-300), 0.0)) / sinc
    values = {"amplitude_deg_h": units.rate_deg_s_to_deg_h(amp), "period_s": 1.0 / f,
              "phase_deg": math.degrees(math.atan2(b, a)) * math.copysign(1.0, popt[2])}
    stderr = {"amplitude_deg_h": units.rate_deg_s_to_deg_h(amp_err),
              "period_s": math.sqrt(max(var[2], 0.0)) / f**2}
    text = f"periodogram peak at {1.0 / f:.4g} s, {ratio:.1f} x background, p = {p:.2g}"
    line = _wandering_line(rate, sample_rate_hz, f0, amp)
    if line is not None:
        values = {"amplitude_deg_h": units.rate_deg_s_to_deg_h(line.amplitude_deg_s),
                  "period_s": 1.0 / line.freq_hz, "phase_deg": 0.0}
        spread_hz = (line.band_hz[1] - line.band_hz[0]) / math.sqrt(12.0)
        stderr = {"amplitude_deg_h": units.rate_deg_s_to_deg_h(line.amplitude_stderr_deg_s),
                  "period_s": spread_hz / line.freq_hz**2}
        text += (f"; a line over {line.band_hz[0]:.4g}-{line.band_hz[1]:.4g} Hz carrying "
                 f"{line.amplitude_deg_s / amp:.1f} x one sinusoid's amplitude: its power taken")
    return Evidence(p < alpha, text, values, stderr)


#: Trial frequencies per periodogram bin where a sinusoid's fit starts (S1).
START_POINTS_PER_BIN = 16


def _finest_peak(resid: NDArray[np.float64], t: NDArray[np.float64], f_peak: float,
                 bin_hz: float) -> float:
    """Frequency (Hz) of the largest periodogram value within a bin of ``f_peak``.

    The sine fit of S1 is a least-squares problem with a minimum per lobe of the
    periodogram in frequency; started at a whole bin, up to half a bin from a line between
    two bins, it can settle on a side lobe (a slow line of 380 s in an hour came out at 447
    s with a fifth of its amplitude). The periodogram evaluated ``START_POINTS_PER_BIN``
    times per bin within +-1 bin of the peak puts the start on the line's own lobe.
    """
    trial = f_peak + bin_hz * np.linspace(-1.0, 1.0, 2 * START_POINTS_PER_BIN + 1)
    trial = trial[trial > 0]
    phase = np.exp(-2j * np.pi * np.outer(trial, t))
    return float(trial[int(np.argmax(np.abs(phase @ resid)))])


def _linear_start(t: NDArray[np.float64], y: NDArray[np.float64], f_hz: float) -> list[float]:
    """Start of the sine fit at frequency ``f_hz``: ``[a, b, f, c, s]`` of ``a sin + b cos + c +
    s t`` by linear least squares (the phase and offset of the data, not a guess)."""
    w = 2.0 * np.pi * f_hz * t
    design = np.column_stack([np.sin(w), np.cos(w), np.ones_like(t), t])
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    return [float(coef[0]), float(coef[1]), f_hz, float(coef[2]), float(coef[3])]


def _wandering_line(
    rate: NDArray[np.float64], sample_rate_hz: float, f0: float, coherent_deg_s: float
) -> Tone | None:
    """The Welch line in ``[f0/1.5, 1.5 f0]`` when it carries more than ``AMPLITUDE_AGREEMENT``
    times the coherent sinusoid's amplitude (a line whose frequency wanders), else None."""
    near = [t for t in find_tones(rate, sample_rate_hz) if f0 / 1.5 <= t.freq_hz <= 1.5 * f0]
    if not near:
        return None
    line = max(near, key=lambda t: t.amplitude_deg_s)
    return line if line.amplitude_deg_s > AMPLITUDE_AGREEMENT * coherent_deg_s else None


@dataclass(frozen=True)
class StepEvidence(Evidence):
    """Change points found by :func:`detect_steps`: where (s) and how big (deg/s) each step is."""

    times_s: tuple[float, ...] = ()
    sizes_deg_s: tuple[float, ...] = ()

    def series(self, n_samples: int, sample_rate_hz: float) -> NDArray[np.float64]:
        """The bias the located steps make, as a rate (deg/s) of ``n_samples`` samples."""
        out = np.zeros(n_samples)
        for t, size in zip(self.times_s, self.sizes_deg_s, strict=True):
            out[min(n_samples, int(round(t * sample_rate_hz))):] += size
        return out


def _locate(rate: NDArray[np.float64], lo: int, hi: int) -> tuple[int, float]:
    """Sample index in ``[lo, hi)`` that best splits the mean (largest two-sample t), and the
    jump."""
    x = rate[lo:hi]
    n = len(x)
    k = np.arange(1, n)
    c = np.cumsum(x)[:-1]
    before = c / k
    after = (c[-1] + x[-1] - c) / (n - k)
    t = np.abs(after - before) * np.sqrt(k * (n - k) / n)
    best = int(np.argmax(t))
    return lo + best + 1, float(after[best] - before[best])


def detect_steps(
    rate: NDArray[np.float64], sample_rate_hz: float, *, alpha: float = ALPHA_CONFIRM
) -> StepEvidence:
    """Change points of the bias (S2): where they are, their count per hour and their rms size.

    Each jump of the block-mean differences is then located to the sample by the largest
    two-sample t statistic between the block before and the block after it, and its size
    is the difference of the means over the neighbouring blocks.
    """
    duration_h = len(rate) / sample_rate_hz / units.S_PER_H
    lengths = sorted({max(1, len(rate) // k) for k in STEP_BLOCK_COUNTS})
    n_tests = sum(len(rate) // b for b in lengths)
    t_bound = float(normal_isf(alpha / (2.0 * n_tests)))
    best: tuple[int, list[int], int] | None = None
    for b in lengths:
        y = block_means(rate, b)
        if len(y) < 12:
            continue
        d = y[2:] - y[:-2]
        sigma = 1.4826 * float(np.median(np.abs(d - np.median(d))))
        if sigma <= 0:
            continue
        over = np.abs(d) > t_bound * sigma
        picks: list[int] = []
        for j in np.argsort(-np.abs(d)):
            if not over[j]:
                break
            if all(abs(j - q) > 2 for q in picks):
                picks.append(int(j))
        if picks and (best is None or len(picks) > len(best[1])):
            best = (b, sorted(picks), len(y))
    if best is None:
        return StepEvidence(
            False, f"change-point test: no block-mean jump beyond {t_bound:.1f} sigma", {}, {}
        )
    b, picks, n_blocks = best
    located = [_locate(rate, j * b, (j + 3) * b) for j in picks]
    times = tuple(i / sample_rate_hz for i, _ in located)
    sizes = np.array([float(np.mean(rate[i:i + 2 * b]) - np.mean(rate[max(0, i - 2 * b):i]))
                      for i, _ in located])
    count = len(sizes)
    rms = float(np.sqrt(np.mean(sizes**2)))
    values = {"rate_per_h": count / duration_h, "size_deg_h": units.rate_deg_s_to_deg_h(rms)}
    stderr = {"rate_per_h": math.sqrt(count) / duration_h,
              "size_deg_h": units.rate_deg_s_to_deg_h(rms) / math.sqrt(2.0 * count)}
    where = ", ".join(
        f"{units.rate_deg_s_to_deg_h(sz):+.3g} deg/h at {t:.0f} s"
        for t, sz in zip(times, sizes, strict=True)
    )
    return StepEvidence(
        True,
        f"change-point test: {count} step(s) beyond {t_bound:.1f} sigma "
        f"({n_blocks} blocks of {b / sample_rate_hz:.3g} s): {where}",
        values,
        stderr,
        times_s=times,
        sizes_deg_s=tuple(float(x) for x in sizes),
    )


def slope_test(
    slope: float, null_slopes: NDArray[np.float64], label: str
) -> tuple[bool, float, str]:
    """Whether a regression slope clears ``Z_CONFIRM`` null standard deviations (S3, S4)."""
    mu, sd = float(np.mean(null_slopes)), float(np.std(null_slopes, ddof=1))
    z = (slope - mu) / sd if sd > 0 else math.inf
    return (
        abs(z) >= Z_CONFIRM,
        sd,
        f"{label}: slope {z:+.1f} null standard deviations from the model's runs",
    )


def temperature_regression(rate: NDArray[np.float64], temperature_c: NDArray[np.float64],
                           null_slopes: NDArray[np.float64]) -> Evidence:
    """Slope of the rate on the temperature (deg/s per degC) against the model's null (S3)."""
    slope = float(regression_slopes(rate[:, None], temperature_c)[0])
    ok, sd, text = slope_test(slope, null_slopes, "rate on temperature")
    return Evidence(ok, text, {"coefficient_deg_s_per_c": slope}, {"coefficient_deg_s_per_c": sd})


def trend_test(
    rate: NDArray[np.float64], sample_rate_hz: float, null_slopes: NDArray[np.float64]
) -> Evidence:
    """Slope of the rate on time (deg/h^2) against the model's null (S4)."""
    t = np.arange(len(rate)) / sample_rate_hz
    slope = float(regression_slopes(rate[:, None], t)[0])
    ok, sd, text = slope_test(slope, null_slopes, "rate on time")
    return Evidence(ok, text, {"R_deg_h2": units.ramp_deg_s2_to_deg_h2(slope)},
                    {"R_deg_h2": units.ramp_deg_s2_to_deg_h2(sd)})


def fit_temperature_profile(
    temperature_c: NDArray[np.float64], sample_rate_hz: float
) -> dict[str, float]:
    """Keys of a :class:`analysis.models.TemperatureBias` profile fitted to a temperature channel.

    ``T(t) = final + (start - final) exp(-t / W) + C sin(2 pi t / P + phi)``: the warm-up by
    nonlinear least squares, then the cycle at the residual's strongest Fourier frequency
    if it halves the residual variance. ``reference_c`` is the mean temperature.
    """
    from scipy import optimize
    block = max(1, len(temperature_c) // 2000)
    y = block_means(temperature_c, block)
    dt = block / sample_rate_hz
    t = np.asarray((np.arange(len(y)) + 0.5) * dt, dtype=np.float64)
    length = len(temperature_c) / sample_rate_hz
    out = {
        "reference_c": float(np.mean(temperature_c)),
        "start_c": float(y[0]),
        "final_c": float(y[-1]),
        "warmup_s": length / 4.0,
    }

    def warm(
        tt: NDArray[np.float64], final: float, delta: float, log_w: float
    ) -> NDArray[np.float64]:
        return np.asarray(final + delta * np.exp(-tt / math.exp(log_w)), dtype=np.float64)

    try:
        popt, _ = optimize.curve_fit(
            warm, t, y, p0=[float(y[-1]), float(y[0] - y[-1]), math.log(length / 4)], maxfev=2000
        )
        out.update(
            final_c=float(popt[0]), start_c=float(popt[0] + popt[1]), warmup_s=math.exp(popt[2])
        )
        resid = y - warm(t, *popt)
    except RuntimeError:
        resid = y - y.mean()
    spec = np.abs(np.fft.rfft(resid - resid.mean()))
    k = int(np.argmax(spec[1:])) + 1 if len(spec) > 2 else 0
    if k:
        f = k / (len(y) * dt)
        design = np.column_stack(
            [np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t), np.ones_like(t)]
        )
        coef, *_ = np.linalg.lstsq(design, resid, rcond=None)
        if np.var(resid - design @ coef) < 0.5 * np.var(resid):
            out.update(
                cycle_amplitude_c=float(math.hypot(coef[0], coef[1])),
                cycle_period_s=1.0 / f,
                cycle_phase_deg=math.degrees(math.atan2(coef[1], coef[0])),
            )
    return out


# ----------------------------------------------------------- the confirmations of a round


#: A ramp (sinusoid) is named only if the time series' slope (line amplitude) and the
#: curve's fit agree within this factor.
RAMP_AGREEMENT = 1.5
AMPLITUDE_AGREEMENT = 1.5
#: A Gauss-Markov fit whose correlation time reaches this share of the record is a random walk.
GM_TAU_LIMIT = 0.25
#: Deterministic terms the time-series tests remove (as the model has them) before testing.
DETERMINISTIC = (Sinusoid, RateRamp, TemperatureBias)


def _deterministic_part(model: NoiseModel, curve: MeasuredCurve,
                        known: dict[str, NDArray[np.float64]]) -> NDArray[np.float64]:
    """Rate (deg/s) of the model's deterministic terms and located events in this record.

    The temperature bias is taken on the measured temperature, ``c (T - mean T)``.
    """
    out = np.zeros(curve.n_samples)
    for series in known.values():
        out += series
    for term in model.terms:
        if isinstance(term, TemperatureBias) and curve.temperature_c is not None:
            out += term.coefficient_deg_s_per_c * (curve.temperature_c - curve.temperature_c.mean())
        elif isinstance(term, DETERMINISTIC):
            out += simulate(
                NoiseModel(terms=(term,)), curve.duration_s, curve.sample_rate_hz
            ).rate_deg_s[:, 0]
    return out


class RoundEvidence:
    """The time-series tests of one round of the reconcile loop and what they allow.

    The tests run on the rate less the model's deterministic terms and the events already
    located (:func:`_deterministic_part`); :meth:`confirm` says whether a candidate is
    confirmed and gives the term to add (with the parameters the time series measures).
    """

    def __init__(self, curve: MeasuredCurve, comparison: Comparison,
                 known: dict[str, NDArray[np.float64]]) -> None:
        self.curve, self.comparison = curve, comparison
        self.residual = curve.rate_deg_s - _deterministic_part(comparison.model, curve, known)
        self.steps: StepEvidence = detect_steps(self.residual, curve.sample_rate_hz)
        self.line: LineDetection | None = strongest_line(
            self.residual, curve.sample_rate_hz, min_cycles=MIN_CYCLES
        )

    def line_sinusoid(self) -> tuple[Sinusoid, Evidence] | None:
        """The sinusoid of the spectral line the line test detects
        (:mod:`analysis.reconcile.line_test`, L2), fitted to the time series as
        :func:`periodogram_peak` fits it; None when no line is detected or the model has a sinusoid
        already."""
        line = self.line
        if line is None or not line.significant() or "sinusoid" in self.comparison.model:
            return None
        ev = periodogram_peak(self.residual, self.curve.sample_rate_hz, 1.0 / line.freq_hz)
        if "amplitude_deg_h" not in ev.values:
            return None
        return Sinusoid(**ev.values), Evidence(True, f"{line.statistic}; {ev.statistic}",
                                               ev.values, ev.stderr)

    def missing_process(self, alpha: float, seed: int, cache: ComparisonCache | None = None,
                        ) -> tuple[GaussMarkov, Evidence] | None:
        """The Gauss-Markov process the spectral process test finds the model lacking
        (:mod:`analysis.reconcile.process_test`, P3 at level ``alpha``, its thresholds kept in
        ``cache``); None when it finds none or the model has a Gauss-Markov process already."""
        if "gauss_markov" in self.comparison.model:
            return None
        found = detect_process(self.residual, self.curve.sample_rate_hz, self.comparison.model,
                               alpha=alpha, seed=seed, cache=cache)
        if found is None or not found.significant:
            return None
        term = found.term()
        return term, Evidence(True, found.describe(), term.to_table(), {})

    def step_series(self) -> NDArray[np.float64] | None:
        """The bias the located steps make (deg/s per sample), when steps were found."""
        if not self.steps.confirmed:
            return None
        return self.steps.series(self.curve.n_samples, self.curve.sample_rate_hz)

    def confirm(
        self, fit: CandidateFit, change: str
    ) -> tuple[NoiseTerm | None, Evidence | None, str]:
        """(term to add, evidence, reason it is refused); term None when refused."""
        curve, band = self.curve, self.comparison.band
        if change == "decreased":
            return fit.term, None, ""
        name = fit.name
        if (
            name == "gauss_markov"
            and fit.values.get("tau_s", 0.0) >= GM_TAU_LIMIT * curve.duration_s
        ):
            return (
                None,
                None,
                (
                    f"correlation time {fit.values['tau_s']:.4g} s at the record's length: "
                    "indistinguishable from a rate random walk"
                ),
            )
        if name == "bias_steps":
            return BiasSteps(**self.steps.values), self.steps, ""
        if name == "sinusoid":
            ev = periodogram_peak(self.residual, curve.sample_rate_hz, fit.values["period_s"])
            if not ev.confirmed:
                return None, ev, f"no periodogram peak ({ev.statistic})"
            ratio = ev.values["amplitude_deg_h"] / fit.values["amplitude_deg_h"]
            if not 1.0 / AMPLITUDE_AGREEMENT <= ratio <= AMPLITUDE_AGREEMENT:
                return None, ev, (f"the periodogram line's amplitude is {ratio:.2g} x the curve's: "
                                  "the line does not explain the curve")
            return Sinusoid(**ev.values), ev, ""
        if name == "temperature_bias":
            if curve.temperature_c is None or band.temperature_slopes is None:
                return None, None, "the record has no temperature channel"
            ev = temperature_regression(
                curve.rate_deg_s, curve.temperature_c, band.temperature_slopes
            )
            if not ev.confirmed:
                return None, ev, f"no correlation with temperature ({ev.statistic})"
            profile = fit_temperature_profile(curve.temperature_c, curve.sample_rate_hz)
            return TemperatureBias(**ev.values, **profile), ev, ""
        if name == "rate_ramp":
            if curve.temperature_c is not None and band.temperature_slopes is not None:
                temp = temperature_regression(
                    curve.rate_deg_s, curve.temperature_c, band.temperature_slopes
                )
                if temp.confirmed:
                    return (
                        None,
                        temp,
                        "the trend follows the temperature: temperature_bias, not a ramp",
                    )
            ev = trend_test(curve.rate_deg_s, curve.sample_rate_hz, band.trend_slopes)
            if not ev.confirmed:
                return None, ev, f"no trend ({ev.statistic})"
            ratio = abs(ev.values["R_deg_h2"]) / fit.values["R_deg_h2"]
            if not 1.0 / RAMP_AGREEMENT <= ratio <= RAMP_AGREEMENT:
                return (
                    None,
                    ev,
                    (
                        f"the trend's ramp is {ratio:.2g} x the curve's: the curve rises for "
                        "another reason (a random walk)"
                    ),
                )
            return RateRamp(**ev.values), ev, ""
        return fit.term, None, ""
