"""The pinned cases: every agent kind's learner on stored models, small budgets.

Each case names a model (a stored artifact beside this file, or the true
plant) and a learner (paper / improved agent, or Dyna-Q). Budgets are small so
the check runs in seconds, but long enough that every part of the learner
(encoding, shaping, ε-greedy ties, snapshots, planning) is exercised.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from msd_bench.core.learning.dyna import DynaConfig, train_dyna
from msd_bench.core.learning.qconfig import QConfig, improved_config
from msd_bench.core.learning.qtrain import greedy_rollouts, train
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.physics.plant import preset
from msd_bench.io.storage.artifacts import load_model

HERE = Path(__file__).resolve().parent
SEEDS = (3, 11)
EPISODES, STEPS, VALIDATION = 12, 3000, 1500

RUNS = {
    f"{model}/{agent}": (model, agent)
    for model in ("glm", "plm", "nlarx-paper", "nlarx-improved", "plant")
    for agent in ("paper", "improved")
} | {"plant/dyna": ("plant", "dyna")}


def model(name: str) -> StepModel:
    """A stored model artifact, or the default true plant."""
    if name == "plant":
        return plant_model(preset("default"))
    return load_model(HERE / f"{name}.json")


def learner(agent: str) -> QConfig:
    """The learner config of an agent at the pinned budget."""
    base = improved_config() if agent == "improved" else QConfig()
    return replace(base, episodes=EPISODES, steps=STEPS)


def run_case(name: str) -> tuple[np.ndarray, np.ndarray]:
    """(final Q-tables, greedy validation positions on the plant) of one case."""
    model_name, agent = RUNS[name]
    plant = plant_model(preset("default"))
    if agent == "dyna":
        qc = replace(QConfig(), episodes=3, steps=STEPS)
        q = train_dyna(plant, DynaConfig(qc, planning_steps=20), SEEDS).q
    else:
        qc = learner(agent)
        q = train(model(model_name), qc, SEEDS).q
    x, _ = greedy_rollouts(plant, q, qc, 1.0, VALIDATION)
    return q, x
