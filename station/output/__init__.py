"""What the station hands out: spec sheets, plots, reconcile reports, the results database."""
