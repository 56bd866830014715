"""Fault row "bad parameters and options": >= 100 bad cases, each one line, exit 2, no traceback.

In-process through the same ``spin.main`` the node processes run (fast); the
node is never spun: a case the node would accept reaches ``spin_node``,
which here raises, so silent acceptance fails the test. A handful of cases
also run as real processes.
"""

from __future__ import annotations

import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from rclpy.node import Node

from msd_bench.nodes import spin
from msd_bench.nodes.agent_node import AgentNode
from msd_bench.nodes.excitation_node import ExcitationNode
from msd_bench.nodes.identifier_node import IdentifierNode
from msd_bench.nodes.plant_node import PlantNode, declare_true_plant
from msd_bench.nodes.recorder_node import RecorderNode
from msd_bench.nodes.rig_node import build_rig
from msd_bench.nodes.surrogate_node import build_surrogate

pytestmark = pytest.mark.ros
REPO = Path(__file__).resolve().parents[2]

BUILDERS: dict[str, Callable[[], Node]] = {
    "plant": lambda: PlantNode(declare_true_plant),
    "excitation": ExcitationNode,
    "recorder": RecorderNode,
    "identifier": IdentifierNode,
    "agent": AgentNode,
    "surrogate": build_surrogate,
    "rig": build_rig,
}
BASE = {  # valid arguments, so each case fails for its own reason
    "plant": ["-p", "duplicate_check:=0.0"],
    "rig": ["-p", "duplicate_check:=0.0"],
    "excitation": [],
    "recorder": ["-p", "bag_path:=/nonexistent-dir/never-created"],
    "identifier": ["-p", "bags_dir:=/nonexistent", "-p", "out_dir:=/tmp/msd-never"],
    "agent": ["-p", "out_dir:=/tmp/msd-never", "-p", "model_path:=/nonexistent.json"],
}
DECLARED = {
    "plant": ["lockstep", "watchdog_timeout", "duplicate_check", "preset", "m", "c", "k", "g", "h", "L",
              "F", "dt"],
    "excitation": ["signal", "seed", "lockstep", "dt", "start_timeout", "settle", "sample_timeout",
                   "reset_first", "min_subscribers", "wait_recorder", "prbs.bias", "prbs.n_samples",
                   "multilevel.levels", "steps.dwell"],
    "identifier": ["bags_dir", "settle_samples", "models", "seed", "stroke", "nlarx_scale", "out_dir"],
    "rig": ["sensor_noise", "sensor_quant", "delay_samples", "actuator_tau", "friction", "offset", "jitter",
            "seed", "publish_truth", "watchdog_timeout", "preset"],
}
OUT_OF_RANGE = [
    ("plant", "m:=1e6", "m"), ("plant", "m:=0.0", "m"), ("plant", "k:=-1.0", "k"), ("plant", "k:=1e9", "k"),
    ("plant", "F:=0.0", "F"), ("plant", "F:=1e9", "F"),
    ("plant", "dt:=0.0", "dt"), ("plant", "dt:=5.0", "dt"),
    ("plant", "watchdog_timeout:=0.0", "watchdog_timeout"), ("plant", "watchdog_timeout:=1000.0",
                                                             "watchdog_timeout"),
    ("plant", "duplicate_check:=-1.0", "duplicate_check"), ("plant", "m:=.nan", "m"),
    ("plant", "c:=.inf", "c"), ("plant", "preset:=bogus", "preset"),
    ("plant", "lockstep:=maybe", "lockstep"), ("plant", "m:=heavy", "m"),
    ("plant", "live_port:=70000", "live_port"), ("plant", "live_port:=-5", "live_port"),
    ("rig", "live_port:=65536", "live_port"),
    ("excitation", "prbs.n_samples:=100000000000", "prbs.n_samples"),
    ("excitation", "prbs.n_samples:=1e11", "prbs.n_samples"),
    ("excitation", "prbs.n_samples:=0", "prbs.n_samples"), ("excitation", "prbs.hold:=0", "prbs.hold"),
    ("excitation", "multilevel.n_samples:=-5", "multilevel.n_samples"),
    ("excitation", "steps.dwell:=0", "steps.dwell"), ("excitation", "dt:=0.0", "dt"),
    ("excitation", "signal:=chirp", "signal"), ("excitation", "min_subscribers:=0", "min_subscribers"),
    ("excitation", "prbs.register_bits:=3", "register_bits"), ("excitation", "prbs.amplitude:=-1.0",
                                                               "amplitude"),
    ("recorder", "max_messages:=-1", "max_messages"), ("recorder", "flush_period_s:=0.0", "flush_period_s"),
    ("recorder", "params_json:=[1]", "params_json"), ("recorder", "topics:=[bogus]", "topics"),
    ("identifier", "nlarx_scale:=0.0", "nlarx_scale"), ("identifier", "models:=[arx]", "arx"),
    ("identifier", "stroke:=-1.0", "stroke"),
    ("agent", "seeds:=[]", "seeds"), ("agent", "episodes:=0", "episodes"), ("agent", "dt:=2.0", "dt"),
    ("agent", "window:=0", "window"),
    ("surrogate", "dt:=0.0", "dt"), ("surrogate", "force_limit:=0.0", "force_limit"),
    ("rig", "sensor_noise:=1.0", "sensor_noise"), ("rig", "sensor_quant:=-0.1", "sensor_quant"),
    ("rig", "delay_samples:=-1", "delay_samples"), ("rig", "delay_samples:=100", "delay_samples"),
    ("rig", "delay_samples:=1.5", "delay_samples"), ("rig", "actuator_tau:=2.0", "actuator_tau"),
    ("rig", "friction:=.nan", "friction"), ("rig", "jitter:=0.02", "jitter"),
    ("rig", "jitter:=0.01", "jitter"), ("rig", "seed:=-1", "seed"),
    ("rig", "publish_truth:=maybe", "publish_truth"), ("rig", "lockstep:=true", "lockstep"),
    ("rig", "reset:=true", "reset"), ("rig", "preset:=ideal", "preset"), ("rig", "m:=0.0", "m"),
]


