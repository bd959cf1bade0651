"""Progress of a long workflow, as notices a view subscribes to (never text it must parse)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True)
class Progress:
    """A step of a workflow: what it is doing, and how far it got (``total`` 0: unknown).

    Attributes
    ----------
    workflow : str
        The workflow (``"reconcile"``, ``"simulate"``, ``"reproduce"``).
    text : str
        What it is doing now, for a person.
    done, total : int
        Steps done and all steps (samples, runs, axes), 0 when not counted.
    """

    workflow: str
    text: str = ""
    done: int = 0
    total: int = 0

    @property
    def fraction(self) -> float | None:
        """``done / total``, or None when the steps are not counted."""
        return self.done / self.total if self.total > 0 else None


ProgressSink = Callable[[Progress], None]


def ignore_progress(_: Progress) -> None:
    """A sink that shows nothing (the default of every workflow)."""
