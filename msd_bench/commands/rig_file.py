"""``msd-bench rig-file``: the rig description of one member of a rig family (docs/rig-families.md).

Writes what the member's owner would state in a rig description (docs/rig-description.md): its
rate, stroke and force limit, the decision period its family gives it and, for a rig recorded and
run under a position loop (a ``stage``), that loop. Nothing else: never the drawn mass, friction or
drive, which a real rig's file would not hold either. ``rig.py -p family:=NAME -p
population_seed:=N`` serves the member; ``bench.py --rig FILE --plant-ns /rig`` runs the method on it.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any


def register(sub: Any) -> None:
    """Add the ``rig-file`` subcommand."""
    from msd_bench.core.rigs.families import DEFAULT_FAMILY, FAMILIES

    p = sub.add_parser("rig-file", help="the rig description of one member of a rig family",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--family", default=DEFAULT_FAMILY,
                   help=f"the rig family, one of {', '.join(FAMILIES)} ({DEFAULT_FAMILY})")
    p.add_argument("--member", type=int, required=True, help="the member's seed (population_seed)")
    p.add_argument("--out", type=Path, required=True, help="the description to write (a new file)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Draw the member, write its description (never over an existing file), print the path."""
    from msd_bench.core.rigs import families
    from msd_bench.io.rigs.rig_file import write_rig

    member = families.draw(args.family, args.member)
    header = [f"Rig description of member {args.member} of the {args.family!r} family, written by "
              "msd-bench rig-file (docs/rig-families.md).",
              f"Served by: python launch_scripts/rig.py --ros-args -p family:={args.family} "
              f"-p population_seed:={args.member}"]
    print(write_rig(args.out, member.description(), header))
    return 0
