"""The two real-time ``bench.py --plant-ns`` runs of the e2e tier, run side by side.

Both are the README's short configuration against a separately started
real-time node: our plant under ``/fakerig`` (msd face) and the rig emulator's
ros2_control face under ``/r2crig``. Each spends almost all its time waiting
for real time (rests, recordings, validation runs at 100 Hz), so running them
together costs the time of the longer one, not of both. They share the
caller's domain, as two benches on one network would, and are told apart by
namespace only.
"""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from msd_bench.app.plant_ns import QUICK_LOOK
from msd_bench.graph import launch

REPO = Path(__file__).resolve().parents[2]
PLANT_NS = "/fakerig"
R2C_NS = "/r2crig"
R2C_FACE = ["--interface", "ros2_control", "--controller", "effort_controller", "--joint", "slider_to_cart"]
TARGET = os.environ.get("MSD_PLANT_NS_TARGET", "plant")
"""``plant`` (our plant node, real time, under PLANT_NS) or the path of another plant-like launch
script, e.g. ``launch_scripts/rig.py`` (started with ``-r __ns:=PLANT_NS``)."""


@dataclass(frozen=True)
class Run:
    """Where a bench run wrote its output, and how its process ended."""

    out: Path
    proc: subprocess.CompletedProcess[str]


def _target() -> tuple[str, list[str]]:
    if TARGET == "plant":
        return "plant.py", ["-p", "lockstep:=false", "-r", f"__ns:={PLANT_NS}"]
    return str(REPO / TARGET), ["-r", f"__ns:={PLANT_NS}"]


def _bench(ns: str, out: Path, face: list[str]) -> subprocess.Popen[str]:
    argv = [sys.executable, "launch_scripts/bench.py", "--plant-ns", ns, *face, "--out", str(out),
            *QUICK_LOOK]
    # the caller's ROS_DOMAIN_ID and discovery range (the test suite's), never one the bench claims
    return subprocess.Popen(argv, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ})


def _finish(popen: subprocess.Popen[str], timeout: float) -> subprocess.CompletedProcess[str]:
    try:
        stdout, stderr = popen.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        popen.kill()
        stdout, stderr = popen.communicate()
    return subprocess.CompletedProcess(popen.args, popen.returncode, stdout, stderr)


def run_both(root: Path, timeout: float = 1500.0) -> dict[str, Run]:
    """Start both nodes, then both bench runs; wait for both; stop the nodes. Keyed ``plant``, ``r2c``."""
    outs = {"plant": root / "plant_ns" / "run", "r2c": root / "r2c" / "run"}
    with launch.process_group() as procs:
        script, args = _target()
        r2c_rig = ["-p", "interface:=ros2_control", "-r", f"__ns:={R2C_NS}"]
        nodes = [procs.start(script, args, name="target"), procs.start("rig.py", r2c_rig, name="rig")]
        for node in nodes:
            node.wait_for_line(r"ready", timeout=60.0)
        running = {"plant": _bench(PLANT_NS, outs["plant"], []), "r2c": _bench(R2C_NS, outs["r2c"], R2C_FACE)}
        return {name: Run(outs[name], _finish(p, timeout)) for name, p in running.items()}
