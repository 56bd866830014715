"""bench.py's job for an on-plant deep-RL kind: no model file, the plant budget, started early."""

from __future__ import annotations

from pathlib import Path

from msd_bench.app.config import RunConfig
from msd_bench.app.pipeline import settings
from msd_bench.designs import budget_note
from msd_bench.graph.bench import BenchConfig, agent_args, model_free_kinds
from msd_bench.nodes.agent_node import AgentNodeConfig
from msd_bench.nodes.params import config_from_job

RUN = RunConfig(seeds=2, episodes=7, steps=50, dyna_episodes=3, agents=("glm", "plant+dqn", "greybox+ppo"))


def test_plant_dqn_learns_on_the_plant_node_at_the_plant_budget(tmp_path: Path) -> None:
    cfg = BenchConfig(run_dir=tmp_path, run=RUN)
    assert model_free_kinds(cfg) == ["plant+dqn"]  # submitted before identification, as Dyna-Q
    args = agent_args(cfg, "plant+dqn")
    node = config_from_job(args[1].removeprefix("job:="), AgentNodeConfig, "agent")
    assert node.model_path == ""  # no model file: the agent node trains over the plant's topics
    assert node.settings().plant_episodes == RUN.dyna_episodes == settings(RUN).plant_episodes
    assert "150 real steps per seed on the plant" in budget_note("plant+dqn", node.settings())
    surrogate = config_from_job(agent_args(cfg, "greybox+ppo")[1].removeprefix("job:="), AgentNodeConfig,
                                "agent")
    assert surrogate.model_path.endswith("greybox.json") and surrogate.episodes == RUN.episodes
