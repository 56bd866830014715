"""Per-step time of the finite-alphabet MPC as an agent node calls it (stepwise ``act``).

Floor (issue 22): on one core, mean <= 2 ms and p99 <= 4 ms per step. The
controller is driven in closed loop on the true plant, from rest, at each
``--setpoints`` value for ``--steps`` samples (default 3 x 3,000 = 9,000 steps),
under the standard noisy scenario's sensor so the search sees realistic
states; only ``act`` is timed (time.perf_counter_ns around each call), after
one warm-up call that compiles it. Prints one JSON object, the 1-minute load
average at the start included (a loaded machine slows the numbers).

    .venv/bin/python benchmarks/bench_mpc.py [--model tests/data/pinned/plm.json] [--steps 3000]
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")  # one thread, before numba is imported

import argparse
import json
import time
from pathlib import Path

import numpy as np

from msd_bench.core import kernels
from msd_bench.core.baselines import mpc
from msd_bench.core.closed_loop import quantise
from msd_bench.core.plant import PlantParams
from msd_bench.io.artifacts import load_model

PINNED = Path(__file__).resolve().parents[1] / "tests" / "data" / "pinned" / "plm.json"


def timed_run(ctrl: mpc.Mpc, plant: kernels.Plant, steps: int, noise: np.ndarray) -> list[int]:
    """One closed-loop run from rest; the nanoseconds of each ``act`` call."""
    ctrl.reset()
    x, v = 0.0, 0.0
    out = []
    for k in range(steps):
        y = quantise(x + noise[k], 0.0)
        t0 = time.perf_counter_ns()
        u = ctrl.act(y)
        out.append(time.perf_counter_ns() - t0)
        x, v = kernels.plant_step(plant, x, v, u)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", type=Path, default=PINNED, help="surrogate artifact the MPC searches on")
    ap.add_argument("--steps", type=int, default=3000, help="samples per set-point")
    ap.add_argument("--setpoints", type=float, nargs="+", default=[1.0, -1.0, 1.5])
    ap.add_argument("--noise", type=float, default=0.002, help="sensor noise sigma, m")
    args = ap.parse_args()
    load1 = os.getloadavg()[0]
    p = PlantParams()
    plant = kernels.Plant(*(float(v) for v in p.as_array()))
    model = load_model(args.model)
    times: list[int] = []
    for i, target in enumerate(args.setpoints):
        ctrl = mpc.Mpc(mpc.design(model, target, p.F, p.dt))
        ctrl.act(0.0)  # compile outside the timing
        noise = args.noise * np.random.default_rng(i).standard_normal(args.steps)
        times += timed_run(ctrl, plant, args.steps, noise)
    ms = np.array(times) / 1e6
    mean, p50, p99 = float(ms.mean()), float(np.percentile(ms, 50)), float(np.percentile(ms, 99))
    print(json.dumps({"model": str(args.model), "steps": int(ms.size), "setpoints": args.setpoints,
                      "load1_at_start": load1, "threads": os.environ["NUMBA_NUM_THREADS"],
                      "mean_ms": mean, "p50_ms": p50, "p99_ms": p99, "max_ms": float(ms.max()),
                      "floor": {"mean_ms": 2.0, "p99_ms": 4.0},
                      "within_floor": mean <= 2.0 and p99 <= 4.0}, indent=2))


if __name__ == "__main__":
    main()
