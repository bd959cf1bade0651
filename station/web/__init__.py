"""``station serve``: the line's web page, a read-only view over the results database and
the run files in progress (:func:`station.web.app.create_app`), beside the CLI and the TUI.
It calls the services; nothing below it imports it."""

from station.web.app import ServeConfig, create_app

__all__ = ["ServeConfig", "create_app"]
