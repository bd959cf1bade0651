"""The names of the five-term fit's methods, without the numerics: what a command's
parser offers (``station analyze --help`` imports this, not the fit)."""

from __future__ import annotations

from typing import Literal

FitMethod = Literal["ols", "ols40", "wls", "nnls", "logwls"]
FIT_METHODS: tuple[FitMethod, ...] = ("ols", "ols40", "wls", "nnls", "logwls")
