"""The Allan family (analysis.allan.deviations): against allantools, against Stable32's PHASE.DAT
outputs, by property, and the coverage of their intervals on white rate noise."""

from __future__ import annotations

import allantools
import numpy as np
import pytest

from analysis.allan.deviations import DEVIATION_KINDS, deviation
from analysis.allan.theo1 import theo1_sums
from analysis.errors import InvalidTauError, TooFewSamplesError
from analysis.models.noise import white_rate_noise
from tests.allantools_reference import STABLE32_KINDS, read_phase, read_stable32

ALLANTOOLS = {"oadev": allantools.oadev, "adev": allantools.adev, "mdev": allantools.mdev,
              "hdev": allantools.hdev, "ohdev": allantools.ohdev, "tdev": allantools.tdev,
              "totdev": allantools.totdev, "theo1": allantools.theo1}


def _random_rate(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.standard_normal(n) + np.cumsum(rng.standard_normal(n)) * 0.01 + 3.0


def _compare_with_allantools(kind: str, y: np.ndarray, fs: float) -> int:
    ours = deviation(y, fs, kind=kind, taus="log")
    m_ours = ours.m
    ref_tau, ref_dev, _, _ = ALLANTOOLS[kind](y, rate=fs, data_type="freq", taus=m_ours / fs)
    m_ref = np.rint(np.asarray(ref_tau) * fs).astype(int)  # allantools reports Theo1 at m / fs
    common = np.isin(m_ours, m_ref)
    np.testing.assert_allclose(
        ours.deviation[common], np.asarray(ref_dev)[np.isin(m_ref, m_ours)], rtol=1e-9
    )
    return int(common.sum())


@pytest.mark.parametrize("n", [1000, 4097])
@pytest.mark.parametrize("kind", [k for k in DEVIATION_KINDS if k != "theo1"])
def test_each_deviation_equals_allantools_on_random_data(kind: str, n: int) -> None:
    compared = _compare_with_allantools(kind, _random_rate(n, n), 12.5)
    assert compared >= 60  # allantools drops a few taus of its own; most are compared


def test_theo1_equals_allantools_on_random_data() -> None:
    # allantools' Theo1 is a pure-Python triple loop: a short record keeps it quick
    assert _compare_with_allantools("theo1", _random_rate(400, 7), 12.5) >= 15


@pytest.mark.parametrize("noise", ["white angle", "white rate", "rate random walk"])
def test_theo1_correlation_sums_equal_the_direct_sums(noise: str) -> None:
    rng = np.random.default_rng(11)
    w = rng.standard_normal(3001)
    x = {"white angle": w, "white rate": np.cumsum(w), "rate random walk": np.cumsum(np.cumsum(w))}[
        noise
    ]
    m = np.array([60, 400, 1500, 3000])
    direct, _ = theo1_sums(x, m, method="direct")
    fast, bound = theo1_sums(x, m, method="fast")
    err = np.abs(fast / direct - 1)
    assert np.all(err <= bound), (err, bound)  # the bound it reports holds
    assert np.all(err[1:] < 1e-9), err


# Stable32's outputs for PHASE.DAT (the phase file distributed with Stable32), as shipped in
# allantools' tests/phasedat: Stable32 1.53 (every tau) and 1.60 (octave taus, with
# intervals); Theo1 with alpha = 0 (no bias correction).
PHASEDAT_FILES = [
    "phase_dat_adev.txt",
    "phase_dat_oadev.txt",
    "phase_dat_mdev.txt",
    "phase_dat_tdev.txt",
    "phase_dat_hdev.txt",
    "phase_dat_ohdev.txt",
    "phase_dat_totdev.txt",
    "phase_dat_theo1_alpha0.txt",
    "phase_dat_theo1_alpha0_decade.txt",
    "phase_dat_adev_octave.txt",
    "phase_dat_oadev_octave.txt",
    "phase_dat_mdev_octave.txt",
    "phase_dat_tdev_octave.txt",
    "phase_dat_hdev_octave.txt",
    "phase_dat_ohdev_octave.txt",
    "phase_dat_totdev_octave.txt",
]


@pytest.mark.parametrize("name", PHASEDAT_FILES)
def test_phasedat_equals_stable32_to_the_printed_digits(allantools_tests, name: str) -> None:
    x = read_phase(allantools_tests / "phasedat" / "PHASE.DAT")
    sigma, rows = read_stable32(allantools_tests / "phasedat" / name)
    kind = STABLE32_KINDS.get(sigma) or ("theo1" if sigma.endswith("o1") else None)
    assert kind is not None, sigma
    taus = rows[:, 1] if kind == "theo1" else rows[:, 0]  # Theo1 tau = 0.75 AF
    ours = deviation(np.diff(x), 1.0, kind=kind, taus=taus)  # phase (s) -> rate at 1 Hz
    np.testing.assert_allclose(ours.tau_s, rows[:, 1], rtol=1e-12)
    printed = rows[:, 5]
    half_digit = 0.5 * 10.0 ** (np.floor(np.log10(printed)) - 4)  # 5 significant digits printed
    # a value on the rounding edge may print either way: 1e-6 of slack (PHASE.DAT tdev at
    # AF 47 is 0.788355, printed 0.78835)
    assert np.all(np.abs(ours.deviation - printed) <= half_digit + 1e-6 * printed), \
        np.max(np.abs(ours.deviation / printed - 1))


# ----------------------------------------------------------------------------- properties


@pytest.mark.parametrize("kind", DEVIATION_KINDS)
def test_scale_offset_and_axes(kind: str) -> None:
    y = _random_rate(600, 3)
    base = deviation(y, 2.0, kind=kind, taus="octave")
    scaled = deviation(7.5 * y - 40.0, 2.0, kind=kind, taus="octave")
    np.testing.assert_allclose(scaled.variance, 7.5**2 * base.variance, rtol=1e-9)
    both = deviation(np.stack([y, 2 * y], axis=1), 2.0, kind=kind, taus="octave")
    np.testing.assert_allclose(both.axis(1).variance, 4 * base.variance, rtol=1e-9)
    assert np.all(base.ci_low <= base.variance) and np.all(base.variance <= base.ci_high)
    assert base.unit == ("angle" if kind == "tdev" else "rate")


def test_relations_between_the_deviations() -> None:
    y = white_rate_noise(0.2, 5000, 10.0, np.random.default_rng(4))
    taus = np.array([0.1, 0.8, 12.0])
    mod = deviation(y, 10.0, kind="mdev", taus=taus)
    time_dev = deviation(y, 10.0, kind="tdev", taus=taus)
    np.testing.assert_allclose(time_dev.deviation, taus * mod.deviation / np.sqrt(3), rtol=1e-12)
    # at m = 1 the reflection adds nothing: total = overlapping Allan; modified = Allan
    one = [deviation(y, 10.0, kind=k, taus=[0.1]).variance[0] for k in ("totdev", "oadev", "mdev")]
    np.testing.assert_allclose(one, one[1], rtol=1e-12)


def test_bad_input_is_refused() -> None:
    y = np.ones(100)
    with pytest.raises(ValueError, match="unknown deviation"):
        deviation(y, 1.0, kind="mtie")  # type: ignore[arg-type]
    with pytest.raises(InvalidTauError, match="Theo1"):
        deviation(y, 1.0, kind="theo1", taus=[7.5 * 1.1])  # not 0.75 of an even m
    with pytest.raises(InvalidTauError, match="Theo1"):
        deviation(y, 1.0, kind="theo1", taus=[3.0])  # m = 4 < 10
    with pytest.raises(TooFewSamplesError):
        deviation(y, 1.0, kind="mdev", taus=[40.0])  # 3m > N + 1
    with pytest.raises(TooFewSamplesError):
        deviation(np.ones(9), 1.0, kind="theo1")  # no even m >= 10 fits


# -------------------------------------------------------------- intervals on white rate noise


def _white_rate_truth(
    kind: str, m: np.ndarray, tau_s: np.ndarray, s: float, fs: float
) -> np.ndarray:
    """Expected variance of each estimator for white rate noise of std s (deg/s) at fs."""
    if kind != "mdev":  # Allan = Hadamard = total = Theo1 (at its own tau) for white rate noise
        return s**2 / fs / tau_s
    out = []
    for mi in m:  # the box sum of m second differences weighs each rate sample by g
        tri = np.minimum(np.arange(2 * mi - 1) + 1, 2 * mi - 1 - np.arange(2 * mi - 1))
        g = np.zeros(3 * mi - 1)
        g[mi:] += tri
        g[: 2 * mi - 1] -= tri
        out.append((s / fs) ** 2 * np.sum(g * g.astype(float)) / (2 * mi**2 * (mi / fs) ** 2))
    return np.array(out)


@pytest.mark.parametrize("kind", ["mdev", "hdev", "ohdev", "totdev", "theo1"])
def test_white_rate_intervals_hold_the_truth_at_the_nominal_rate(kind: str) -> None:
    s, fs, n = 0.3, 50.0, 2048
    hits = []
    for seed in range(120):
        y = white_rate_noise(s / np.sqrt(fs), n, fs, np.random.default_rng(seed))
        r = deviation(y, fs, kind=kind, taus="octave")
        truth = _white_rate_truth(kind, r.m, r.tau_s, s, fs)
        hits.append((r.ci_low <= truth) & (truth <= r.ci_high))
    share = np.mean(hits)
    assert 0.62 <= share <= 0.80, (kind, share, np.mean(hits, axis=0))


# ------------------------------------------------------------------------ station analyze


@pytest.fixture(scope="module")
def small_record(tmp_path_factory):
    from station.storage.csv_records import write_csv_record

    rate = 0.01 + white_rate_noise(0.02, 6000, 20.0, np.random.default_rng(5), n_axes=2)
    return write_csv_record(
        tmp_path_factory.mktemp("dev") / "run.csv", rate, 20.0, axis_names=["x", "y"]
    )


def _analyze_json(capsys, *args: str) -> dict:
    from station.cli import main

    assert main(["analyze", *args, "--json"]) == 0
    return __import__("json").loads(capsys.readouterr().out)


def test_analyze_deviation_option(small_record, capsys) -> None:
    """--deviation picks the curve (tau_s, adev, adev_ci_*), never the fit or the figures."""
    base = _analyze_json(capsys, str(small_record))
    axis0 = base["axes"][0]
    assert axis0["deviation"] == "oadev" and axis0["estimator"] == "overlapping"
    assert axis0["n_clusters"][-1] == 2  # the log grid reaches two clusters
    rate = np.loadtxt(small_record, delimiter=",", skiprows=1, comments="#")[:, -2:]
    octave = _analyze_json(capsys, str(small_record), "--taus", "octave")["axes"][1]
    for kind in ("mdev", "tdev", "hdev", "totdev", "theo1"):
        doc = _analyze_json(capsys, str(small_record), "--deviation", kind, "--taus", "octave")
        axis = doc["axes"][1]
        expected = deviation(rate[:, 1], 20.0, kind=kind, taus="octave")
        assert axis["deviation"] == kind and axis["deviation_unit"] == (
            "deg" if kind == "tdev" else "deg/s"
        )
        np.testing.assert_allclose(axis["tau_s"], expected.tau_s)
        np.testing.assert_allclose(axis["adev"], expected.deviation, rtol=1e-9)
        np.testing.assert_allclose(axis["adev_ci_high"], expected.deviation_ci_high, rtol=1e-9)
        assert (
            len(axis["n_clusters"])
            == len(axis["edf"])
            == len(axis["noise_alpha"])
            == len(axis["tau_s"])
        )
        assert axis["fit"] == octave["fit"] and axis["figures"] == octave["figures"]
        assert axis["fit_from"] == "overlapping Allan variance"
    clusters = _analyze_json(capsys, str(small_record), "--deviation", "adev", "--taus", "octave")[
        "axes"
    ][0]
    assert clusters["estimator"] == "clusters" and clusters["deviation"] == "adev"


def test_analyze_deviation_table_and_bad_name(small_record, capsys) -> None:
    from station.cli import main

    assert main(["analyze", str(small_record), "--deviation", "mdev", "--taus", "octave"]) == 0
    out = capsys.readouterr().out
    assert (
        "modified Allan deviation [deg/h]" in out
        and "fit and figures above are on the Allan variance" in out
    )
    with pytest.raises(SystemExit) as exc:
        main(["analyze", str(small_record), "--deviation", "mtie"])
    assert exc.value.code == 2


def test_analyze_refuses_a_deviation_that_cannot_skip_gaps(tmp_path, capsys) -> None:
    from station.cli import main
    from station.storage.csv_records import write_csv_record

    rate = white_rate_noise(0.02, 4000, 10.0, np.random.default_rng(2))
    index = np.concatenate([np.arange(2000), np.arange(2500, 4500)])  # a 50 s outage
    path = write_csv_record(tmp_path / "gap.csv", rate, 10.0, axis_names=["x"], sample_index=index)
    assert main(["analyze", str(path), "--deviation", "mdev"]) == 2
    assert "gap-free stretch" in capsys.readouterr().err
    assert main(["analyze", str(path), "--deviation", "oadev", "--json"]) == 0  # the Allan ones do
