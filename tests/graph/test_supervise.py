"""bench.py's supervisor wiring without ROS: where it goes by default, its options and their one-line
errors, the remaps for either face, the recording default against the ±10 N bias records, and the
runs it reports handed back to the agent kinds and into the report line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from msd_bench.app import plan
from msd_bench.core.evaluation.results import METRIC_KEYS
from msd_bench.core.identification import excitation as exc
from msd_bench.core.physics.plant import PRESETS, simulate
from msd_bench.core.safety.supervisor import Supervisor, SupervisorOptions
from msd_bench.graph import supervise
from msd_bench.graph.bench import agent_args, agent_placement
from msd_bench.graph.main import config, main, parse
from msd_bench.io.storage.supervisor_file import read_options
from msd_msgs_py.contract import REFERENCE
from msd_msgs_py.interface import make

PLANT = PRESETS["default"]


def cfg_of(tmp_path: Path, *argv: str):  # type: ignore[no-untyped-def]
    return config(parse([*argv, "--out", str(tmp_path / "run")]))


@pytest.mark.parametrize("face", [make("msd"), make("ros2_control")])
def test_every_topic_of_the_face_and_the_reference_are_remapped_behind_it(face) -> None:  # type: ignore[no-untyped-def]
    args = supervise.remap_args(face, "/rig")
    pairs = [a.split(":=") for a in args[1::2]]
    assert args[::2] == ["-r"] * len(pairs)
    topics = [t for t in (face.command, face.state, face.position, face.reset, REFERENCE) if t is not None]
    assert pairs == [[t.resolve("/rig"), t.resolve("/rig/supervisor")] for t in topics]
    assert len(pairs) == (5 if face.kind == "msd" else 3)  # ros2_control has no position and no reset


def test_plant_ns_validates_behind_it_by_default_and_no_supervisor_opts_out(tmp_path: Path) -> None:
    on = cfg_of(tmp_path, "--plant-ns", "/rig")
    assert on.supervision.validation and not on.supervision.recording
    assert supervise.remap_args(on.interface, "/rig") == agent_args(on, "glm+improved")[-10:]
    off = cfg_of(tmp_path, "--plant-ns", "/rig", "--no-supervisor")
    assert not off.supervision.on and "-r" not in agent_args(off, "glm+improved")
    assert supervise.report_facts(off) == {"on": False, "line": "Supervisor: off (--no-supervisor)."}
    assert supervise.announce(off).startswith("Supervisor: off (--no-supervisor)")


def test_the_emulator_is_unsupervised_unless_asked(tmp_path: Path) -> None:
    plain = cfg_of(tmp_path)
    assert not plain.supervision.on and "-r" not in agent_args(plain, "glm+improved")
    assert "off (the emulator's own plant; ask with --supervisor)" in supervise.report_facts(plain)["line"]
    asked = cfg_of(tmp_path, "--supervisor")
    assert asked.supervision.validation
    assert agent_placement(asked, "glm+improved")["pooled"] is False  # a pooled endpoint is not remapped
    assert "/msd/force:=/msd/supervisor/force" in agent_args(asked, "glm+improved")


def test_the_limits_are_printed_with_their_source(tmp_path: Path) -> None:
    line = supervise.announce(cfg_of(tmp_path, "--plant-ns", "/rig"))
    assert "validation behind /rig/supervisor; recording unsupervised" in line
    assert "envelope ±2.25 m" in line and "(defaults from the stroke and F)" in line
    opts = tmp_path / "opts.json"
    opts.write_text('{"envelope": 2.0}')
    line = supervise.announce(cfg_of(tmp_path, "--plant-ns", "/rig", "--supervisor-params", str(opts),
                                     "--supervisor-option", "v_margin=0.7"))
    assert "envelope ±2 m" in line and "+0.7 m/s estimate margin" in line and f"from {opts}" in line


BAD = [
    ("missing.json", None, "cannot read"),
    ("notjson.json", "[1", "not valid JSON"),
    ("unknown.json", '{"envelop": 2}', "unknown option 'envelop'"),
    ("list.json", "[1, 2]", "must be a JSON object"),
    ("past.json", '{"envelope": 2.45, "margin": 0.1}', "must stay below the stop"),
    ("outside.json", '{"envelope": 3}', "inside the stroke"),
]


@pytest.mark.parametrize(("name", "text", "says"), BAD)
def test_a_bad_params_file_is_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                  name: str, text: str | None, says: str) -> None:
    path = tmp_path / name
    if text is not None:
        path.write_text(text)
    assert main(["--plant-ns", "/rig", "--supervisor-params", str(path), "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bench: error: ") and says in err[0], err
    assert str(path) in err[0] or "--supervisor-params" in err[0]
    assert not (tmp_path / "run").exists()  # refused before anything was written


@pytest.mark.parametrize(("option", "says"), [("envelop=2", "expected KEY=VALUE"), ("envelope", "KEY=VALUE"),
                                              ("envelope=two", "is not a number"),
                                              ("envelope=inf", "not a finite number"),
                                              ("envelope=2.6", "inside the stroke")])
def test_a_bad_option_is_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                             option: str, says: str) -> None:
    assert main(["--plant-ns", "/rig", "--supervisor-option", option, "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bench: error: ") and says in err[0], err


def test_supervised_recording_needs_real_time(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--supervise-recording", "--out", str(tmp_path / "run")]) == 2
    assert "--supervise-recording needs real time" in capsys.readouterr().err


def test_the_options_file_spells_out_every_derived_limit(tmp_path: Path) -> None:
    cfg = cfg_of(tmp_path, "--plant-ns", "/rig")
    path = supervise.write_options(cfg)
    doc = json.loads(path.read_text())
    assert doc["envelope"] == 2.25 and doc["v_max"] > 0 and doc["margin"] > 0
    assert read_options(path).limits(PLANT) == SupervisorOptions().limits(PLANT)  # the node holds the same


def held_overrides(options: SupervisorOptions, bias: float) -> tuple[int, int, float]:
    """The paper's bias record at full length on the default plant through the filter: overrides in
    its settle, overrides after it, and the settle's peak |x| unsupervised."""
    e = next(e for e in plan.paper_plan(0) if e.bias == bias)
    u = exc.prbs(e.signal, e.seed)
    x, _, _ = simulate(u, PLANT)
    sup = Supervisor(options, PLANT)
    over = np.array([sup.step(y, y, f).overridden for y, f in zip(x, u, strict=True)])
    settle = e.signal.settle
    return int(over[:settle].sum()), int(over[settle:].sum()), float(np.abs(x[:settle]).max())


