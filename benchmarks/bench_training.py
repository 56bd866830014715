"""Speed of compiled Q-learning and Dyna-Q, against a minimal compiled loop and a plain Python loop.

Prints one JSON object (medians over ``--repeat`` rounds; every ratio is taken
within one round, so a loaded machine slows both sides alike). Floors (issue
10): one paper-sized run (300 × 3,000 = 900 k steps) within 1.5× of a minimal
compiled loop of the same algorithm (``over_minimal_loop``), and a batch of 64
agents at >= 10 M agent-steps/s on the machine's cores
(``batch64_agent_steps_per_s``). The minimal loop is checked to learn the very
same Q-table as ``train`` (``minimal_loop_equals_train``), so the ratio
compares equal work. ``scripts/make_results.py performance`` stores this JSON
with the commit and machine. With ``--success N`` it also trains N seeds of the
paper and the improved agent on the true plant and reports their success rates.

    .venv/bin/python benchmarks/bench_training.py [--repeat 3]
    .venv/bin/python benchmarks/bench_training.py --success 64 --first-seed 1000
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import statistics
import time
from typing import Any

import numba
import numpy as np

from msd_bench.core.evaluation import robustness
from msd_bench.core.evaluation.scenarios import parse
from msd_bench.core.evaluation.stats import summarize
from msd_bench.core.learning import rng
from msd_bench.core.learning.dyna import DynaConfig, train_dyna
from msd_bench.core.learning.qconfig import QConfig, improved_config, packed
from msd_bench.core.learning.qtrain import budget, run_batch, train
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PlantParams, preset
from msd_bench.designs.qlearning import tables_policy

FloatArray = np.ndarray


def python_loop_steps_per_s(params: PlantParams, cfg: QConfig, n_steps: int) -> float:
    """The paper's Q-learning step (plant, state, ε-greedy, reward, shaped update), all plain Python."""
    rnd = random.Random(0)
    n, emax = cfg.n_states, cfg.e_max
    q = [[0.0] * 5 for _ in range(n)]
    forces = list(cfg.actions())
    target = rnd.uniform(cfg.target_low, cfg.target_high)
    m, c, k, g, h, stroke, f_max, dt = (params.m, params.c, params.k, params.g, params.h, params.L,
                                        params.F, params.dt)

    def plant_step(x: float, v: float, u: float) -> tuple[float, float]:
        u = min(max(u, -f_max), f_max)
        v = v + dt * (u - c * v - k * math.sin(g * x) - h * x * x * x) / m
        x_free = x + dt * v
        x_new = min(max(x_free, -stroke / 2), stroke / 2)
        return x_new, (v if x_new == x_free else 0.0)

    def index(e: float) -> int:
        return math.floor((n - 1) * (min(max(e, -emax), emax) + emax) / (2 * emax) + 0.5)

    def phi(s: int, a: int) -> float:
        side = 0 if abs(2 * s - (n - 1)) < 2 else (1 if s > n // 2 else -1)
        return 1.0 if side * forces[a] > 0 else 0.0

    x, v = 0.0, 0.0
    err = abs(x - target)
    s = index(x - target)
    start = time.perf_counter()
    for _ in range(n_steps):
        row = q[s]
        if rnd.random() < cfg.epsilon:
            a = rnd.randrange(5)
        else:
            best = max(row)
            a = rnd.choice([i for i in range(5) if row[i] == best])
        x, v = plant_step(x, v, forces[a])
        e = x - target
        s2 = index(e)
        r = cfg.g / (1 + abs(e)) - cfg.zeta * (abs(e) - err) / cfg.e_max
        td = cfg.reward_gain * r + cfg.gamma * max(q[s2]) - row[a]
        row[a] += cfg.alpha * td - cfg.eta * phi(s, a)
        err, s = abs(e), s2
    return n_steps / (time.perf_counter() - start)


@numba.njit(cache=True)
def _splitmix(z: np.uint64) -> tuple[np.uint64, float]:
    z = z + np.uint64(0x9E3779B97F4A7C15)
    y = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    y = (y ^ (y >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    y = y ^ (y >> np.uint64(31))
    return z, float(y >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@numba.njit(cache=True)
def minimal_loop(p: FloatArray, phi: FloatArray, forces: FloatArray, w: FloatArray, n: int,
                 episodes: int, steps: int, seed: int) -> FloatArray:
    """The paper's learner as one straightforward numba loop: nothing but locals and the Q-table.

    ``p`` = plant [m, c, k, g, h, L, F, dt]; ``w`` = [α, γ, ε, A, g, ζ, e_max, η, target_low,
    target_high]. Same stream (splitmix64), same draws, same operations as
    ``train``, so it must learn the same table: what ``train`` costs beyond
    this is the price of its generality (any model, any encoder, observers).
    """
    m, c, k, g, h, stroke, f_max, dt = p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]
    alpha, gamma, eps, gain, g_r, zeta, emax, eta, lo, hi = (w[0], w[1], w[2], w[3], w[4], w[5],
                                                             w[6], w[7], w[8], w[9])
    q = np.zeros((n, 5))
    z = np.uint64(seed)
    for _ in range(episodes):
        z, u01 = _splitmix(z)
        target = lo + (hi - lo) * u01
        x, v = 0.0, 0.0
        err = abs(x - target)
        s = math.floor((n - 1) * (min(max(x - target, -emax), emax) + emax) / (2.0 * emax) + 0.5)
        for _ in range(steps):
            z, u01 = _splitmix(z)
            if u01 < eps:
                z, u01 = _splitmix(z)
                a = min(int(u01 * 5), 4)
            else:
                best, count = q[s, 0], 1
                for b in range(1, 5):
                    if q[s, b] > best:
                        best, count = q[s, b], 1
                    elif q[s, b] == best:
                        count += 1
                j = 0
                if count > 1:
                    z, u01 = _splitmix(z)
                    j = min(int(u01 * count), count - 1)
                a = 0
                for b in range(5):
                    if q[s, b] == best:
                        if j == 0:
                            a = b
                            break
                        j -= 1
            u = min(max(forces[a], -f_max), f_max)
            v = v + dt * (u - c * v - k * math.sin(g * x) - h * x * x * x) / m
            x_free = x + dt * v
            x = min(max(x_free, -0.5 * stroke), 0.5 * stroke)
            if x != x_free:
                v = 0.0
            e = x - target
            s2 = math.floor((n - 1) * (min(max(e, -emax), emax) + emax) / (2.0 * emax) + 0.5)
            r = g_r / (1.0 + abs(e)) - zeta * (abs(e) - err) / emax
            nxt = q[s2, 0]
            for b in range(1, 5):
                nxt = max(nxt, q[s2, b])
            q[s, a] += alpha * (gain * r + gamma * nxt - q[s, a]) - eta * phi[s, a]
            err, s = abs(e), s2
    return q


def minimal_args(params: PlantParams, cfg: QConfig, seed: int) -> tuple[Any, ...]:
    """Arguments of :func:`minimal_loop` for ``cfg`` on the plant ``params``."""
    lr = packed(cfg)
    w = np.array([cfg.alpha, cfg.gamma, cfg.epsilon, cfg.reward_gain, cfg.g, cfg.zeta, cfg.e_max,
                  cfg.eta, cfg.target_low, cfg.target_high])
    return (plant_model(params).kernel.params, lr.phi, lr.actions, w, cfg.n_states, cfg.episodes,
            cfg.steps, seed)


def best_of(fn: Any, repeats: int = 3) -> float:
    """Fastest wall time of ``repeats`` calls (the machine is shared)."""
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def fastest_with_cpu(fn: Any, repeats: int) -> tuple[float, float]:
    """(wall, process CPU time) of the fastest of ``repeats`` calls; CPU time counts every thread."""
    best = (math.inf, 0.0)
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        fn()
        wall, cpu = time.perf_counter() - t, time.process_time() - c
        best = min(best, (wall, cpu))
    return best


def speed() -> dict[str, Any]:
    """One round: compiled training against the minimal loop and Python, batches, Dyna-Q."""
    params = PlantParams()
    model = plant_model(params)
    cfg = QConfig()
    t = time.perf_counter()
    train(model, QConfig(episodes=1, steps=10), [0])
    train_dyna(model, DynaConfig(QConfig(episodes=1, steps=10)), [0])
    minimal_loop(*minimal_args(params, QConfig(episodes=1, steps=10), 0))
    compile_s = time.perf_counter() - t
    args = minimal_args(params, cfg, 0)
    equal = bool(np.array_equal(minimal_loop(*args), train(model, cfg, [0]).q[0]))
    run_s, minimal_s = [], []
    for _ in range(5):  # interleaved, so both sides see the same machine
        run_s.append(best_of(lambda: train(model, cfg, [0]), repeats=1))
        minimal_s.append(best_of(lambda: minimal_loop(*args), repeats=1))
    one_run, minimal = min(run_s), min(minimal_s)
    steps = cfg.episodes * cfg.steps
    py_rate = python_loop_steps_per_s(params, cfg, 30_000)
    out: dict[str, Any] = {
        "compile_or_cache_load_s": round(compile_s, 2),
        "paper_run_steps": steps,
        "paper_run_s": round(one_run, 4),
        "paper_run_ns_per_step": round(one_run / steps * 1e9, 1),
        "minimal_loop_s": round(minimal, 4),
        "minimal_loop_ns_per_step": round(minimal / steps * 1e9, 1),
        "minimal_loop_equals_train": equal,
        "over_minimal_loop": round(one_run / minimal, 3),
        "python_loop_steps_per_s": round(py_rate),
        "python_loop_paper_run_s_extrapolated": round(steps / py_rate, 1),
        "speedup_vs_python": round(steps / py_rate / one_run, 1),
    }
    batch_cfg = QConfig(episodes=10)  # 30 k steps per agent keeps the 256-agent batch short
    per_agent = batch_cfg.episodes * batch_cfg.steps
    lr, plan = packed(batch_cfg), budget(batch_cfg, 0)
    one_core = best_of(lambda: run_batch(model.kernel, lr, plan, rng.seed_states(range(64)), workers=1),
                       repeats=2)
    out["batch64_one_core_agent_steps_per_s"] = round(64 * per_agent / one_core)
    for n in (64, 256):
        wall, cpu = fastest_with_cpu(lambda n=n: train(model, batch_cfg, list(range(n))), repeats=2)
        out[f"batch{n}_agent_steps_per_s"] = round(n * per_agent / wall)
        if n == 64:  # how much of the machine's cores the batch got (other jobs share them)
            out["batch64_cpu_share_of_all_cores"] = round(cpu / (wall * (os.cpu_count() or 1)), 2)
    out["batch64_over_one_core"] = round(out["batch64_agent_steps_per_s"]
                                         / out["batch64_one_core_agent_steps_per_s"], 2)
    dyna = DynaConfig()
    out["dyna_budget"] = "full: 300 episodes x 3000 steps x 100 planning updates, one agent"
    out["dyna_s"] = round(best_of(lambda: train_dyna(model, dyna, [0]), repeats=1), 2)
    return out


def medians(rounds: list[dict[str, Any]]) -> dict[str, Any]:
    """Per key: the median over rounds for numbers, all-true for flags, the value otherwise."""
    out: dict[str, Any] = {}
    for key, first in rounds[0].items():
        values = [r[key] for r in rounds]
        if isinstance(first, bool):
            out[key] = all(values)
        elif isinstance(first, int | float):
            out[key] = statistics.median(values)
        else:
            out[key] = first
    return out


def success(n: int, first: int) -> list[dict[str, Any]]:
    """Success rate (SSE < 5 %) of both agents trained and validated on the true plant."""
    rows = []
    seeds = list(range(first, first + n))
    for name in ("default", "mild"):
        params = preset(name)
        model = plant_model(params)
        for agent, cfg in (("paper", QConfig()), ("improved", improved_config())):
            # The nominal scenario is the ordinary validation: unit step, 3,000 steps, SSE window 500.
            tables = tables_policy(train(model, cfg, seeds).q, cfg, seeds, model)
            nominal = robustness.evaluate_policy(tables, params, seeds, [parse("nominal")])["nominal"]
            sse = summarize(nominal["sse"])
            rows.append({"preset": name, "agent": agent, "seeds": f"{first}..{first + n - 1}",
                         "n": nominal["n"], "n_success": nominal["n_success"],
                         "success_rate": round(nominal["n_success"] / nominal["n"], 3),
                         "sse_median": round(sse.median, 3), "sse_mean": round(sse.mean, 3),
                         "sse_sd": round(sse.sd, 3)})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="rounds; the JSON gives medians")
    parser.add_argument("--success", type=int, default=0, help="seeds per agent (0 = skip)")
    parser.add_argument("--first-seed", type=int, default=0)
    args = parser.parse_args()
    load_before = [round(v, 2) for v in os.getloadavg()]
    rounds = [speed() for _ in range(max(1, args.repeat))]
    out = medians(rounds)
    out["rounds"] = len(rounds)
    out["per_round"] = {k: [r[k] for r in rounds] for k in
                        ("paper_run_s", "minimal_loop_s", "over_minimal_loop", "speedup_vs_python",
                         "batch64_agent_steps_per_s", "batch64_over_one_core",
                         "batch64_cpu_share_of_all_cores")}
    out["floor_over_minimal_loop_1_5"] = out["over_minimal_loop"] <= 1.5
    out["floor_batch64_10M_agent_steps_per_s"] = out["batch64_agent_steps_per_s"] >= 10e6
    out["load_average_1_5_15_before"] = load_before
    out["load_average_1_5_15_after"] = [round(v, 2) for v in os.getloadavg()]
    if args.success > 0:
        out["success_on_true_plant"] = success(args.success, args.first_seed)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
