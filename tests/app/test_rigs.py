"""``msd-bench rigs`` end to end on two tiny rigs: files, report, executors, resume, bad options."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from msd_bench.cli import main as cli_main
from msd_bench.io.rigs.rigs_report import render
from msd_bench.io.storage.run_dir import is_complete

RIGS = ["rigs", "--rigs", "2", "--seeds", "1", "--agents", "glm,glm+robust", "--episodes", "3",
        "--steps", "200", "--samples", "500", "--val-samples", "400", "--validation-steps", "300",
        "--rig-scenarios", "setpoint=-0.5;disturbance=1@1", "--bootstrap", "200", "--workers", "1"]


def _without_times(doc: Any) -> Any:
    """The document apart from what depends on the machine and the invocation: wall times, and how
    this invocation ran (its executor, workers and the rigs it computed)."""
    if isinstance(doc, dict):
        return {k: _without_times(v) for k, v in doc.items() if k not in ("seconds", "sweep")}
    if isinstance(doc, list):
        return [_without_times(v) for v in doc]
    return doc


@pytest.fixture(scope="module")
def whole(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("rigs") / "whole"
    assert cli_main([*RIGS, "--out", str(out)]) == 0
    return out


def test_the_command_writes_rigs_json_md_and_figure(whole: Path) -> None:
    doc = json.loads((whole / "rigs.json").read_text())
    assert is_complete(whole)
    assert doc["schema"] == "msd-bench/rigs" and doc["rig_set"] == "held-out"
    assert doc["rigs_run"] == [1000, 1001] and doc["bootstrap"]["resamples"] == 200
    assert [k["kind"] for k in doc["kinds"]] == ["glm", "glm+robust"]
    for k in doc["kinds"]:
        assert k["n"] == 2 and 0 <= k["successes"] <= 2 and len(k["wilson95"]) == len(k["bootstrap95"]) == 2
        assert set(k["scenarios"]) == {"setpoint=-0.5", "disturbance=1@1"}
    for rig in doc["rigs"]:
        assert set(rig["parameters"]) == {"mass", "damping", "spring", "hardening", "friction", "delay",
                                          "lag", "noise", "quant"}
        assert [(o["kind"], o["seed"]) for o in rig["outcomes"]] == [("glm", 0), ("glm+robust", 0)]
        assert all(isinstance(o["success"], bool) and "sse_measured" in o for o in rig["outcomes"])
        assert rig["rests"]["before_experiments"][0] == 300  # the first experiment starts from start-up rest
        drive = rig["actuator"]  # what the broad record shows of the drive, told to the robust agent
        assert drive["delay_samples"] == rig["parameters"]["delay"] == drive["told_robust_agent"]
    starts = [o["start_x"] for r in doc["rigs"] for o in r["outcomes"]]
    assert all(s != 0.0 for s in starts)  # every validation run starts where the rig came to rest
    assert (whole / "rigs.md").read_text() == render(doc)  # generated from rigs.json only
    assert (whole / "rigs.png").stat().st_size > 10_000
    assert "<h2>Rigs</h2>" in (whole / "index.html").read_text()  # the run's page (io/reports/html_report.py)
    assert len(doc["worst"]) == 2 and {w["rig"] for w in doc["worst"]} == {1000, 1001}
    sweep = doc["sweep"]
    assert sweep["rigs_computed"] == 2 and sweep["executor"] == "local" and sweep["workers"] == 1
    assert sweep["wall_seconds"] > 0


@pytest.mark.cluster  # a whole sweep on Ray: the cluster tier (docs/testing.md §Tiers)
@pytest.mark.usefixtures("ray_cluster")
def test_ray_writes_the_rigs_json_of_the_local_pool(whole: Path, tmp_path: Path) -> None:
    assert cli_main([*RIGS, "--executor", "ray", "--workers", "2", "--out", str(tmp_path / "ray")]) == 0
    local, ray = (json.loads((d / "rigs.json").read_text()) for d in (whole, tmp_path / "ray"))
    assert _without_times(ray) == _without_times(local)


def test_an_interrupted_sweep_resumes_without_recomputing_a_rig(whole: Path, tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    from msd_bench.io.storage.run_dir import RunDir

    real_run = RunDir.run_task
    written: list[str] = []

    def run_then_stop(self: RunDir, task: str, produce: Any) -> bool:
        if len(written) == 1:
            raise KeyboardInterrupt  # Ctrl-C in the driver after the first rig was written
        written.append(task)
        return real_run(self, task, produce)

    cut = tmp_path / "cut"
    monkeypatch.setattr(RunDir, "run_task", run_then_stop)
    assert cli_main([*RIGS, "--out", str(cut)]) == 130
    assert not is_complete(cut) and not (cut / "rigs.json").exists()
    first = cut / "rigs" / f"{written[0]}.json"
    mtime = first.stat().st_mtime_ns
    monkeypatch.setattr(RunDir, "run_task", real_run)
    capsys.readouterr()
    assert cli_main([*RIGS, "--out", str(cut)]) == 0
    assert "resuming: 1 of 2 tasks already written, not recomputed" in capsys.readouterr().err
    assert first.stat().st_mtime_ns == mtime
    local, resumed = (json.loads((d / "rigs.json").read_text()) for d in (whole, cut))
    assert _without_times(resumed) == _without_times(local)
    assert resumed["sweep"]["rigs_computed"] == 1  # this invocation computed only the rig left


@pytest.mark.parametrize(("extra", "message"), [
    (["--first-rig", "5"], "rig 5 is a design rig (seeds 0-999): held-out rigs start at 1000; pass --design"),
    (["--design", "--first-rig", "999"], "rig 1000 is held out: --design runs only design rigs 0-999"),
    (["--rigs", "0"], "--rigs must be >= 1"),
    (["--first-rig", "999999", "--rigs", "2"], "rig 1000000 is beyond the population's held-out seeds"),
    (["--agents", "glm,plant"], "rigs trains on identified surrogates only, not plant"),
    (["--id-seeds", "2"], "--id-seeds must be 1"),
    (["--record-noise", "0.001"], "a rig measures through its own sensor"),
    (["--rig-scenarios", "noise=0.01"], "rig scenario 'noise=0.01': only setpoint and disturbance"),
    (["--rig-scenarios", "setpoint=9"], "setpoint must be non-zero and within"),
    (["--bootstrap", "10"], "--bootstrap must be >= 100"),
    (["--agents", "nope"], "unknown agent kind 'nope'"),
    (["--robust-actuator", "guess"], "--robust-actuator must be one of measured, none, got 'guess'"),
])
def test_bad_options_are_one_line_and_write_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                    extra: list[str], message: str) -> None:
    assert cli_main([*RIGS, *extra, "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("msd-bench rigs: error: ") and message in err
    assert not (tmp_path / "x").exists()


def test_a_design_run_says_so(tmp_path: Path) -> None:
    from msd_bench.app.rigs import RigsConfig
    from msd_bench.cli import build_parser
    from msd_bench.commands.rigs import rigs_config

    args = build_parser().parse_args([*RIGS, "--design", "--first-rig", "10", "--out", str(tmp_path / "d")])
    cfg = rigs_config(args)
    assert isinstance(cfg, RigsConfig) and cfg.design and cfg.rig_seeds() == [10, 11]


def test_the_robust_agent_told_no_delay_trains_as_on_the_ideal_plant() -> None:
    """``--robust-actuator none``: the rig's delay is still measured and reported, but the observer is
    told none, so the robust learner is the ideal plant's; a rig with a delay changes the learner."""
    from msd_bench import designs
    from msd_bench.app.job import agent_params
    from msd_bench.app.rigs import rig_task
    from msd_bench.cli import build_parser
    from msd_bench.commands.rigs import rigs_config
    from msd_bench.designs.qlearning import learner_config

    args = build_parser().parse_args([*RIGS, "--agents", "glm+robust", "--rigs", "1", "--first-rig", "1012",
                                      "--robust-actuator", "none", "--rig-scenarios", "", "--out", "unused"])
    cfg = rigs_config(args)
    got = rig_task(cfg, 1012)
    assert got["parameters"]["delay"] == got["actuator"]["delay_samples"] == 2
    assert got["actuator"]["told_robust_agent"] == 0
    run = cfg.run
    plain = learner_config("glm+robust", run.episodes, run.steps, run.plant.F, run.shaping)
    settings = designs.protocol.settings_from(agent_params(run))

    def told(drive: designs.Drive | None) -> object:  # what the Q design makes of the request's drive
        return designs.agent_kind("glm+robust").design.config(  # type: ignore[attr-defined]
            designs.request("glm+robust", None, settings, [0], drive))

    assert told(None) == plain and told(designs.Drive(2, 0.04)).obs_delay == 2  # type: ignore[attr-defined]


