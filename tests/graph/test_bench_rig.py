"""bench.py --rig FILE: the description fills the face, explicit options win, bad files stop the run."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest

from msd_bench.core.safety.supervisor import SupervisorOptions
from msd_bench.graph import main as bench_main

DEFAULT_RIG = Path(__file__).resolve().parents[2] / "config" / "rigs" / "default.yaml"
ROS2_CONTROL_RIG = """/**:
  ros__parameters:
    rate: 100.0
    stroke: 5.0
    force_limit: 10.0
    interface: ros2_control
    plant_ns: /rig
    controller: stage_controller
    joint: stage
"""


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "rig.yaml"
    path.write_text(text)
    return path


def test_default_rig_changes_nothing_but_states_itself(tmp_path: Path) -> None:
    plain = bench_main.config(bench_main.parse(["--out", str(tmp_path / "a")]))
    cfg = bench_main.config(bench_main.parse(["--out", str(tmp_path / "a"), "--rig", str(DEFAULT_RIG)]))
    assert cfg.run == plain.run and cfg.interface == plain.interface
    assert cfg.rig is not None and plain.rig is None
    assert (cfg.rig["rate_hz"], cfg.rig["stroke"], cfg.rig["force_limit"]) == (100.0, 5.0, 10.0)
    assert json.loads(json.dumps(cfg.rig))["samples_per_decision"] == 1


def test_rig_file_fills_the_face_and_explicit_options_win(tmp_path: Path) -> None:
    rig = str(_write(tmp_path, ROS2_CONTROL_RIG))
    cfg = bench_main.config(bench_main.parse(["--plant-ns", "/rig", "--rig", rig]))
    assert cfg.interface.kind == "ros2_control" and cfg.interface.joint == "stage"
    assert cfg.interface.controller == "stage_controller"
    cfg = bench_main.config(bench_main.parse(["--plant-ns", "/rig", "--rig", rig, "--joint", "other"]))
    assert cfg.interface.joint == "other"


@pytest.mark.parametrize(("text", "needle"), [
    ("/**:\n  ros__parameters:\n    rate: 0\n    stroke: 5.0\n    force_limit: 10.0\n", "rate in"),
    ("/**:\n  ros__parameters:\n    rate: 100.0\n    strok: 5.0\n    force_limit: 10.0\n",
     "did you mean stroke?"),
    ("/**:\n  ros__parameters:\n    rate: 1000.0\n    stroke: 0.25\n    force_limit: 350.0\n"
     "    decision_period: 0.0015\n", "not a whole number of rig samples"),
    ("/**:\n  ros__parameters:\n    rate: 1000.0\n    position_min: -0.1\n    position_max: 0.15\n"
     "    force_limit: 350.0\n    decision_period: 0.001\n", "centred on 0"),
    ("/**:\n  ros__parameters:\n    rate: 250.0\n    stroke: 5.0\n    force_limit: 10.0\n"
     "    decision_period: 0.01\n", "not a whole number of rig samples"),
    (ROS2_CONTROL_RIG, "give --plant-ns /rig"),
    ("/**:\n  ros__parameters:\n    rate: 500.0\n    stroke: 0.5\n    force_limit: 200.0\n"
     "    decision_period: 0.01\n    hold_stiffness: 1000.0\n", "states a hold loop, which the rig's drive"),
])
def test_bad_rig_is_one_line_and_writes_nothing(tmp_path: Path, text: str, needle: str,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    assert bench_main.main(["--rig", str(_write(tmp_path, text)), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_a_held_rig_on_the_ros2_control_face_is_one_line(tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    held = "/**:\n  ros__parameters:\n    rate: 500.0\n    stroke: 0.5\n    force_limit: 200.0\n" \
           "    decision_period: 0.01\n    hold_stiffness: 1000.0\n"
    out = tmp_path / "out"
    assert bench_main.main(["--rig", str(_write(tmp_path, held)), "--plant-ns", "/rig", "--interface",
                            "ros2_control", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "states a hold loop: only a face whose rows carry the force" in err
    assert len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_a_held_rigs_identifier_is_told_the_loop(tmp_path: Path) -> None:
    """The identifier's job carries the stated loop (it identifies the held system); a bare rig's none."""
    from msd_bench.app.job import job_document
    from msd_bench.graph.bench_report import rig_line

    held = "/**:\n  ros__parameters:\n    rate: 500.0\n    stroke: 0.5\n    force_limit: 200.0\n" \
           "    decision_period: 0.01\n    hold_stiffness: 1000.0\n    hold_damping: 50.0\n"
    cfg = bench_main.config(bench_main.parse(["--plant-ns", "/rig", "--rig", str(_write(tmp_path, held)),
                                              "--out", str(tmp_path / "out")]))
    params = job_document("identifier", cfg.run, {})["params"]
    assert (params["hold_stiffness"], params["hold_damping"], params["hold_position"]) == (1000.0, 50.0, 0.0)
    assert cfg.rig is not None and "held by its drive's position loop (stiffness 1000" in rig_line(cfg.rig)
    bare = bench_main.config(bench_main.parse(["--out", str(tmp_path / "b"), "--rig", str(DEFAULT_RIG)]))
    assert "hold_stiffness" not in job_document("identifier", bare.run, {})["params"]


def test_report_line_states_rate_stroke_and_force(tmp_path: Path) -> None:
    from msd_bench.graph.bench_report import rig_line

    cfg = bench_main.config(bench_main.parse(["--out", str(tmp_path), "--rig", str(DEFAULT_RIG)]))
    assert cfg.rig is not None
    line = rig_line(cfg.rig)
    assert line == ("Rig (`--rig`): 100 Hz (dt 0.01 s), stroke 5 m, force limit 10 N, "
                    "1 sample(s) per 0.01 s decision, msd face.\n")


STAGE = Path(__file__).resolve().parents[2] / "config" / "rigs" / "stage_1khz.yaml"


def test_a_kilohertz_rig_runs_in_its_own_scales(tmp_path: Path) -> None:
    """The shipped stage: its plant, its scales, the budgets the same seconds, the job's quantities."""
    from msd_bench.app.job import agent_params, job_document

    plain = bench_main.config(bench_main.parse(["--plant-ns", "/rig", "--out", str(tmp_path)]))
    cfg = bench_main.config(bench_main.parse(["--plant-ns", "/rig", "--out", str(tmp_path),
                                              "--rig", str(STAGE)]))
    p = cfg.run.plant
    assert (p.L, p.F, p.dt) == pytest.approx((0.25, 350.0, 0.001))
    assert cfg.run.scales.length == pytest.approx(0.05) and cfg.run.scales.time == pytest.approx(0.1)
    assert cfg.run.samples == 10 * plain.run.samples
    assert cfg.run.validation_steps == 10 * plain.run.validation_steps
    assert cfg.run.target == pytest.approx(0.05)  # the paper's unit step, 0.4 of the half-stroke
    assert cfg.node_scenarios == ("setpoint=0.025", "disturbance=70@15")
    params = agent_params(cfg.run)
    assert (params["stroke"], params["force"], params["dt"]) == pytest.approx((0.25, 350.0, 0.001))
    assert params["rest_window"] == 3000  # the 3 s stillness window
    assert params["decision_samples"] == cfg.run.decision_samples == 10  # 10 ms decisions, 10 samples each
    assert job_document("excitation", cfg.run, {})["params"]["dt"] == pytest.approx(0.001)
    assert cfg.rig_file == STAGE and cfg.rig is not None and cfg.rig["rate_hz"] == 1000.0


def test_a_setpoint_outside_the_rigs_stroke_is_one_line(tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    """Scenario values are in the rig's units: 0.2 m is beyond the stage's ±0.125 m (nothing started)."""
    out = tmp_path / "out"
    argv = ["--plant-ns", "/rig", "--rig", str(STAGE), "--out", str(out), "--node-scenarios", "setpoint=0.2"]
    assert bench_main.main(argv) == 2
    err = capsys.readouterr().err
    assert "within the ±0.125 m stroke" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_the_run_target_must_lie_within_the_stroke() -> None:
    from msd_bench.app.config import RunConfig
    from msd_bench.core.errors import ConfigError
    from msd_bench.io.rigs.rig_file import read_rig

    on_stage = RunConfig().on_rig(read_rig(STAGE))
    assert on_stage.target == pytest.approx(0.05)
    with pytest.raises(ConfigError, match=r"set-point 0.2 m is outside the ±0.125 m stroke of the rig"):
        replace(on_stage, target=0.2)  # a set-point typed in the rig's units


def test_a_design_that_cannot_hold_its_command_is_one_line(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    """The stage decides every 10 samples; a deep-RL design has not opted in to holding: refused up front."""
    out = tmp_path / "out"
    assert bench_main.main(["--plant-ns", "/rig", "--rig", str(STAGE), "--out", str(out),
                            "--agents", "glm+ppo,glm+improved"]) == 2
    err = capsys.readouterr().err
    assert "glm+ppo: a decision period of 10 rig samples is not supported" in err
    assert len(err.strip().splitlines()) == 1 and not out.exists()


STATED_DRIVE = ("/**:\n  ros__parameters:\n    rate: 1000.0\n    stroke: 0.25\n    force_limit: 350.0\n"
                "    decision_period: 0.01\n    actuator_delay_samples: 3\n    lag: 0.05\n")
"""A 1 kHz rig whose description states a slow drive: 3 samples of dead time and a 50 ms lag."""


def test_the_supervisors_latency_comes_from_the_described_drive(tmp_path: Path) -> None:
    """Held sample + dead time + lag (4 ms + 50 ms), not the paper's 40 ms scaled to the rig; a
    --supervisor-option still wins, and a description without the drive keeps the scaled default."""
    rig = _write(tmp_path, STATED_DRIVE)
    cfg = bench_main.config(bench_main.parse(["--out", str(tmp_path / "a"), "--rig", str(rig),
                                              "--supervisor"]))
    assert cfg.supervision.resolved(cfg.run.plant).latency == pytest.approx(0.001 * 4 + 0.05)
    assert cfg.supervision.limits(cfg.run.plant).latency == pytest.approx(0.054)
    told = bench_main.config(bench_main.parse(["--out", str(tmp_path / "b"), "--rig", str(rig),
                                               "--supervisor", "--supervisor-option", "latency=0.2"]))
    assert told.supervision.resolved(told.run.plant).latency == 0.2
    plain = bench_main.config(bench_main.parse(["--out", str(tmp_path / "c"), "--rig", str(STAGE),
                                                "--supervisor"]))
    scaled = SupervisorOptions().scaled(plain.run.scales).latency  # the paper's 40 ms in the rig's time
    assert plain.supervision.resolved(plain.run.plant).latency == scaled


def test_a_described_drive_sets_the_latency_unless_a_part_is_unknown() -> None:
    from msd_bench.core.rigs.description import parse_description

    base = {"rate": 100.0, "stroke": 5.0, "force_limit": 10.0}
    assert parse_description(base).latency(0.04) == 0.04  # nothing stated: the default
    both = parse_description({**base, "actuator_delay_samples": 1, "lag": 0.005})
    assert both.latency(0.04) == pytest.approx(0.025)  # stated whole: itself, even when shorter
    only_delay = parse_description({**base, "actuator_delay_samples": 9})
    assert only_delay.latency(0.04) == pytest.approx(0.1)  # the lag unknown: never below the default
    assert parse_description({**base, "lag": 0.001}).latency(0.04) == 0.04


def test_a_held_rigs_agent_is_told_the_loop_with_the_drive(tmp_path: Path) -> None:
    """The agent's job carries the stated loop beside the drive its bags showed (as ``msd-bench rigs``
    tells the robust agent both); with no drive file it is told neither. Its node's design is then
    told a drive holding that loop."""
    from msd_bench.core.rigs.hold import HoldLoop
    from msd_bench.graph.bench import agent_placement
    from msd_bench.io.bags.drive_file import DRIVE_FILE
    from msd_bench.nodes.agent_node import AgentNodeConfig

    held = "/**:\n  ros__parameters:\n    rate: 500.0\n    stroke: 0.5\n    force_limit: 200.0\n" \
           "    decision_period: 0.01\n    hold_stiffness: 1000.0\n    hold_damping: 50.0\n"
    cfg = bench_main.config(bench_main.parse(["--plant-ns", "/rig", "--rig", str(_write(tmp_path, held)),
                                              "--out", str(tmp_path / "out")]))
    assert "hold_stiffness" not in agent_placement(cfg, "greybox+robust")
    models = cfg.run_dir / "models"
    models.mkdir(parents=True)
    (models / DRIVE_FILE).write_text(json.dumps({"drive": {"delay_samples": 2, "lag_s": 0.001,
                                                            "fit_percent": 99.0}}))
    place = agent_placement(cfg, "greybox+robust")
    assert (place["drive_delay"], place["hold_stiffness"], place["hold_damping"]) == (2, 1000.0, 50.0)
    made_on = {"kind": "greybox+robust", "out_dir": str(tmp_path / "a"), "model_path": "greybox.json"}
    node = AgentNodeConfig(**made_on, drive_delay=2, hold_stiffness=1000.0, hold_damping=50.0)
    drive = node.drive()
    assert drive is not None and drive.hold == HoldLoop(1000.0, 50.0, 0.0)
    bare = AgentNodeConfig(**made_on, drive_delay=2).drive()
    assert bare is not None and bare.hold is None
