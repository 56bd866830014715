"""``msd-bench``: paper, efficiency, rigs, rig-file, identify, bag, echo, hz, check-rig, compare, resid.

Also runs as ``python -m msd_bench`` with any interpreter: one that lacks the
project's dependencies re-executes with the project's venv (``msd_bench/_bootstrap.py``).

Every subcommand module exposes ``register(subparsers)`` and sets ``func`` on
its parser. A user mistake (:class:`MsdBenchError`) prints one line on stderr
and exits with status 2 — never a traceback.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from msd_bench._bootstrap import ensure_environment

if __name__ == "__main__":  # `python -m msd_bench.cli` with an interpreter lacking the deps
    ensure_environment(module="msd_bench.cli")

from msd_bench.core.errors import MsdBenchError  # only after the re-exec above


def build_parser() -> argparse.ArgumentParser:
    """The full parser with every subcommand registered."""
    from msd_bench.commands import (
        bag,
        check_rig,
        diagnose,
        efficiency,
        identify,
        paper,
        rig_file,
        rigs,
        topics,
    )

    parser = argparse.ArgumentParser(prog="msd-bench", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for module in (paper, efficiency, rigs, rig_file, identify, bag, topics, check_rig, diagnose):
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Parse, dispatch, and turn user errors into one line and exit status 2.

    Without ``argv`` this is the process's entry point (the console script,
    ``python -m msd_bench``): the process's DDS is confined to loopback first
    when the discovery range asks for it (:func:`msd_bench.dds.confine_process`).
    A caller passing ``argv`` owns its process's environment.
    """
    if argv is None:
        from msd_bench.dds import confine_process

        confine_process()
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except MsdBenchError as exc:
        print(f"msd-bench {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"msd-bench {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
