"""One module per ``station`` sub-command: each has ``register(subparsers)`` and ``run(args)``."""