@pytest.mark.parametrize("bias", [10.0, -10.0])
def test_the_recording_default_leaves_the_held_bias_records_alone(tmp_path: Path, bias: float) -> None:
    """With --supervise-recording the default envelope is 2.4 m: none of the held part of a ±10 N
    record is overridden. The default bound counts half the spring, so the validation default
    (2.25 m) leaves it alone too; a bound that leaves the spring out overrides it at 2.25 m but not
    at 2.4 m, the margin the wider recording envelope keeps. The settle, a 10 N step from rest,
    reaches the stop unsupervised, and there the supervisor brakes whatever the envelope."""
    cfg = cfg_of(tmp_path, "--plant-ns", "/rig", "--supervise-recording")
    recording = cfg.supervision.resolved(PLANT)
    assert recording.limits(PLANT).envelope == pytest.approx(2.4)
    in_settle, held, peak = held_overrides(recording, bias)
    assert held == 0 and in_settle > 0 and peak == PLANT.x_max
    assert held_overrides(SupervisorOptions(), bias)[1] == 0
    assert held_overrides(SupervisorOptions(passive_share=0.0), bias)[1] > 0
    assert held_overrides(SupervisorOptions(passive_share=0.0, envelope=2.4), bias)[1] == 0


def broad_overridden(options: SupervisorOptions) -> tuple[int, int]:
    """The paper's broad record on the default plant through the filter: overridden samples, samples."""
    e = next(e for e in plan.paper_plan(0) if e.bias is None)
    u = exc.multilevel(e.signal, e.seed)
    x, _, _ = simulate(u, PLANT)
    sup = Supervisor(options, PLANT)
    return sum(sup.step(y, y, f).overridden for y, f in zip(x, u, strict=True)), len(u)


