"""bench.py's ``--rig FILE``: a rig description applied to the run (docs/rig-description.md).

Why a module of its own: the description fills options the command line left
unset (explicit options still win) and refuses, in one line and before any
process starts, what the run cannot honour. Its rate, stroke and force limit
become the run's plant and scales (:meth:`msd_bench.app.config.RunConfig.on_rig`,
called by :func:`msd_bench.graph.main.config`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from msd_bench.core.errors import ConfigError
from msd_bench.core.rigs.description import RigDescription
from msd_bench.io.rigs.rig_file import read_rig
from msd_msgs_py.interface import from_cli

FACE_OPTIONS = ("interface", "controller", "joint", "controller_joints", "effort")
"""Interface options a rig file may fill (argparse dests; the file's keys have the same names)."""


def add_rig_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--rig FILE``."""
    parser.add_argument("--rig", type=Path, metavar="FILE",
                        help="rig description, a ROS 2 parameter file (docs/rig-description.md); "
                             "explicit options win over it")


def given_options(argv: list[str]) -> frozenset[str]:
    """The argparse dests of the long options written on the command line (``--x`` or ``--x=v``)."""
    return frozenset(a[2:].split("=", 1)[0].replace("-", "_") for a in argv if a.startswith("--"))


def apply_rig(args: argparse.Namespace, given: frozenset[str]) -> RigDescription | None:
    """Read ``--rig``, fill the face options not given, refuse what the run cannot honour."""
    if args.rig is None:
        return None
    rig = read_rig(args.rig)
    if rig.plant_ns and rig.plant_ns != args.plant_ns:
        raise ConfigError(f"--rig {args.rig} names plant_ns {rig.plant_ns!r} but the command line "
                          f"gives --plant-ns {args.plant_ns!r}: give --plant-ns {rig.plant_ns}")
    for name in FACE_OPTIONS:
        value = getattr(rig, name)
        if name not in given and value:
            setattr(args, name, ",".join(value) if isinstance(value, tuple) else value)
    _check_hold(args, rig)
    return rig


def _check_hold(args: argparse.Namespace, rig: RigDescription) -> None:
    """A stated hold loop is run by the rig's own drive (``rig.py`` serving a held family member): the
    bench's plant node has none, and on the ros2_control face the measured effort would be rebuilt from
    commands that leave the loop's force out; both are one line before anything starts."""
    if rig.hold() is None:
        return
    if args.plant_ns is None:
        raise ConfigError(f"--rig {args.rig} states a hold loop, which the rig's drive runs; the bench's "
                          "own plant has none: give --plant-ns of the rig (rig.py serving it)")
    face = from_cli(args)
    if not face.contract_rows:  # a measured effort would be rebuilt from commands without the loop's force
        raise ConfigError(f"--rig {args.rig} states a hold loop: only a face whose rows carry the force the "
                          f"drive applied (the loop's included), the msd face's, is read under one; the "
                          f"{face.kind} face's are not")
