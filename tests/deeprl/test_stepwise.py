"""Deep RL pushed step by step (the agent node's side of training over the plant node), without ROS.

A Python loop stands in for the episode client: it resets the plant model,
asks the learner for a force, steps the model and hands the answer back, as
the client does over a lock-step plant. The network must be the in-process one
bit for bit and every step the "node" answered must be charged.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from msd_bench import designs
from msd_bench.core.deeprl.hyper import CHOSEN
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.designs import Settings
from msd_bench.designs.deeprl_stepwise import DeepLearner, DeepStepwiseError
from msd_bench.designs.deeprl_train import train


def _drive(learners, episodes: int, steps: int) -> int:
    """The episode client's calls over the plant model; the steps the 'node' answered."""
    model, answered = plant_model(PlantParams()), 0
    for lr in learners:
        for _ in range(episodes):
            state = model.initial_state()
            lr.start_episode(float(state[0]))
            for _ in range(steps):
                x = model.step(state, lr.act())
                answered += 1
                lr.learn(x)
    return answered


@pytest.mark.parametrize("kind", ["plant+dqn", "plant+ppo"])
def test_pushed_training_is_the_in_process_network_and_charges_every_step(kind: str) -> None:
    settings = Settings(episodes=50, plant_episodes=2, steps=150)  # episodes: a surrogate budget, unused
    over = designs.stepwise(kind, None, settings, (3,))
    assert over is not None and over.on_plant and (over.episodes, over.steps) == (2, 150)
    answered = _drive(over.learners, over.episodes, over.steps)
    policy = over.finish()
    assert answered == 300 and policy.facts.real_interactions == answered
    algo = designs.agent_kind(kind).design.algo  # type: ignore[attr-defined]
    ref = train(plant_model(PlantParams()), CHOSEN[algo], 3, 300, episode_steps=150)
    assert ref.steps == 300  # PPO wanted a whole rollout of 2,048: the budget stopped it, in both
    for got, want in zip(policy.net, ref.net, strict=True):
        assert np.array_equal(got, want)


def test_the_in_process_plant_kind_trains_at_the_plant_budget() -> None:
    policy = designs.make("plant+ppo", plant_model(PlantParams()),
                          replace(Settings(), episodes=99, plant_episodes=1, steps=120), (1, 2))
    assert policy.facts.real_interactions == 240 and policy.facts.design == "plant-ppo"
    assert "120 real steps per seed on the plant" in designs.budget_note(
        "plant+ppo", Settings(plant_episodes=1, steps=120))


def test_a_surrogate_kind_learns_nothing_over_topics() -> None:
    assert designs.stepwise("greybox+dqn", None, Settings(), (0,)) is None


def test_a_turn_out_of_order_ends_training_with_one_line() -> None:
    lr = DeepLearner(CHOSEN["dqn"], 0, 10, 0.01, 2.5, 5)
    lr.start_episode(0.0)
    assert lr.act() in (-10.0, -5.0, 0.0, 5.0, 10.0)  # SB3's first force
    lr.to_env.put(("reset", 0.0))  # a reset where SB3 waits for the answer to that force
    with pytest.raises(DeepStepwiseError, match=r"without a network: seed 0: SB3 waited for a x and the node "
                                                r"sent a reset"):
        lr.act()
    with pytest.raises(DeepStepwiseError, match="did not end with a network"):
        lr.join(5.0)