def test_every_design_runs_on_the_rigs(tmp_path: Path) -> None:
    """Baselines (PID, LQR, MPC) go through ``designs.make`` and their controllers through each rig's own
    loop, as Q-tables do: one deterministic member each, validated nominally and under the scenarios."""
    out = tmp_path / "baselines"
    agents = "glm+pid,greybox+lqr,plm+mpc"
    assert cli_main([*RIGS, "--agents", agents, "--seeds", "2", "--out", str(out)]) == 0
    doc = json.loads((out / "rigs.json").read_text())
    assert [k["kind"] for k in doc["kinds"]] == agents.split(",")
    for rig in doc["rigs"]:
        rows = rig["outcomes"]
        assert [o["kind"] for o in rows] == agents.split(",")  # deterministic: one member each
        for o in rows:  # run on the rig, or its design could not be made on this rig's surrogate (why)
            if "design_failed" in o:
                assert not o["success"] and o["design_failed"] == rig["design_failed"][o["kind"]]
                continue
            assert o["identified"] and set(o["scenarios"]) == {"setpoint=-0.5", "disturbance=1@1"}
            assert o["sse"] > 0 and o["start_x"] != 0.0 and isinstance(o["success"], bool)
    ran = {o["kind"] for r in doc["rigs"] for o in r["outcomes"] if "design_failed" not in o}
    assert ran == set(agents.split(","))  # every baseline really ran through a rig
