"""Speed of compiled Q-learning and Dyna-Q, against a plain Python loop measured in the same run.

Prints one JSON object. Floors from the brief: one paper-sized run (300 × 3,000
= 900 k steps) under 2 s, and a batch of agents at >= 2 M agent-steps/s.
With ``--success N`` it also trains N seeds of the paper and the improved agent
on the true plant (default and mild presets) and reports their success rates.

    .venv/bin/python benchmarks/bench_training.py [--success 64 --first-seed 1000]
"""

from __future__ import annotations

import argparse
import json
import math
import random
import time
from typing import Any

from msd_bench.core import plant, robustness
from msd_bench.core.dyna import DynaConfig, train_dyna
from msd_bench.core.model import plant_model
from msd_bench.core.plant import PlantParams, preset
from msd_bench.core.qconfig import QConfig, improved_config
from msd_bench.core.qtrain import train
from msd_bench.core.scenarios import parse
from msd_bench.core.stats import summarize


def python_loop_steps_per_s(params: PlantParams, cfg: QConfig, n_steps: int) -> float:
    """The paper's Q-learning step (state, ε-greedy, reward, shaped update) in plain Python."""
    rnd = random.Random(0)
    n, emax = cfg.n_states, cfg.e_max
    q = [[0.0] * 5 for _ in range(n)]
    forces = list(cfg.actions())
    target = rnd.uniform(cfg.target_low, cfg.target_high)

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
        x, v = plant.step(x, v, forces[a], params)
        e = x - target
        s2 = index(e)
        r = cfg.g / (1 + abs(e)) - cfg.zeta * (abs(e) - err) / cfg.e_max
        td = cfg.reward_gain * r + cfg.gamma * max(q[s2]) - row[a]
        row[a] += cfg.alpha * td - cfg.eta * phi(s, a)
        err, s = abs(e), s2
    return n_steps / (time.perf_counter() - start)


def best_of(fn: Any, repeats: int = 3) -> float:
    """Fastest wall time of ``repeats`` calls (the machine is shared)."""
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def speed() -> dict[str, Any]:
    """Timings of compiled training, batches, the Python baseline and Dyna-Q."""
    params = PlantParams()
    model = plant_model(params)
    cfg = QConfig()
    t = time.perf_counter()
    train(model, QConfig(episodes=1, steps=10), [0])
    train_dyna(model, DynaConfig(QConfig(episodes=1, steps=10)), [0])
    compile_s = time.perf_counter() - t
    one_run = best_of(lambda: train(model, cfg, [0]))
    steps = cfg.episodes * cfg.steps
    py_rate = python_loop_steps_per_s(params, cfg, 30_000)
    out: dict[str, Any] = {
        "compile_or_cache_load_s": round(compile_s, 2),
        "paper_run_steps": steps,
        "paper_run_s": round(one_run, 3),
        "python_loop_steps_per_s": round(py_rate),
        "python_loop_paper_run_s_extrapolated": round(steps / py_rate, 1),
        "speedup_vs_python": round(steps / py_rate / one_run, 1),
        "floor_one_run_under_2s": one_run < 2.0,
    }
    batch_cfg = QConfig(episodes=10)  # 30 k steps per agent keeps the 256-agent batch short
    for n in (64, 256):
        wall = best_of(lambda n=n: train(model, batch_cfg, list(range(n))), repeats=2)
        out[f"batch{n}_agent_steps_per_s"] = round(n * batch_cfg.episodes * batch_cfg.steps / wall)
    out["floor_batch_2M_agent_steps_per_s"] = min(out["batch64_agent_steps_per_s"],
                                                  out["batch256_agent_steps_per_s"]) >= 2e6
    dyna = DynaConfig()
    out["dyna_budget"] = "full: 300 episodes x 3000 steps x 100 planning updates, one agent"
    out["dyna_s"] = round(best_of(lambda: train_dyna(model, dyna, [0]), repeats=1), 2)
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
            nominal = robustness.evaluate(train(model, cfg, seeds).q, cfg, params, seeds,
                                          [parse("nominal")])["nominal"]
            sse = summarize(nominal["sse"])
            rows.append({"preset": name, "agent": agent, "seeds": f"{first}..{first + n - 1}",
                         "n": nominal["n"], "n_success": nominal["n_success"],
                         "success_rate": round(nominal["n_success"] / nominal["n"], 3),
                         "sse_median": round(sse.median, 3), "sse_mean": round(sse.mean, 3),
                         "sse_sd": round(sse.sd, 3)})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--success", type=int, default=0, help="seeds per agent (0 = skip)")
    parser.add_argument("--first-seed", type=int, default=0)
    args = parser.parse_args()
    out = speed()
    if args.success > 0:
        out["success_on_true_plant"] = success(args.success, args.first_seed)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
