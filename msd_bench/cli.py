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

COMMANDS: dict[str, str] = {
    "paper": "paper", "efficiency": "efficiency", "rigs": "rigs", "rig-file": "rig_file",
    "identify": "identify", "bag": "bag", "echo": "topics", "hz": "topics", "check-rig": "check_rig",
    "compare": "diagnose", "resid": "diagnose",
}
"""Each subcommand and the module of :mod:`msd_bench.commands` that registers it (in ``--help``'s order)."""


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser with every subcommand registered, or only ``command``'s module if it names one.

    Why only one: the modules import what their commands need (identification,
    python-control, bag readers); ``msd-bench paper --seeds 0`` should answer
    its one line in a fraction of a second, not after importing every other
    command's science. Help and an unknown command still see them all.
    """
    from importlib import import_module

    parser = argparse.ArgumentParser(prog="msd-bench", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    names = [COMMANDS[command]] if command in COMMANDS else list(dict.fromkeys(COMMANDS.values()))
    for name in names:
        import_module(f"msd_bench.commands.{name}").register(sub)
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
    words = list(sys.argv[1:] if argv is None else argv)
    args = build_parser(words[0] if words else None).parse_args(words)
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
