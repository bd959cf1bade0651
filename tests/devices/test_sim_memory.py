"""A simulated unit runs overnight in bounded memory.

At 2 kHz a 12 h run generates 86.4 million samples: kept as rates (24 bytes each) and
lost indices, that was about 2 GB per unit. The simulator now keeps counts, and the
rates and lost indices of a bounded window only when a test asks for them (``history=``).
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from devices.sim.faults import RateHistory
from devices.urls import parse_sim_params, sim_core

CHUNK = 5_000


def _run(core, n_chunks: int) -> None:
    """Generate ``n_chunks`` x CHUNK samples as fast as they come and lose them all (a
    disconnected device: every index goes through the ledger)."""
    for _ in range(n_chunks):
        readings = core.due(CHUNK)
        assert len(readings) == CHUNK
        core.lose(readings)


@pytest.mark.parametrize("history", [0, 2000])
@pytest.mark.slow
def test_a_long_simulation_keeps_memory_bounded(history: int) -> None:
    # warp 1e9: any wall time is years of device time, so due() always has CHUNK ready
    params = parse_sim_params("STIM300", {"rate": "2000", "warp": "1e9", "seed": "3",
                                          "history": str(history)})
    core, _ = sim_core(params, 3)
    _run(core, 2)  # warm up (the signal generator's buffers)
    tracemalloc.start()
    try:
        before, _ = tracemalloc.get_traced_memory()
        # 50,000 more samples: 1.2 MB of rates if they were all kept, 1.8 MB as a list
        # of lost indices (3 to 4 times the bound; tracemalloc slows generation 4-fold)
        _run(core, 10)
        after, _ = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert after - before < 400_000, f"grew by {after - before} bytes"
    ledger = core.ledger
    assert ledger.generated == ledger.lost_in_outage == 60_000
    assert len(ledger.lost_indices) == history
    if history:
        assert core.history_start == 60_000 - history
        assert list(ledger.lost_indices)[-1] == 59_999
        assert core.history().shape == (history, 3)


def test_rate_history_window_returns_the_latest_samples_by_index() -> None:
    ring = RateHistory(4, 1)
    ring.extend(0, np.arange(3.0)[:, None])
    ring.extend(3, np.arange(3.0, 9.0)[:, None])  # more than the window at once
    assert ring.start == 5
    np.testing.assert_array_equal(ring.rates([8, 5, 6]).ravel(), [8.0, 5.0, 6.0])
    np.testing.assert_array_equal(ring.rates().ravel(), [5.0, 6.0, 7.0, 8.0])
    with pytest.raises(IndexError):
        ring.rates([4])
    with pytest.raises(IndexError):
        RateHistory(0, 3).rates([0])
