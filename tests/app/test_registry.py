"""The model registry and the agent kinds that follow from it: one table, no fall-through.

An unknown kind must be a one-line error at every door (configuration, nodes,
artifacts, the compiled model handle); every registered kind must get both agent
kinds, a fitter, and a figure.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from msd_bench.app.agents import AGENT_KINDS, agent_kind, learner_config, learner_from_meta
from msd_bench.app.bag_identification import IdentifierConfig
from msd_bench.app.config import RunConfig
from msd_bench.core.errors import ConfigError, InvalidInputError
from msd_bench.core.identification.data import Experiment, IOData
from msd_bench.core.identification.model_kinds import (
    KERNELS,
    MODEL_KINDS,
    check_models,
    model_kind,
    needs_bias_records,
)
from msd_bench.core.identification.records import Records
from msd_bench.core.learning.qconfig import QConfig, improved_config
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.physics.plant import PlantParams, simulate
from msd_bench.io.storage import artifacts
from msd_bench.io.storage.artifacts import ArtifactError
from msd_bench.io.storage.run_output import FigureData, qtable_meta, write_figures
from msd_bench.nodes.agent_node import AgentNodeConfig

PINNED = Path(__file__).resolve().parents[1] / "data" / "pinned"
REPO = Path(__file__).resolve().parents[2]


def test_unknown_model_kind_is_one_line_naming_every_kind():
    with pytest.raises(ConfigError) as err:
        model_kind("arx")
    msg = str(err.value)
    assert "\n" not in msg and "'arx'" in msg
    assert all(name in msg for name in MODEL_KINDS)


@pytest.mark.parametrize("build", [
    lambda: check_models(["glm", "arx"]),
    lambda: RunConfig(agents=("arx",)),
    lambda: RunConfig(agents=("arx+improved",)),
    lambda: AgentNodeConfig(kind="arx", model_path="m.json", out_dir="/tmp/x"),
    lambda: IdentifierConfig(bags_dir="b", out_dir="/tmp/x", models=("glm", "arx")),
])
def test_unknown_kind_is_refused_at_every_configuration_door(build):
    with pytest.raises(ConfigError, match="arx"):
        build()


def test_unknown_kernel_kind_is_refused_by_the_model_handle_and_the_artifact_loader(tmp_path):
    with pytest.raises(InvalidInputError, match="unknown model kind"):
        StepModel(99, np.zeros(3))
    path = artifacts.save_model(plant_model(PlantParams()), tmp_path / "m.json", artifacts.Provenance())
    doc = json.loads(path.read_text())
    doc["kind"] = "arx"
    path.write_text(json.dumps(doc))
    with pytest.raises(ArtifactError, match="unknown model kind 'arx'"):
        artifacts.load_model(path)


def test_every_registered_kind_gives_a_paper_and_an_improved_agent_kind():
    for name, entry in MODEL_KINDS.items():
        assert entry.kernel in KERNELS
        assert agent_kind(name).surrogate == name and agent_kind(name).agent == "paper"
        assert agent_kind(f"{name}+improved").agent == "improved"
        assert entry.label in agent_kind(name).label


def test_greybox_is_a_registered_kind_with_its_agent_kinds():
    assert model_kind("greybox").kernel == "plant"
    assert {"greybox", "greybox+improved"} <= set(AGENT_KINDS)


def test_only_the_plm_needs_the_bias_records():
    assert needs_bias_records(["glm", "plm"])
    assert not needs_bias_records([n for n in MODEL_KINDS if n != "plm"])


def test_learner_is_chosen_by_the_kind_and_round_trips_through_qtable_metadata():
    paper = learner_config("plm", 7, 11, 10.0)
    improved = learner_config("plm+improved", 7, 11, 10.0)
    assert paper.state == QConfig().state and improved.state == improved_config().state
    assert (paper.episodes, paper.steps, improved.episodes) == (7, 11, 7)
    for cfg in (paper, improved):
        meta = json.loads(json.dumps(artifacts.jsonable(qtable_meta(cfg, [1, 2], {}))))
        assert learner_from_meta(meta) == cfg


def test_qtables_without_a_learner_config_are_a_clean_error():
    with pytest.raises(ConfigError, match="no learner config"):
        learner_from_meta({"seeds": [0]})


def _records() -> Records:
    p = PlantParams()
    u = np.sin(np.arange(600) * 0.05) * 4.0
    x, _, ua = simulate(u, p)
    broad = IOData((Experiment(ua, x, "broad"),), p.dt)
    return Records({b: broad for b in (-10.0, -5.0, 0.0, 5.0, 10.0)},
                   {b: broad for b in (-10.0, -5.0, 0.0, 5.0, 10.0)}, broad, broad)


def test_every_registered_kind_gets_its_fit_figure(tmp_path):
    stored = {name: artifacts.load_model(PINNED / f"{name}.json")
              for name in ("glm", "plm", "nlarx-paper", "nlarx-improved")}
    stored["greybox"] = plant_model(PlantParams())
    stored["greybox-rig"] = StepModel(kernels.KIND_GREYBOX_RIG,
                                      np.concatenate([PlantParams().as_array(), [0.2, 0.02, 1.0]]),
                                      "greybox-rig")
    p = PlantParams()
    rk4 = np.array([p.m, p.c, 0.0, 0.0, p.h, p.L, p.F, p.dt, p.k, p.g, 0.0, 0.01, 0.0, 1.0, 1.0])
    stored["greybox-rk4"] = StepModel(kernels.KIND_RK4, rk4, "greybox-rk4", dt=p.dt, force_limit=p.F)
    assert set(stored) == set(MODEL_KINDS), "add a stored model of the new kind to this test"
    paths = write_figures(tmp_path, FigureData(1.0, 0.01, models=stored, records=_records()))
    assert sorted(p.name for p in paths) == sorted(f"fit_{n}.png" for n in MODEL_KINDS)
    assert all(p.stat().st_size > 1000 for p in paths)


def test_agent_report_and_cli_processes_never_import_torch():
    """torch costs seconds and hundreds of MB: only fitting or loading a neural model may pull it in."""
    code = ("import sys, msd_bench.nodes.agent_node, msd_bench.graph.bench_report, msd_bench.graph.main, "
            "msd_bench.nodes.identifier_node, msd_bench.app.output, msd_bench.cli; "
            "print('torch' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, check=True)
    assert out.stdout.strip() == "False"


def test_matrix_names_every_default_kind_and_bench_runs_a_subset_of_it() -> None:
    from msd_bench.app.agents import BENCH_AGENTS, DEFAULT_AGENTS, parse_agents

    assert parse_agents("matrix") == DEFAULT_AGENTS
    assert parse_agents("matrix, plant+robust") == (*DEFAULT_AGENTS, "plant+robust")
    assert set(BENCH_AGENTS) < set(DEFAULT_AGENTS)
    with pytest.raises(ConfigError, match="once each"):
        parse_agents("matrix,plm")


def test_bench_default_kinds_train_off_the_plant() -> None:
    """The main job's plant time is recording and validation only (docs/decisions.md §Main job)."""
    from msd_bench.app.agents import BENCH_AGENTS, PLANT, agent_kind

    assert {"glm", "plm", "nlarx-paper"} <= set(BENCH_AGENTS)
    assert all(agent_kind(k).surrogate != PLANT for k in BENCH_AGENTS)


def test_bench_runs_its_own_default_kinds_and_the_matrix_on_request() -> None:
    from msd_bench.app.agents import BENCH_AGENTS, DEFAULT_AGENTS
    from msd_bench.graph.main import config, parse

    assert config(parse(["--out", "/tmp/x"])).run.agents == BENCH_AGENTS
    assert config(parse(["--out", "/tmp/x", "--agents", "matrix"])).run.agents == DEFAULT_AGENTS
