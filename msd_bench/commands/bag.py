"""``msd-bench bag info PATH``, ``bag check PATH`` and ``bag recover PATH``.

``register(subparsers)`` adds the ``bag`` command to the project CLI; every
leaf parser sets ``func(args) -> int`` (the exit status). :func:`main` runs
the command alone (tests, or before the CLI exists). User mistakes print one
``error:`` line and exit with status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from typing import Any

from msd_bench.core.errors import MsdBenchError
from msd_bench.io.bags.bag_check import check_bag, scan_bag
from msd_bench.io.bags.bag_recover import RECOVERED_SUFFIX, recover
from msd_bench.io.bags.reader import bag_info

EXIT_USAGE = 2
"""Exit status on a user mistake (bad path, unreadable bag)."""
EXIT_DAMAGED = 1
"""Exit status of ``bag check`` on a bag with a fault."""


def _info(args: argparse.Namespace) -> int:
    """Everything is read before the first line is printed: a fault is one error line, not half an info.

    The per-topic counts rosbags reports are ``metadata.yaml``'s claims; for an MCAP bag the CRC scan
    ``bag info`` runs anyway counts the messages too, so a count is printed as verified, as the data's
    with the claim beside it when they differ, or marked as not verified (a damaged or sqlite3 bag).
    """
    info = bag_info(args.path)
    scan = scan_bag(args.path) if info.storage == "mcap" else None
    problem = scan.problems[0] if scan is not None and scan.problems else None
    found = scan.topics if scan is not None and problem is None else None
    print(f"bag:       {info.path}")
    print(f"duration:  {info.duration_s:.3f} s")
    wrong = []
    for topic, (ros_type, count) in sorted(info.topics.items()):
        counted = None if found is None else found[topic]
        print(f"topic:     {topic}  [{ros_type}]  {_count_text(count, counted)}")
        if counted is not None and counted != count:
            wrong.append(topic)
    print(f"params:    {json.dumps(info.params, sort_keys=True) if info.params else '(none)'}")
    if info.storage != "mcap":
        print(f"storage:   {info.storage} (no chunk CRCs to check; bag check reads MCAP bags only)")
    if problem is not None:
        print(f"warning: {args.path}: {problem}; run `msd-bench bag check {args.path}`", file=sys.stderr)
    elif wrong:
        print(f"warning: {args.path}: metadata.yaml's message counts disagree with the data on "
              f"{', '.join(wrong[:3])}; run `msd-bench bag check {args.path}`", file=sys.stderr)
    return 0


def _count_text(claimed: int, counted: int | None) -> str:
    """A topic's count: verified, the data's with metadata.yaml's claim beside it, or marked unverified."""
    if counted is None:
        return f"{claimed} messages (metadata.yaml's count, not verified)"
    if counted != claimed:
        return f"{counted} messages (metadata.yaml claims {claimed})"
    return f"{counted} messages"


def _check(args: argparse.Namespace) -> int:
    report = check_bag(args.path)
    for warning in report.warnings:
        print(f"warning: {args.path}: {warning}", file=sys.stderr)
    if report.ok:
        print(f"ok: {args.path}: {report.messages} messages in {report.chunks} chunks; "
              f"CRCs, index and metadata.yaml agree")
        return 0
    for problem in report.problems:
        print(f"damaged: {args.path}: {problem}")
    return EXIT_DAMAGED


def _recover(args: argparse.Namespace) -> int:
    report = recover(args.path, output=args.output, overwrite=args.overwrite)
    print(report.summary())
    for topic, count in sorted(report.counts.items()):
        print(f"  {topic}: {count} messages")
    return 0


def register(subparsers: Any) -> None:
    """Add ``bag info``, ``bag check`` and ``bag recover`` to an argparse subparsers object."""
    bag = subparsers.add_parser("bag", help="inspect, check or recover rosbag2 (MCAP) bags")
    sub = bag.add_subparsers(dest="bag_command", required=True, metavar="{info,check,recover}")
    info = sub.add_parser("info", help="topics, message counts, duration and stored parameters")
    info.add_argument("path", help="bag directory")
    info.set_defaults(func=_info)
    check = sub.add_parser("check", help="verify chunk CRCs, the index and metadata.yaml (exit 1 if damaged)")
    check.add_argument("path", help="bag directory (or its .mcap file)")
    check.set_defaults(func=_check)
    rec = sub.add_parser(
        "recover",
        help="rebuild a complete bag from a killed recording (the original is left untouched)",
    )
    rec.add_argument("path", help="bag directory (or its .mcap file)")
    rec.add_argument("--output", default=None, help=f"new bag directory (default: PATH{RECOVERED_SUFFIX})")
    rec.add_argument("--overwrite", action="store_true", help="replace an existing recovered bag")
    rec.set_defaults(func=_recover)


def run(args: argparse.Namespace) -> int:
    """Call the chosen subcommand; a :class:`MsdBenchError` becomes one line and status 2."""
    try:
        return int(args.func(args))
    except MsdBenchError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_USAGE


def main(argv: Sequence[str] | None = None) -> int:
    """``msd-bench bag ...`` on its own: ``main(["bag", "info", "bags/x"])``."""
    parser = argparse.ArgumentParser(prog="msd-bench")
    register(parser.add_subparsers(dest="command", required=True))
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