def _misspell(name: str) -> str:
    head, _, last = name.rpartition(".")
    cut = last[:-1] if len(last) > 3 else last + "x"
    return f"{head}.{cut}" if head else cut


def _cases(tmp: Path) -> Iterator[tuple[str, list[str], str]]:
    """(node, argv after the script name, a word the error line must contain)."""
    for node, names in DECLARED.items():
        for name in names:
            bad = _misspell(name)
            yield node, ["--ros-args", *BASE[node], "-p", f"{bad}:=1"], bad
    for node, arg, needle in OUT_OF_RANGE:
        yield node, ["--ros-args", *BASE.get(node, []), "-p", arg], needle
    files = {
        "missing.yaml": None,
        "bad.yaml": "a: [1, 2\n",
        "scalar.yaml": "hello\n",
        "flat.yaml": "m: 2.0\n",
        "nobody.yaml": "/msd/plant:\n  m: 2.0\n",
    }
    for fname, text in files.items():
        if text is not None:
            (tmp / fname).write_text(text)
        for node in ("plant", "recorder"):
            yield node, ["--ros-args", *BASE[node], "--params-file", str(tmp / fname)], fname
    section = "/msd/plant:\n  ros__parameters:\n    watchdog_timout: 1.0\n"
    (tmp / "typo.yaml").write_text(section)
    yield "plant", ["--ros-args", *BASE["plant"], "--params-file", str(tmp / "typo.yaml")], "watchdog_timout"
    for node in BUILDERS:
        yield node, ["--not-ros-arg"], "--not-ros-arg"
        yield node, ["extra", "--ros-args", *BASE.get(node, [])], "extra"
    for node in ("plant", "excitation", "recorder", "identifier"):
        yield node, ["--ros-args", "--bogus"], "bogus"
        yield node, ["--ros-args", "-p"], "error"
        yield node, ["--ros-args", "-p", "novalue"], "error"


class Accepted(Exception):
    """The node was built and would have run: the bad case was silently accepted."""


def _refuse_to_spin(node: Node, executor: object) -> int:
    raise Accepted(node.get_name())


def test_sweep_of_bad_parameters_and_options(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(spin, "spin_node", _refuse_to_spin)
    handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    cases = list(_cases(tmp_path))
    assert len(cases) >= 100
    failures = []
    try:
        for node, argv, needle in cases:
            try:
                status = spin.main(BUILDERS[node], [f"{node}.py", *argv])
            except Accepted:
                status = "accepted"
            err = capsys.readouterr().err.strip()
            lines = err.splitlines()
            if status != spin.EXIT_USAGE or len(lines) != 1 or not lines[0].startswith("error:") \
                    or needle not in lines[0] or "Traceback" in err:
                failures.append((node, argv, status, err[-300:]))
    finally:
        for sig, handler in handlers.items():
            signal.signal(sig, handler)
    assert not failures, f"{len(failures)} of {len(cases)} cases: {failures[:5]}"


@pytest.mark.parametrize(("script", "args", "needle"), [
    ("plant.py", ["--ros-args", "-p", "watchdog_timout:=1.0"], "did you mean watchdog_timeout"),
    ("plant.py", ["--not-ros-arg"], "--not-ros-arg"),
    ("agent.py", ["--ros-args", "-p", "seeds:=[]", "-p", "out_dir:=/tmp/msd-never", "-p", "dyna:=true"],
     "seeds must not be empty"),
    ("excitation.py", ["--ros-args", "-p", "prbs.n_samples:=100000000000"], "out of range"),
])
def test_bad_options_in_real_processes(script: str, args: list[str], needle: str) -> None:
    proc = subprocess.run([sys.executable, f"launch_scripts/{script}", *args], cwd=REPO,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and needle in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stdout + proc.stderr
