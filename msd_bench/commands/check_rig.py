"""``check-rig NS``: does the plant-like node under NS keep the topic contract? (docs/check-rig.md)

    msd-bench check-rig /rig
    msd-bench check-rig /msd --seconds 20 --watchdog-timeout 0.5
    msd-bench check-rig --interface ros2_control --controller effort_controller --joint slider_to_cart /rig

Drives the node through a short, safe script (small forces, one brief
over-limit command) and prints one line per clause, PASS or FAIL with the
measured figure. Exit status 0 only if every clause passes, 1 otherwise,
2 on a usage mistake.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
import os
import platform
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import rclpy

from msd_bench.core.errors import MsdBenchError
from msd_bench.core.physics.plant import DT, PlantParams
from msd_bench.core.rigs.conformance import Clause, Limits
from msd_bench.io.rigs.rig_file import probe_new_rig, read_rig, write_rig
from msd_bench.io.storage.atomic import write_text_atomic
from msd_bench.io.storage.paths import writable_dir
from msd_bench.io.storage.safe_read import read_json_bounded
from msd_bench.nodes.spin import ros_session
from msd_msgs_py.interface import add_cli_options, from_cli


class CheckRigError(MsdBenchError):
    """A check-rig option is out of its range."""


def register(subparsers: Any) -> None:
    """Add ``check-rig`` to an argparse subparsers object."""
    p = subparsers.add_parser("check-rig", help="check that a plant-like node keeps the topic contract",
                              description=__doc__.splitlines()[0])
    p.add_argument("namespace", help="namespace of the plant-like node, e.g. /rig or /msd")
    p.add_argument("--seconds", type=float, default=10.0,
                   help="real time: least telemetry the timing clauses see, s (the script itself takes ~4 s)")
    p.add_argument("--watchdog-timeout", type=float, default=0.5,
                   help="the node's declared watchdog timeout, s (real time)")
    p.add_argument("--force-limit", type=float, help=f"the node's force limit F, N (default: --rig's, "
                                                      f"else {PlantParams().F:g})")
    p.add_argument("--dt", type=float,
                   help=f"the node's sample period, s (default: 1/rate of --rig, else {DT:g})")
    p.add_argument("--rig", type=Path, metavar="FILE",
                   help="rig description (docs/rig-description.md): force limit, dt and face from it; "
                        "explicit options win")
    p.add_argument("--p99-limit", type=float, default=0.025, help="limit of the inter-arrival p99, s")
    p.add_argument("--timing-tolerance", type=float, default=1.0,
                   help="factor on the timing limits (rate, gaps, p99, watchdog slack); > 1 on a loaded "
                        "machine")
    p.add_argument("--position-tolerance", type=float, default=1e-9,
                   help="largest |position - joint_states.position| of one sample, m")
    p.add_argument("--rest-tolerance", type=float, default=0.01,
                   help="how close to the origin a real-time reset must bring the measured position, m")
    p.add_argument("--step-fraction", type=float, default=0.3, help="the step command as a fraction of F")
    p.add_argument("--discovery-timeout", type=float, default=5.0, help="wait for the node's endpoints, s")
    p.add_argument("--json", type=Path, metavar="PATH",
                   help="also write the clauses, the command, commit and machine to PATH (JSON)")
    p.add_argument("--write-rig", type=Path, metavar="FILE",
                   help="also write a starting rig description (docs/rig-description.md) to the new FILE "
                        "from what was measured: rate, stroke seen, force limit, and the face; never "
                        "overwrites")
    add_cli_options(p)
    # --interface unset is None, so a typed --interface wins over --rig's face even when it names the
    # default face; apply_rig fills it from the file or from the option's own default
    p.set_defaults(func=run, interface=None, default_interface=p.get_default("interface"))


def apply_rig(args: argparse.Namespace) -> None:
    """Fill what the command line left unset from ``--rig`` (one line on a bad file), else the defaults.

    ``--interface`` is unset while None (``register``); the other face options
    while they hold their empty defaults (the options come from msd_msgs_py).
    """
    rig = read_rig(args.rig) if getattr(args, "rig", None) is not None else None
    if args.force_limit is None:
        args.force_limit = rig.force_limit if rig is not None else PlantParams().F
    if args.dt is None:
        args.dt = rig.dt if rig is not None else DT
    if getattr(args, "interface", None) is None:
        args.interface = rig.interface if rig is not None else args.default_interface
    if rig is None:
        return
    for name in ("controller", "joint", "effort"):
        if not getattr(args, name):
            setattr(args, name, getattr(rig, name))
    if not args.controller_joints:
        args.controller_joints = ",".join(rig.controller_joints)


def _check(args: argparse.Namespace) -> None:
    apply_rig(args)
    positive = ("watchdog_timeout", "force_limit", "dt", "p99_limit", "timing_tolerance", "discovery_timeout")
    for name in positive:
        value = getattr(args, name)
        if not (math.isfinite(value) and value > 0):
            raise CheckRigError(f"--{name.replace('_', '-')} must be finite and > 0, got {value}")
    for name in ("seconds", "position_tolerance", "rest_tolerance"):
        value = getattr(args, name)
        if not (math.isfinite(value) and value >= 0):
            raise CheckRigError(f"--{name.replace('_', '-')} must be finite and >= 0, got {value}")
    if not 0 < args.step_fraction <= 0.5:
        raise CheckRigError(f"--step-fraction must be in (0, 0.5], got {args.step_fraction}")
    if not args.namespace.startswith("/"):
        raise CheckRigError(f"namespace must be absolute (start with /), got {args.namespace!r}")


def limits_from_args(args: argparse.Namespace) -> Limits:
    """The clause limits the options ask for."""
    return Limits(dt=args.dt, p99_limit=args.p99_limit, timing_tolerance=args.timing_tolerance,
                  force_limit=args.force_limit, watchdog_timeout=args.watchdog_timeout,
                  position_tolerance=args.position_tolerance, rest_tolerance=args.rest_tolerance)


def check(args: argparse.Namespace, context: rclpy.context.Context | None = None) -> list[Clause]:
    """Run the check on ``context`` (an initialised one; the default context if None); with
    ``--write-rig`` also write the starting description (:func:`write_measured_rig`)."""
    from msd_bench.nodes.rig_checker import RigChecker, Script

    _check(args)
    script = Script(step_fraction=args.step_fraction, seconds=args.seconds,
                    discovery_timeout=args.discovery_timeout)
    node = rclpy.create_node("msd_bench_check_rig", context=context, start_parameter_services=False)
    try:
        checker = RigChecker(node, args.namespace, limits_from_args(args), script, from_cli(args))
        clauses = checker.run()
        if getattr(args, "write_rig", None) is not None:
            write_measured_rig(args, checker.measured)
        return clauses
    finally:
        node.destroy_node()


def write_measured_rig(args: argparse.Namespace, measured: Callable[[], dict[str, float]]) -> None:
    """The starting description of ``--write-rig``: the measured rate, stroke seen and force limit,
    the face it was checked through, the namespace; a one-line error (nothing written) when one of
    them could not be measured. Why a starting file: check-rig drives the node gently, so the
    stroke is what the mass moved within, not the stops; the header says to check every value."""
    try:
        values = measured()
    except MsdBenchError as exc:
        raise CheckRigError(f"--write-rig {args.write_rig}: not written: {exc}") from None
    iface = from_cli(args)
    params: dict[str, Any] = {**values, "interface": iface.kind, "plant_ns": args.namespace}
    for name in ("controller", "joint", "effort"):
        if getattr(args, name):
            params[name] = getattr(args, name)
    if args.controller_joints:
        params["controller_joints"] = [j.strip() for j in args.controller_joints.split(",") if j.strip()]
    header = ["Starting rig description written by msd-bench check-rig --write-rig from what it measured",
              f"on {args.namespace} at {dt.datetime.now(dt.UTC).isoformat(timespec='seconds')} "
              f"(docs/rig-description.md).",
              "rate: median stamp interval; stroke: twice the largest |position| seen (a lower bound:",
              "the stops were not looked for); force_limit: the effort under a command beyond it.",
              "Check every value against the rig's data sheet before running the method on it."]
    write_rig(args.write_rig, params, header)
    print(f"wrote {args.write_rig}: rate {values['rate']:g} Hz, stroke seen {values['stroke']:g}, "
          f"force limit {values['force_limit']:g}", flush=True)


def run(args: argparse.Namespace) -> int:
    """Print one line per clause (and write them to ``--json``); 0 if all pass."""
    _check(args)
    from_cli(args)  # an inconsistent interface is one line before any ROS work
    if args.json is not None:
        probe_json(args.json)
    if args.write_rig is not None:
        probe_new_rig(args.write_rig)
    with ros_session([]):
        clauses = check(args)
    for c in clauses:
        print(c.line(), flush=True)
    if args.json is not None:
        write_text_atomic(args.json, json.dumps(report(args, clauses), indent=1) + "\n")
    return 0 if all(c.passed for c in clauses) else 1


def probe_json(path: Path) -> None:
    """Before any ROS work: ``--json`` must be new, or a check-rig report of ours (it is regenerated).

    Never a directory, a symlink or another file: the check would otherwise run
    for seconds and then fail, or replace something the tool did not write.
    """
    writable_dir(path.parent.absolute(), "--json directory")
    if not os.path.lexists(path):
        return
    if path.is_symlink() or not path.is_file():
        raise CheckRigError(f"--json {path} exists and is not a regular file (a directory or a symlink); "
                            f"name a new file")
    try:
        doc = read_json_bounded(path, CheckRigError)
    except CheckRigError:
        doc = None
    ours = isinstance(doc, dict) and isinstance(doc.get("clauses"), list) and \
        str(doc.get("command", "")).startswith("msd-bench check-rig")
    if not ours:
        raise CheckRigError(f"--json {path} exists and is not a check-rig report; not overwriting it")


def report(args: argparse.Namespace, clauses: list[Clause]) -> dict[str, Any]:
    """The check as a results document: what ran where, and every clause."""
    argv = ["msd-bench", "check-rig", *sys.argv[2:]] if sys.argv[1:2] == ["check-rig"] else []
    return {
        "namespace": args.namespace,
        "passed": all(c.passed for c in clauses),
        "clauses": [{"name": c.name, "passed": c.passed, "figure": c.figure} for c in clauses],
        "command": " ".join(argv) or f"msd-bench check-rig {args.namespace}",
        "commit": _commit(),
        "machine": f"{platform.node()} ({os.cpu_count()} cores, {platform.platform()})",
        "created_utc": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
    }


def _commit() -> str | None:
    """The repository's commit (``+dirty`` with uncommitted changes), None outside a checkout."""
    repo = Path(__file__).resolve().parents[2]
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=repo, capture_output=True,
                              text=True, timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=repo,
                               capture_output=True, text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return head + ("+dirty" if dirty else "")
