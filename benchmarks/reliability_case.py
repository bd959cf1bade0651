"""The tallies of one case of ``benchmarks/bench_reliability.py``."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class Case:
    """Tallies of one case."""

    name: str
    trials: int = 0
    lost_s: list[float] = field(default_factory=list)
    balanced: int = 0
    books_checked: int = 0
    bad_errors: list[str] = field(default_factory=list)
    kept: dict[str, list[int]] = field(default_factory=dict)  # damage -> [kept, committed]
    told_after_s: list[float] = field(default_factory=list)
    widths: list[int] = field(default_factory=list)  # outage intervals, samples
    held: list[int] = field(default_factory=lambda: [0, 0])  # gaps held, gaps

    def line(self) -> str:
        lost = f"{max(self.lost_s):.3f}" if self.lost_s else "-"
        books = f"{self.balanced}/{self.books_checked}" if self.books_checked else "-"
        told = f"{max(self.told_after_s):.1f}" if self.told_after_s else "-"
        return (f"{self.name:34s}{self.trials:7d}{lost:>16s}{books:>16s}"
                f"{len(self.bad_errors):>12d}{told:>14s}")


def one_line(text: str) -> bool:
    lines = [line for line in text.strip().splitlines() if line.strip()]
    return len(lines) <= 1 and "Traceback" not in text
