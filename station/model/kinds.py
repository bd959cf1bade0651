"""Names of kinds the station compares, as Literal types the type checker holds to."""

from __future__ import annotations

from typing import Literal, get_args

#: The verdict of one figure against one limit (:func:`station.evaluation.grading.decide`).
Verdict = Literal["pass", "fail", "indeterminate"]
VERDICTS: tuple[Verdict, ...] = get_args(Verdict)
