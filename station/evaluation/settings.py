"""The analysis settings a product profile implies, in one place: warm-up, tau grid, fit, DAVAR map.

Every view of a graded run (the spec sheets, the TUI, ``station analyze --profile``)
takes these from :func:`settings_of`, so the warm-up discarded, the Allan grid and fit,
and the dynamic Allan deviation heat map are the same wherever a run is shown.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from analysis.allan.kinds import Estimator
from analysis.fit.methods import FitMethod
from station.model.profiles import DEFAULT_FIT_METHOD

if TYPE_CHECKING:
    from station.model.profiles import Profile

#: The tau grids ``station analyze`` offers (:func:`analysis.allan.resolve_m`).
TauGrid = Literal["log", "octave", "all"]
TAU_GRIDS: tuple[TauGrid, ...] = ("log", "octave", "all")
#: The DAVAR heat map of a spec sheet: at most this many windows, a step of half a window;
#: each window at least this many samples (taus over two decades); this many log-spaced
#: taus (a terminal map has 2 pixels a row: 48 fill 24 rows, and cost half of the default
#: 100; a PDF panel is as readable).
DAVAR_WINDOWS = 40
DAVAR_MIN_WINDOW_SAMPLES = 900
DAVAR_TAUS = 48


@dataclass(frozen=True)
class AnalysisSettings:
    """How a record is analysed for a profile (times in s).

    Attributes
    ----------
    warmup_s : float
        Warm-up discarded from the start of the record before the Allan analysis.
    estimator : {"overlapping", "clusters"}
        Allan estimator of the fit and the figures.
    taus : {"log", "octave", "all"}
        Tau grid of the Allan variance (``"log"``: :func:`analysis.allan.analysis_log_m`).
    fit_method : str
        Noise-term fit method (:data:`analysis.fit.FIT_METHODS`).
    davar_windows, davar_min_window_samples, davar_taus : int
        The DAVAR heat map: most windows, fewest samples a window, taus per window.
    """

    warmup_s: float = 0.0
    estimator: Estimator = "overlapping"
    taus: TauGrid = "log"
    fit_method: FitMethod = DEFAULT_FIT_METHOD
    davar_windows: int = DAVAR_WINDOWS
    davar_min_window_samples: int = DAVAR_MIN_WINDOW_SAMPLES
    davar_taus: int = DAVAR_TAUS

    def davar_plan(self, n_samples: int) -> tuple[int, int]:
        """Window and step (samples) of the heat map's DAVAR of a record of ``n_samples``.

        The step is half a window and the windows cover the record: as many windows as
        :attr:`davar_windows` allows while each keeps :attr:`davar_min_window_samples`
        (one window of the whole record when it is shorter than two of those). ``(0, 0)``
        when the record has fewer than 2 samples.
        """
        if n_samples < 2:
            return 0, 0
        n_windows = max(1, min(self.davar_windows,
                               2 * n_samples // max(1, self.davar_min_window_samples) - 1))
        step = n_samples // (n_windows + 1)
        return 2 * step, step


def settings_of(profile: Profile | None) -> AnalysisSettings:
    """The analysis settings of ``profile`` (the defaults when there is none)."""
    if profile is None:
        return AnalysisSettings()
    return AnalysisSettings(warmup_s=max(0.0, profile.warmup_s), fit_method=profile.fit_method)
