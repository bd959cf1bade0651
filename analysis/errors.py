"""Exceptions raised by the analysis layer.

Each one also inherits the builtin that fits, so callers that only know the builtins
(``except ValueError``) still catch it.
"""

from __future__ import annotations


class AnalysisError(Exception):
    """Base class of every error the analysis package raises on purpose."""


class NonFiniteSamplesError(AnalysisError, ValueError):
    """The input holds NaN or infinite samples; the message says where."""


class TooFewSamplesError(AnalysisError, ValueError):
    """The record is too short for the requested averaging time or fit."""


class InvalidSampleRateError(AnalysisError, ValueError):
    """The sample rate is not a finite positive number."""


class InvalidTauError(AnalysisError, ValueError):
    """A requested averaging time is not a positive multiple of the sample period."""


class FitError(AnalysisError, ValueError):
    """A noise-term fit cannot be made with the values given (too few taus, unknown term)."""


class ModelError(AnalysisError, ValueError):
    """A noise model or one of its terms is invalid (unknown term or key, bad value, bad TOML)."""


class InvalidWindowError(AnalysisError, ValueError):
    """A DAVAR window or step is not a positive whole number of samples that fits the record."""


class ReconcileError(AnalysisError, ValueError):
    """Model versus measurement cannot be compared with the inputs given (record too short for
    the tau grid, a model without any Allan variance, a temperature channel of the wrong length)."""
