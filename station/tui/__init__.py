"""``station tui``: the Textual terminal user interface (see :mod:`station.tui.app`)."""
