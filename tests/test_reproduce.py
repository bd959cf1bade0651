"""The WLS paper's Monte Carlo: the alternative ways of simulating its gyros hold their Allan
level."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.allan.estimators import overlapping_allan_variance
from station.evaluation.reproduce import Lv2015Setup, simulate_paper_gyro

#: B only (Q and N far below it), deg/h; 0.664 B is the Allan plateau or the Markov peak.
TRUE = {"Q": 1e-6, "N": 1e-6, "B": 10.0}


@pytest.mark.parametrize("bias_noise", ["flicker", "bank", "markov"])
def test_each_bias_generator_reaches_the_papers_allan_level(bias_noise: str) -> None:
    setup = Lv2015Setup(duration_s=3600.0, bias_noise=bias_noise, markov_correlation_s=10.0)
    level = (0.664 * TRUE["B"] / 3600.0) ** 2
    taus = np.array([1.0, 3.0, 10.0, 19.0, 30.0, 100.0])
    avar = np.mean(
        [
            overlapping_allan_variance(
                simulate_paper_gyro(TRUE, np.random.default_rng(s), setup),
                setup.sample_rate_hz,
                taus=taus,
            ).avar
            for s in range(4)
        ],
        axis=0,
    )
    if bias_noise == "markov":
        # one Gauss-Markov process: its Allan variance peaks at 0.664 B near tau = 1.89 T
        assert np.argmax(avar) == 3 and avar[3] == pytest.approx(level, rel=0.1)
        assert avar[-1] < 0.5 * level
    else:
        np.testing.assert_allclose(avar[1:], level, rtol=0.15)


def test_setup_grid_and_length() -> None:
    setup = Lv2015Setup(duration_s=100.0, max_clusters_m=9)
    assert setup.n_samples == 1000 and setup.m_values()[-1] == 1000 // 9
    assert Lv2015Setup().m_values()[-1] == Lv2015Setup().n_samples // 2
