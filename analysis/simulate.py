"""Moved to :mod:`analysis.models.simulation`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.models.simulation import (
    FLICKER_FLOOR_HZ as FLICKER_FLOOR_HZ,
    GyroSimulator as GyroSimulator,
    SimulatedChunk as SimulatedChunk,
    n_samples_of as n_samples_of,
    polled_loss as polled_loss,
    simulate as simulate,
    term_generator as term_generator,
)
from analysis.moved import warn_moved

warn_moved("analysis.simulate", "analysis.models.simulation")
