"""Recording runs: the recorder engine, its units' readers, the live progress line."""
