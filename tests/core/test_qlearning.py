"""Q-learning (paper §4): state index, reward, one update by hand, shaping, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError, InvalidInputError, MsdBenchError
from msd_bench.core.learning import q_kernels as qlearning
from msd_bench.core.learning import rng
from msd_bench.core.learning.qconfig import QConfig, encoding, improved_config, packed
from msd_bench.core.learning.qtrain import budget, greedy_rollout, greedy_rollouts, run_batch, train
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.physics.plant import PlantParams

GAIN = 0.01  # x_{k+1} = GAIN * u_k: a model whose next state is known by hand


def _linear_model() -> StepModel:
    # [L, n1, n2, d1, d2, u0, y0]: y[k+1] = n1 u[k]
    return StepModel(kernels.KIND_LINEAR, np.array([5.0, GAIN, 0.0, 0.0, 0.0, 0.0, 0.0]), "lin")


def _paper_index(e: float) -> int:
    return qlearning.encode(encoding(QConfig()), e, 0.0, 1.0)


@pytest.mark.parametrize(("e", "s"), [(-5.0, 0), (0.0, 50), (5.0, 99), (-7.3, 0), (12.0, 99),
                                      (-1e-9, 49), (-1.0, 40), (0.2, 51)])
def test_paper_state_index(e: float, s: int) -> None:
    # s = floor(99 (clip(e) + 5) / 10 + 0.5): e = 0 gives 49.5 + 0.5 -> 50 (half up);
    # e = -1: 39.6 + 0.5 -> 40; e = 0.2: 51.48 + 0.5 -> 51
    assert _paper_index(e) == math.floor(99 * (min(max(e, -5), 5) + 5) / 10 + 0.5) == s


def test_improved_state_uses_lead_error() -> None:
    cfg = improved_config(lead_steps=50.0)
    enc = encoding(cfg)
    assert enc.n_states == 2 * len(cfg.error_edges) + 2
    edges = cfg.error_edges
    # e = -0.03 moving up 1 mm/step: lead error -0.03 + 0.05 = 0.02 -> bin [0.02, 0.04)
    s = qlearning.encode(enc, -0.03, 0.001, 1.0)
    assert s == len(edges) + 1 + edges.index(0.02) + 1
    # with direction bins, rising is the third of three
    enc3 = encoding(improved_config(direction_bins=True, lead_steps=0.0))
    s3 = qlearning.encode(enc3, 0.005, 0.001, 1.0)
    assert s3 == (len(edges) + 1) * 3 + 2


def test_reward_by_hand() -> None:
    lr = packed(QConfig(g=2.0, zeta=10.0, e_max=4.0))
    assert qlearning.reward(lr, 0.5, 1.0) == pytest.approx(2 / 1.5 + 10 * 0.5 / 4)
    assert qlearning.reward(lr, 1.0, 0.5) == pytest.approx(2 / 2.0 - 10 * 0.5 / 4)
    assert qlearning.reward(lr, 0.0, 0.0) == pytest.approx(2.0)


def test_shaping_table_marks_actions_pushing_away() -> None:
    phi = packed(QConfig()).phi
    assert phi[49].sum() == 0 and phi[50].sum() == 0  # the zero-error bins
    assert list(phi[40]) == [1, 1, 0, 0, 0]  # below target: negative forces push away
    assert list(phi[60]) == [0, 0, 0, 1, 1]  # above target: positive forces push away


def test_one_update_by_hand() -> None:
    cfg = QConfig(episodes=1, steps=1, epsilon=0.0, target_low=1.0, target_high=1.0)
    forces = cfg.actions()
    phi = packed(cfg).phi
    seen = set()
    for seed in range(40):
        q = train(_linear_model(), cfg, [seed]).q[0]
        (s, a), = zip(*np.nonzero(q), strict=True)  # exactly one entry was updated
        e1 = GAIN * forces[a] - 1.0
        r = 1 / (1 + abs(e1)) - 10 * (abs(e1) - 1.0) / 5
        assert s == 40
        assert q[s, a] == pytest.approx(0.5 * (r + 0.9 * 0.0 - 0.0) - 0.05 * phi[s, a])
        seen.add(int(a))
    assert seen == set(range(5))  # all-zero row: ties are broken at random over every action


def test_shaping_lowers_penalised_values() -> None:
    # epsilon = 1: actions ignore Q, so both runs follow the same trajectory
    base = QConfig(episodes=2, steps=400, epsilon=1.0, eta=0.0)
    free = train(plant_model(PlantParams()), base, [5]).q[0]
    shaped_cfg = QConfig(episodes=2, steps=400, epsilon=1.0, eta=0.05)
    shaped = train(plant_model(PlantParams()), shaped_cfg, [5]).q[0]
    phi = packed(shaped_cfg).phi
    hit = (free != 0) & (phi == 1)
    assert hit.sum() > 5
    assert np.all(shaped[hit] < free[hit])
    assert np.all(shaped <= free + 1e-12)  # a penalty never raises any value


def test_same_seed_same_table_and_batch_equals_single() -> None:
    cfg = QConfig(episodes=3, steps=300, snapshot_episodes=(2,))
    m = plant_model(PlantParams())
    batch = train(m, cfg, [3, 7, 11])
    single = train(m, cfg, [7])
    again = train(m, cfg, [7])
    assert np.array_equal(single.q, again.q)
    assert np.array_equal(batch.q[1], single.q[0])
    assert np.array_equal(batch.returns[1], single.returns[0])
    assert np.array_equal(batch.snapshots[1], single.snapshots[0])
    assert not np.array_equal(batch.q[0], batch.q[1])


def test_snapshots_first_and_last_always_kept() -> None:
    cfg = QConfig(episodes=3, steps=50, snapshot_episodes=(2, 10))
    res = train(plant_model(PlantParams()), cfg, [0])
    assert res.snapshot_episodes == (1, 2, 3)
    assert res.snapshots.shape == (1, 3, 100, 5)
    assert np.array_equal(res.snapshots[0, -1], res.q[0])
    assert not np.array_equal(res.snapshots[0, 0], res.q[0])


def test_greedy_rollout_from_rest_and_batch() -> None:
    cfg = QConfig()
    q = np.zeros((100, 5))
    q[:50, 4] = 1.0  # below target: push +F
    q[50:, 2] = 1.0  # at or above: no force
    x, u = greedy_rollout(_linear_model(), q, cfg, target=1.0, n_steps=4)
    # from rest: e = -1 -> +F, x = 0.1; still below -> +F, x stays 0.1
    assert list(x) == [0.0, 0.1, 0.1, 0.1]
    assert list(u) == [10.0, 10.0, 10.0, 10.0]
    xs, _ = greedy_rollouts(_linear_model(), np.stack([q, q]), cfg, 1.0, 4)
    assert np.array_equal(xs[1], x)


def test_improved_agent_trains_and_rolls_out() -> None:
    cfg = improved_config(episodes=2, steps=200)
    res = train(plant_model(PlantParams()), cfg, [1, 2])
    assert res.q.shape == (2, encoding(cfg).n_states, 5)
    x, _ = greedy_rollout(plant_model(PlantParams()), res.q[0], cfg, n_steps=100)
    assert x.shape == (100,) and np.all(np.isfinite(x))


def test_rng_streams_are_per_agent_and_in_range() -> None:
    a = rng.seed_states([1, 2])
    b = rng.seed_states([2])
    u = [rng.uniform(a, 1) for _ in range(1000)]
    assert u == [rng.uniform(b, 0) for _ in range(1000)]
    assert min(u) >= 0.0 and max(u) < 1.0 and 0.4 < np.mean(u) < 0.6
    ks = [rng.below(a, 0, 5) for _ in range(1000)]
    assert set(ks) == set(range(5))


@pytest.mark.parametrize("kwargs", [{"alpha": 0.0}, {"gamma": 1.0}, {"epsilon": 1.5},
                                    {"state": "fancy"}, {"target_low": 2.0, "target_high": 1.0},
                                    {"episodes": 0}, {"eta": -1.0}, {"error_edges": (0.1, 0.05)}])
def test_bad_config_raises(kwargs: dict[str, object]) -> None:
    with pytest.raises(ConfigError):
        QConfig(**kwargs)  # type: ignore[arg-type]


def test_bad_inputs_raise() -> None:
    m = plant_model(PlantParams())
    with pytest.raises(InvalidInputError):
        train(m, QConfig(episodes=1, steps=1), [])
    with pytest.raises(InvalidInputError):
        train(m, QConfig(episodes=1, steps=1), [-1])
    with pytest.raises(InvalidInputError):
        greedy_rollout(m, np.zeros((10, 5)), QConfig())
    with pytest.raises(MsdBenchError):
        greedy_rollout(m, np.full((100, 5), np.nan), QConfig())


@pytest.mark.parametrize("cfg", [QConfig(), improved_config()], ids=["paper", "improved"])
@pytest.mark.parametrize("on_plant", [True, False], ids=["plant", "linear"])
def test_fast_episode_equals_transition_step_by_step(cfg: QConfig, on_plant: bool) -> None:
    # q_episode is the hot loop: it must take exactly transition's steps (draws, updates, bits).
    model = (plant_model(PlantParams()) if on_plant else _linear_model()).kernel
    lr, target, steps = packed(cfg), 0.7, 400
    s0 = qlearning.encode(lr.enc, -target, 0.0, target)
    q_fast, q_ref = np.zeros((lr.enc.n_states, 5)), np.zeros((lr.enc.n_states, 5))
    st_fast, st_ref = rng.seed_states([5]), rng.seed_states([5])
    pl_fast, pl_ref = np.zeros(4), np.zeros(4)
    total = qlearning.q_episode(model, lr, q_fast, pl_fast, s0, 0.0, target, steps, st_fast, 0)
    s, x, err, ref_total = s0, 0.0, target, 0.0
    for _ in range(steps):
        _, x, err, s, r = qlearning.transition(model, lr, q_ref, pl_ref, s, x, err, target, st_ref, 0)
        ref_total += r
    assert np.count_nonzero(q_ref) > 3  # the episode did learn something
    assert np.array_equal(q_fast, q_ref)
    assert total == ref_total
    assert np.array_equal(st_fast, st_ref) and np.array_equal(pl_fast, pl_ref)


def test_batch_sliced_over_threads_equals_one_call() -> None:
    m = plant_model(PlantParams())
    cases = [(packed(QConfig(episodes=2, steps=300)), 0),
             (packed(improved_config(episodes=2, steps=300, observer="alpha-beta", obs_gain=0.5,
                                     train_noise=0.01, train_delay=2)), 0),
             (packed(QConfig(episodes=2, steps=100)), 5)]  # Dyna-Q
    seeds = [4, 9, 1, 16, 25, 36, 49, 64, 81, 100, 121]  # slices of one and of several agents
    for lr, n_plan in cases:
        plan = budget(QConfig(episodes=2, steps=300), n_plan)
        one = run_batch(m.kernel, lr, plan, rng.seed_states(seeds), workers=1)
        for workers in (2, 3, 8):
            sliced = run_batch(m.kernel, lr, plan, rng.seed_states(seeds), workers=workers)
            for a, b in zip(one, sliced, strict=True):
                assert a.shape == b.shape and np.array_equal(a, b)
