"""The station: runs, recording, grading, reports, the command line and the TUI."""
