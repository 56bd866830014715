"""Subcommands of the ``msd-bench`` CLI; each module offers ``register(subparsers)``."""
