"""The station's workflows, one typed request and one function each; the CLI and the TUI call
these."""
