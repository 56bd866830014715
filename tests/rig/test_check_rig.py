"""check-rig against real node processes: the plant and every surrogate kind pass, in both clock modes.

The lock-step graph is the one ``bench.py --via-ros`` starts (the plant's and
the surrogates' own arguments), so it also shows the graph has one /clock owner.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import rclpy
from rclpy.context import Context

from msd_bench.cli import main
from msd_bench.graph import launch
from msd_bench.graph.bench import BenchConfig, plant_args, surrogate_args
from msd_msgs_py.contract import PLANT_NAMESPACE, surrogate_namespace
from tests.nodes.conftest import shutdown_context
from tests.rig.conftest import LENIENT, check, failed

pytestmark = pytest.mark.e2e
REPO = Path(__file__).resolve().parents[2]
PINNED = REPO / "tests" / "data" / "pinned"
KINDS = ("glm", "plm", "nlarx-paper", "nlarx-improved", "greybox")
"""Every surrogate model kind (linear, PLM, both NLARX forms, grey box) as a pinned artifact."""
NAMESPACES = (PLANT_NAMESPACE, *(surrogate_namespace(k) for k in KINDS))


@pytest.fixture(scope="module", params=["lock-step", pytest.param("real-time", marks=pytest.mark.realtime)])
def graph(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """The plant and one surrogate per kind, started as ``bench.py`` starts them."""
    realtime = request.param == "real-time"
    cfg = BenchConfig(tmp_path_factory.mktemp("graph"), realtime=realtime, via_ros=True)
    (cfg.run_dir / "models").mkdir()
    for kind in KINDS:
        shutil.copy(PINNED / f"{kind}.json", cfg.run_dir / "models" / f"{kind}.json")
    quick = ["-p", "duplicate_check:=0.0"]
    with launch.process_group() as procs:
        started = [procs.start("plant.py", [*plant_args(cfg), *quick], name="plant")]
        for kind in KINDS:
            mode = ["-p", "lockstep:=false"] if realtime else []
            args = [*surrogate_args(cfg, kind), *mode, *quick]
            started.append(procs.start("surrogate.py", args, name=kind))
        for proc in started:
            proc.wait_for_line(r"ready \(", timeout=90.0)
        yield request.param


@pytest.mark.parametrize("namespace", NAMESPACES[1:])
def test_every_surrogate_kind_passes(graph: str, namespace: str) -> None:
    clauses = check(namespace)
    assert failed(clauses) == [], "\n".join(c.line() for c in clauses)
    mode = next(c for c in clauses if c.name == "mode")
    assert mode.figure.startswith(graph)
    if graph == "lock-step":
        clock = next(c for c in clauses if c.name == "clock")
        assert clock.figure == f"not published by this node (owner: {PLANT_NAMESPACE}/plant)"


def test_the_plant_passes_through_the_cli(graph: str, tmp_path: Path) -> None:
    """The command as a user types it: one line per clause, exit 0, the same clauses in --json."""
    out = tmp_path / "results" / "check.json"
    proc = subprocess.run([sys.executable, "-m", "msd_bench.cli", "check-rig", PLANT_NAMESPACE, *LENIENT,
                           "--json", str(out)], cwd=REPO, capture_output=True, text=True, timeout=120)
    lines = proc.stdout.splitlines()
    assert proc.returncode == 0, proc.stdout + proc.stderr
    names = [ln.split()[1] for ln in lines]
    timing = ["steps", "clock"] if graph == "lock-step" else ["rate", "stamps", "inter-arrival"]
    assert names == ["publishers", "qos", "mode", *timing, "position", "effort-step", "saturation",
                     "non-finite", "watchdog", "reset"]
    assert all(ln.startswith("PASS  ") for ln in lines)
    doc = json.loads(out.read_text())
    assert doc["passed"] is True and doc["namespace"] == PLANT_NAMESPACE
    assert [c["name"] for c in doc["clauses"]] == names
    assert doc["command"].startswith(f"msd-bench check-rig {PLANT_NAMESPACE} --timing-tolerance 10")
    if graph == "lock-step":
        assert any("published by this node" in ln for ln in lines)


def test_a_via_ros_graph_has_exactly_one_clock_publisher(graph: str) -> None:
    ctx = Context()
    rclpy.init(args=[], context=ctx)
    try:
        node = rclpy.create_node("clock_census", context=ctx)
        expected = [f"{PLANT_NAMESPACE}/plant"] if graph == "lock-step" else []

        def owners() -> list[str]:
            return [f"{i.node_namespace}/{i.node_name}" for i in node.get_publishers_info_by_topic("/clock")]

        # Discovery on a loaded machine can take many seconds: wait for all six nodes and the
        # expected owner (or a wrong one), then give late endpoints two more seconds to show.
        deadline = time.monotonic() + 45.0
        while time.monotonic() < deadline and (len(node.get_node_names_and_namespaces()) < 7
                                               or (expected and not owners())):
            time.sleep(0.1)
        time.sleep(2.0)
        found = owners()
        node.destroy_node()
    finally:
        shutdown_context(ctx)
    assert found == expected


def test_an_empty_namespace_fails_in_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check-rig", "/nobody_here", "--discovery-timeout", "1"]) == 1
    out, err = capsys.readouterr()
    assert out.splitlines() == [
        "FAIL  node          no plant-like node on /nobody_here: no publisher on /nobody_here/joint_states "
        "and no subscriber on /nobody_here/force (waited 1 s)"]
    assert err == ""


@pytest.mark.parametrize(("argv", "message"), [
    (["rig"], "namespace must be absolute"),
    (["/rig", "--timing-tolerance", "0"], "--timing-tolerance must be finite and > 0"),
    (["/rig", "--step-fraction", "0.9"], "--step-fraction must be in (0, 0.5]"),
])
def test_a_usage_mistake_is_one_line(argv: list[str], message: str,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check-rig", *argv]) == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.splitlines()) == 1
    assert err.startswith("msd-bench check-rig: error: ") and message in err


@pytest.mark.realtime
def test_the_rig_emulator_passes_with_its_default_imperfections() -> None:
    """2 mm noise, 0.1 mm quantisation, one sample of delay, a 20 ms lag, friction, jitter, no reset.

    The realtime tier's: its effort-step clause judges real time, and beside the default tier's three
    workers under CI's 100-example fuzz load it once saw no effort move in 0.8 s (a 336 ms stall of
    the rows' arrival); the ros2_control face's run of the same clauses stays in the default tier."""
    with launch.process_group() as procs:
        rig = procs.start("rig.py", ["-p", "duplicate_check:=0.0", "-r", "__ns:=/rig_check"], name="rig")
        rig.wait_for_line(r"ready \(", timeout=90.0)
        clauses = check("/rig_check")
    lines = "\n".join(c.line() for c in clauses)
    assert failed(clauses) == [], lines
    figures = {c.name: c.figure for c in clauses}
    assert figures["mode"].startswith("real-time")
    assert figures["reset"].startswith("unsupported")
    delay = int(figures["effort-step"].split("delay ")[1].split()[0])
    tau_ms = float(figures["effort-step"].split("time constant ")[1].split()[0])
    assert delay >= 1, lines  # the rig's one sample of dead time (more if the rig was starved of CPU)
    assert tau_ms == pytest.approx(20.0, abs=1.0), lines  # its actuator_tau, recovered from the rise
