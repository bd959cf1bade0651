"""Text a user gave (a serial number, a lot, an operator, a station, a profile's or a
figure's name) drawn by matplotlib as it was typed.

Matplotlib reads a string with two ``$`` as math ("Writing mathematical expressions",
matplotlib's user guide): ``SN-$1$`` would be drawn as math, and ``lot $\\x$`` stops the
drawing with a parse error. The station writes no math of its own into a figure, so every
text of a figure is drawn literally (:func:`draw_literally`) except the axes' tick labels
and offsets, which matplotlib's formatters write as math (``10^{-2}`` on a log axis); tick
labels that are the caller's text (a lot per bar, fixed labels) are escaped
(:func:`literal`) as they are drawn.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def literal(text: str) -> str:
    """``text`` for a matplotlib string that may be parsed as math (a tick label): every
    ``$`` escaped (``\\$``), so that it is drawn as given."""
    return text.replace("$", r"\$")


def draw_literally(fig: Figure) -> Figure:
    """Every text of ``fig`` (titles, labels, legends, tables, notes) drawn as given, none
    parsed as math, except the tick labels and offsets the axes' formatters write; call
    it when the figure is complete, before it is saved. Returns ``fig``."""
    from matplotlib.category import StrCategoryFormatter
    from matplotlib.text import Text
    from matplotlib.ticker import FixedFormatter, FuncFormatter

    class LiteralLabels(FuncFormatter):
        """The caller's tick labels, escaped."""

    given = (FixedFormatter, StrCategoryFormatter, FuncFormatter)  # set_ticklabels: Func
    formatted: set[int] = set()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            for minor, formatter in ((False, axis.get_major_formatter()),
                                     (True, axis.get_minor_formatter())):
                if isinstance(formatter, given) and not isinstance(formatter, LiteralLabels):
                    escaped = LiteralLabels(lambda x, pos, f=formatter: literal(f(x, pos)))
                    (axis.set_minor_formatter if minor else axis.set_major_formatter)(escaped)
            formatted.add(id(axis.offsetText))
            for tick in (*axis.get_major_ticks(), *axis.get_minor_ticks()):
                formatted.update((id(tick.label1), id(tick.label2)))
    texts = list(fig.findobj(Text))
    for ax in fig.axes:  # a table's cells hold their text apart from the artist tree
        texts += [cell.get_text() for table in ax.tables for cell in table.get_celld().values()]
    for text in texts:
        if id(text) not in formatted:
            text.set_parse_math(False)
    return fig