def test_the_broad_record_is_overridden_much_so_supervised_recording_is_for_excitations_inside() -> None:
    """The broad record visits the whole stroke and the stops: the filter overrides a large share of
    it at the validation default, which is why a supervised recording of it is refused at the cut."""
    overridden, n = broad_overridden(SupervisorOptions())
    assert overridden > 0.1 * n


def result_doc(seeds: list[int], scenarios: dict[str, int]) -> dict[str, object]:
    row = {"seed": 0, "id_seed": 0, "sse": 1.0, "mae": 0.1, "std": 0.1, "po": 0.0, "ts2": None, "ts5": None,
           "success": True}
    row.update({k: 0.0 for k in METRIC_KEYS if k not in row})
    cells = {sid: {"n": n, "n_success": n, "median_sse": 1.0, "median_mae": 0.1, "sse": [1.0] * n,
                   "mae": [0.1] * n} for sid, n in scenarios.items()}
    return {"training": "in-process", "per_seed": [{**row, "seed": s} for s in seeds],
            "real_interactions": 0, "on_node_scenarios": cells}


def run_event(i: int, aborted: str | None = None, overridden: int = 0) -> dict[str, object]:
    counts = dict.fromkeys(("envelope", "velocity", "stale", "time_limit", "divergence", "estop"), 0)
    counts["envelope"] = overridden
    return {"run": i, "reference": 1.0, "samples": 300, "steps": 300, "overrides": counts,
            "overridden": overridden, "aborted": aborted, "complete": True}


def test_runs_go_back_to_the_kinds_in_the_order_they_ran_and_aborts_reach_the_report(tmp_path: Path) -> None:
    cfg = cfg_of(tmp_path, "--plant-ns", "/rig", "--agents", "glm+improved,dyna-q",
                 "--node-scenarios", "setpoint=0.5", "--scenario-kinds", "glm+improved")
    agents = cfg.run_dir / "agents"
    for kind, doc in (("dyna-q", result_doc([0, 1], {})),  # ran first: submitted before identification
                      ("glm+improved", result_doc([0, 1], {"setpoint=0.5": 2}))):
        (agents / kind).mkdir(parents=True)
        (agents / kind / "result.json").write_text(json.dumps(doc))
    assert supervise.run_order(cfg) == ["dyna-q", "glm+improved"]
    runs = [run_event(1), run_event(2, overridden=3), run_event(3), run_event(4, "estop"),
            run_event(5, "estop"), run_event(6, "stale")]
    summary = supervise.write_kind_records(cfg, runs)
    assert summary["attributed"] and summary["kinds"]["dyna-q"]["overridden"] == 3
    glm = json.loads((agents / "glm+improved" / "supervisor.json").read_text())
    assert [(r["scenario"], r["seed"], r["aborted"]) for r in glm["runs"]] == [
        ("nominal", 0, None), ("nominal", 1, "estop"), ("setpoint=0.5", 0, "estop"),
        ("setpoint=0.5", 1, "stale")]
    assert glm["aborted"][0] == {"scenario": "nominal", "seed": 1, "reason": "estop"}
    record = {"runs": runs, "totals": {"outside_steps": 10, "outside_overrides": {"envelope": 1}},
              "limits": "supervisor: envelope ±2.25 m", "stages": ["validation"], "by_kind": summary}
    line = supervise.report_line(record)
    assert line["aborted"] == 3 and line["overrides"]["envelope"] == 3
    assert "glm+improved nominal seed 1 (estop)" in line["line"]
    assert "glm+improved setpoint=0.5 seed 1 (stale)" in line["line"]
    assert "\n" not in line["line"]
    short = supervise.write_kind_records(cfg, runs[:5])  # a run the node never saw: nothing guessed
    assert not short["attributed"] and "reported 5 runs where the agents ran 6" in short["note"]
