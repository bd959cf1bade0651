"""``reproduce``: re-run a published Monte Carlo and set its table beside the paper's."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from station.evaluation.reproduce import reproduce_lv2015
from station.services.progress import Progress, ProgressSink, ignore_progress


@dataclass(frozen=True)
class ReproduceRequest:
    """Which study, how many simulated runs per gyro, the study's seed, processes to use."""

    paper: Literal["lv2015"] = "lv2015"
    runs: int = 30
    seed: int = 1
    workers: int = 2


def reproduce(request: ReproduceRequest,
              progress: ProgressSink = ignore_progress) -> dict[str, object]:
    """The study's table as a JSON-ready dict (:func:`reproduce_lv2015`); ``progress`` hears
    of every run."""

    def step(done: int, total: int) -> None:
        progress(Progress("reproduce", f"{done}/{total} runs", done, total))

    return reproduce_lv2015(request.runs, request.seed, workers=request.workers, progress=step)
