"""A served launch script (``--serve``): node after node in one process, each with its own arguments."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError
from msd_bench.core.learning.qtrain import train
from msd_bench.graph.jobs import JobServer
from msd_bench.graph.launch import process_group, stop
from msd_bench.io.bags.reader import bag_info
from msd_bench.io.storage import artifacts
from msd_bench.nodes.agent_node import AgentNodeConfig
from msd_bench.nodes.serve import job_args, wants_serving


def _qc(cfg):
    """The learner the node's kind trains with at its budgets (the design's choice)."""
    from msd_bench.app.agents import learner_config

    return learner_config(cfg.kind, cfg.episodes, cfg.steps, cfg.force, cfg.shaping)

pytestmark = pytest.mark.ros


def test_serving_is_asked_for_before_the_ros_arguments_only() -> None:
    assert wants_serving(["recorder.py", "--serve"])
    assert not wants_serving(["recorder.py"])
    assert not wants_serving(["recorder.py", "--ros-args", "-p", "x:=--serve"])


@pytest.mark.parametrize("line", ["not json", '{"a": 1}', '["-p", 3]'])
def test_a_job_line_must_be_a_json_list_of_strings(line: str) -> None:
    with pytest.raises(ConfigError, match="JSON list of ROS arguments"):
        job_args(line)


def _recorder_args(bag: Path, **extra: str) -> list[str]:
    args = ["-p", f"bag_path:={bag}", "-p", "topics:=[position]", "-p", "namespace:=/serve_test"]
    for key, value in extra.items():
        args += ["-p", f"{key}:={value}"]
    return args


def test_each_job_is_its_own_node_and_a_mistake_ends_only_its_job(tmp_path: Path) -> None:
    """Bad lines and bad parameters fail their job in one line; the next jobs still run and a
    ``stop`` closes a recorder with a complete bag, as Ctrl-C closes its process."""
    with process_group() as procs:
        server = JobServer(procs, "recorder.py", "recorder").ready()
        bad_line = server.submit([], name="empty")  # no bag_path: the node refuses to start
        assert bad_line.wait(120.0) == 2
        assert any("bag_path is required" in ln for ln in bad_line.lines)
        typo = server.submit([*_recorder_args(tmp_path / "typo"), "-p", "max_mesages:=3"], name="typo")
        assert typo.wait(120.0) == 2
        assert any("did you mean max_messages" in ln for ln in typo.lines)
        bags = []
        for k in range(2):  # two recorders in turn: each writes its own bag with its own parameters
            bag = tmp_path / f"bag{k}"
            job = server.submit(_recorder_args(bag, params_json=f"'{json.dumps({'k': k})}'"), name=f"rec{k}")
            job.wait_for_line(r"running", 120.0)
            assert job.stop() == 0
            bags.append(bag)
        server.proc.send("not json")
        assert server.close() == 0
    assert [bag_info(b).params["k"] for b in bags] == [0, 1]
    assert "job 4 exit 2" in server.proc.output()  # the malformed line was a job that failed alone


def test_a_stopped_server_closes_its_running_node(tmp_path: Path) -> None:
    """SIGINT to a served recorder mid-job: the bag is complete and the process exits 0."""
    bag = tmp_path / "mid"
    with process_group() as procs:
        server = JobServer(procs, "recorder.py", "recorder").ready()
        server.submit(_recorder_args(bag), name="mid").wait_for_line(r"running", 120.0)
        assert stop(server.proc) == 0
    assert bag_info(bag).params == {}
    assert (bag / "metadata.yaml").is_file()


def test_a_served_agent_trains_over_ros_on_its_own_events_executor(tmp_path: Path) -> None:
    """Agent jobs spin on a per-job events executor: the Q-table is the in-process one bit for bit,
    and SIGINT in the middle of ROS training still closes the server with status 0."""
    model = Path(__file__).resolve().parents[1] / "data" / "pinned" / "plm.json"
    agent_args = ["-p", "kind:=plm", "-p", f"model_path:={model}", "-p", "seeds:=[2]", "-p", "via_ros:=true",
                  "-p", "surrogate_ns:=/surrogate/plm", "-p", "validation_steps:=200", "-p", "window:=50"]
    with process_group() as procs:
        procs.start("plant.py", ["-p", "lockstep:=true", "-p", "duplicate_check:=0.0"])
        procs.start("surrogate.py", ["-p", f"model_path:={model}", "-p", "lockstep:=true",
                                     "-p", "duplicate_check:=0.0", "-r", "__ns:=/surrogate/plm"])
        server = JobServer(procs, "agent.py", "agent").ready()
        short = server.submit([*agent_args, "-p", "episodes:=2", "-p", "steps:=200",
                               "-p", f"out_dir:={tmp_path / 'short'}"], name="short")
        assert short.wait(120.0) == 0
        long = server.submit([*agent_args, "-p", "episodes:=200", "-p", "steps:=1000",
                              "-p", f"out_dir:={tmp_path / 'long'}"], name="long")
        long.wait_for_line(r"training 1 seed", 60.0)
        time.sleep(1.5)
        assert stop(server.proc) == 0
        assert "Traceback" not in server.proc.output()
    arrays, _ = artifacts.load_qtables(tmp_path / "short" / "qtables.npz")
    cfg = AgentNodeConfig(kind="plm", model_path=str(model), seeds=(2,), episodes=2, steps=200,
                          out_dir=str(tmp_path))
    assert np.array_equal(arrays["q"], train(artifacts.load_model(model), _qc(cfg), cfg.seeds).q)
    assert not (tmp_path / "long" / "qtables.npz").exists()


def test_pooled_agent_jobs_match_once_and_validate_as_an_unpooled_job(tmp_path: Path) -> None:
    """Two lock-step agent jobs with ``pooled:=true`` share one force publisher and one position reader
    (created once, nodes/endpoints.py); their closed loop is the unpooled job's, sample for sample."""
    model = Path(__file__).resolve().parents[1] / "data" / "pinned" / "plm.json"
    args = ["-p", "kind:=plm", "-p", f"model_path:={model}", "-p", "seeds:=[2]", "-p", "episodes:=2",
            "-p", "steps:=200", "-p", "validation_steps:=300", "-p", "window:=50"]
    with process_group() as procs:
        procs.start("plant.py", ["-p", "lockstep:=true", "-p", "duplicate_check:=0.0"])
        server = JobServer(procs, "agent.py", "agent").ready()
        for name, pooled in (("first", "true"), ("second", "true"), ("plain", "false")):
            job = server.submit([*args, "-p", f"pooled:={pooled}", "-p", f"out_dir:={tmp_path / name}"],
                                name=name)
            assert job.wait(120.0) == 0
        assert server.close() == 0
    output = server.proc.output()
    assert output.count("pooled publisher /msd/force") == 1
    assert output.count("pooled subscription /msd/position") == 1
    results = {n: json.loads((tmp_path / n / "result.json").read_text())["per_seed"]
               for n in ("first", "second", "plain")}
    assert results["second"] == results["first"] == results["plain"]
