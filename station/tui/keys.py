"""The keys of a screen, every one within reach at 80x24: a footer that goes on a second
line when its keys do not fit on one, and the F1 screen that lists each key of the screen
under it (those the footer leaves out too, with what they do)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from rich.cells import cell_len
from rich.text import Text
from textual import events
from textual.app import App, ComposeResult
from textual.binding import Binding
from textual.containers import HorizontalGroup, Vertical
from textual.screen import ModalScreen, Screen
from textual.widget import Widget
from textual.widgets import Footer, Label, Static

#: What escape does on a screen pushed over another.
BACK = "back to the screen before"


def footer_key_width(key_display: str, description: str) -> int:
    """Columns a compact footer key takes: ``f5 Start`` and the column after it."""
    return cell_len(key_display) + (1 + cell_len(description) if description else 0) + 1


def footer_rows(widths: Iterable[int], columns: int) -> list[list[int]]:
    """Indices of the footer's keys on each line: as many on a line as fit in ``columns``
    (each key's width counts the column after it, which the last of a line may lose)."""
    rows: list[list[int]] = [[]]
    used = 0
    for i, width in enumerate(widths):
        if rows[-1] and used + width - 1 > columns:
            rows.append([])
            used = 0
        rows[-1].append(i)
        used += width
    return rows


class StationFooter(Footer):
    """Textual's footer, compact, on as many lines as its keys need at the terminal's
    width (one where they fit): no key is ever cut off at the right edge."""

    DEFAULT_CSS = """
    StationFooter { layout: vertical; height: auto; max-height: 3; }
    StationFooter > HorizontalGroup { height: 1; }
    """

    def __init__(self) -> None:
        super().__init__(compact=True, show_command_palette=False)
        self._columns = 0

    def compose(self) -> ComposeResult:
        """The keys of :class:`Footer`, in lines that fit the terminal's width."""
        keys: list[Widget] = list(super().compose())
        self._columns = self.app.size.width
        # a key (FooterKey: key_display, description), else a group of keys: room for it
        widths = [footer_key_width(str(getattr(k, "key_display", "")),
                                   str(getattr(k, "description", "")))
                  if hasattr(k, "key_display") else 20 for k in keys]
        for row in footer_rows(widths, self._columns):
            yield HorizontalGroup(*(keys[i] for i in row))

    def on_resize(self) -> None:
        """Lay the keys out again for a terminal of another width."""
        if self._columns and self.app.size.width != self._columns:
            self._columns = self.app.size.width
            self.call_after_refresh(self.recompose)


@dataclass(frozen=True)
class KeyHelp:
    """A key of a screen: how it reads and what it does."""

    key: str
    text: str


def own_keys(node: object) -> set[str]:
    """The keys the station's classes bind on ``node`` (not Textual's own: tab, copy...)."""
    keys: set[str] = set()
    for cls in type(node).__mro__:
        if not cls.__module__.startswith("textual"):
            for b in cls.__dict__.get("BINDINGS", ()):
                key = b.key if isinstance(b, Binding) else b[0]
                keys.update(k.strip() for k in key.split(","))
    return keys


def screen_keys(app: App[Any], screen: Screen[Any]) -> list[KeyHelp]:
    """Every key ``screen`` answers now (its own, then the app's), hidden ones too: the
    binding's tooltip where it has one, else its description. Textual's own keys and those
    of the focused widget (editing a field, moving in a table) are left out."""
    seen: set[str] = set()
    out: list[KeyHelp] = []
    active = screen.active_bindings.values()
    for owner in (screen, app):
        keys = own_keys(owner)
        for active_binding in active:
            binding: Binding = active_binding.binding
            if (active_binding.node is not owner or not active_binding.enabled
                    or binding.key not in keys):
                continue
            text = binding.tooltip or binding.description or binding.action
            shown = app.get_key_display(binding)
            if shown not in seen:
                seen.add(shown)
                out.append(KeyHelp(shown, text))
    return out


class KeysScreen(ModalScreen[None]):
    """F1: the keys of the screen under it, one a line; any key closes it."""

    DEFAULT_CSS = """
    KeysScreen { align: center middle; }
    KeysScreen > Vertical { width: 78; height: auto; max-height: 22; border: round $primary;
                            background: $surface; padding: 0 1; }
    KeysScreen #keys { height: auto; }
    KeysScreen #keys-hint { color: $text-muted; }
    """

    def __init__(self, title: str, keys: list[KeyHelp]) -> None:
        super().__init__()
        self.title_text = title
        self.keys = keys

    def compose(self) -> ComposeResult:
        """The list, under the screen's name."""
        width = max((cell_len(k.key) for k in self.keys), default=3) + 2
        lines = Text("\n").join(Text.assemble((f"{k.key:<{width}}", "bold"), k.text)
                                for k in self.keys)
        with Vertical():
            yield Label(Text(f"Keys: {self.title_text}", style="bold"))
            yield Static(lines if self.keys else Text("no keys"), id="keys")
            yield Label("Tab moves between fields. Any key closes this list.", id="keys-hint")

    def on_key(self, event: events.Key) -> None:
        """Any key closes the list (and does nothing else)."""
        event.stop()
        event.prevent_default()
        self.dismiss()
