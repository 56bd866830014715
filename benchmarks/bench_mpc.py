"""Per-step time of the finite-alphabet MPC as an agent node calls it (stepwise ``act``).

Floor (issue 22): on one core, mean <= 2 ms and p99 <= 4 ms per step. The
controller is driven in closed loop on the true plant, from rest, at each
``--setpoints`` value for ``--steps`` samples (default 3 x 3,000 = 9,000 steps),
under the standard noisy scenario's sensor so the search sees realistic
states; only ``act`` is timed, after one warm-up call that compiles it, both
in wall-clock time (``perf_counter_ns``: what a node's period sees, including
preemption on a shared machine) and in the thread's CPU time
(``thread_time_ns``: the search's own cost on one core). Prints one JSON
object, the 1-minute load average at the start, the commit and the machine
included; ``--out`` also writes it (never over an existing file) for
``scripts/readme_results.py`` to render into docs/baselines.md.

    .venv/bin/python benchmarks/bench_mpc.py [--model tests/data/pinned/plm.json] [--steps 3000]
        [--out docs/results/bench_mpc.json]
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")  # one thread, before numba is imported

import argparse
import json
import shlex
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from msd_bench.core.baselines import mpc
from msd_bench.core.errors import MsdBenchError
from msd_bench.core.evaluation.closed_loop import quantise
from msd_bench.core.physics import kernels
from msd_bench.core.physics.plant import PlantParams
from msd_bench.io.storage.artifacts import load_model

REPO = Path(__file__).resolve().parents[1]
PINNED = REPO / "tests" / "data" / "pinned" / "plm.json"


def timed_run(ctrl: mpc.Mpc, plant: kernels.Plant, steps: int,
              noise: np.ndarray) -> tuple[list[int], list[int]]:
    """One closed-loop run from rest; wall-clock and thread-CPU nanoseconds of each ``act`` call."""
    ctrl.reset()
    x, v = 0.0, 0.0
    wall, cpu = [], []
    for k in range(steps):
        y = quantise(x + noise[k], 0.0)
        t0, c0 = time.perf_counter_ns(), time.thread_time_ns()
        u = ctrl.act(y)
        cpu.append(time.thread_time_ns() - c0)
        wall.append(time.perf_counter_ns() - t0)
        x, v = kernels.plant_step(plant, x, v, u)
    return wall, cpu


def stats(ns: list[int]) -> dict[str, float]:
    """Mean, p50, p99 and max of per-step times, ms."""
    ms = np.array(ns) / 1e6
    return {"mean_ms": float(ms.mean()), "p50_ms": float(np.percentile(ms, 50)),
            "p99_ms": float(np.percentile(ms, 99)), "max_ms": float(ms.max())}


def provenance() -> dict[str, Any]:
    """Command, commit and machine: the generated docs cite them beside the figures."""
    sys.path.insert(0, str(REPO / "scripts"))
    from make_results import commit, machine

    return {"command": "benchmarks/bench_mpc.py " + shlex.join(sys.argv[1:]), "commit": commit(),
            "machine": machine()}


def fail(message: str) -> NoReturn:
    """A usage mistake: one line on stderr, exit 2, no traceback."""
    print(f"bench_mpc: error: {message}", file=sys.stderr)
    raise SystemExit(2)


def refuse_existing(out: Path | None) -> None:
    """A one-line exit 2 before any work when ``--out`` would overwrite a file or has no directory."""
    if out is None:
        return
    if out.exists():
        fail(f"{out} exists; not overwriting it")
    if not out.parent.is_dir():
        fail(f"{out}: directory {out.parent} does not exist")


def write(out: Path, text: str) -> None:
    """Write the document to a new file only (``x``): what another run wrote is never replaced."""
    try:
        with out.open("x") as f:
            f.write(text + "\n")
    except OSError as e:
        fail(f"cannot write {out}: {e.strerror}")


def shown(path: Path) -> str:
    """The model's path relative to the repository when inside it, so the document names no clone."""
    resolved = path.resolve()
    return str(resolved.relative_to(REPO)) if resolved.is_relative_to(REPO) else str(path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", type=Path, default=PINNED, help="surrogate artifact the MPC searches on")
    ap.add_argument("--steps", type=int, default=3000, help="samples per set-point")
    ap.add_argument("--setpoints", type=float, nargs="+", default=[1.0, -1.0, 1.5])
    ap.add_argument("--noise", type=float, default=0.002, help="sensor noise sigma, m")
    ap.add_argument("--blocks", type=int, nargs="+", help="searched blocks (default: MpcOptions')")
    ap.add_argument("--tail", type=int, help="hold-mode tail samples (default: MpcOptions')")
    ap.add_argument("--out", type=Path, help="also write the JSON here (must not exist)")
    args = ap.parse_args()
    refuse_existing(args.out)
    prov = provenance()  # before the run: the commit is the code that ran
    try:
        model = load_model(args.model)
    except MsdBenchError as e:
        fail(str(e))
    load1 = os.getloadavg()[0]
    start = time.monotonic()
    p = PlantParams()
    plant = kernels.Plant(*(float(v) for v in p.as_array()))
    opt = mpc.MpcOptions()
    opt = replace(opt, blocks=tuple(args.blocks) if args.blocks else opt.blocks,
                  tail=opt.tail if args.tail is None else args.tail)
    wall: list[int] = []
    cpu: list[int] = []
    for i, target in enumerate(args.setpoints):
        ctrl = mpc.Mpc(mpc.design(model, target, p.F, p.dt, opt))
        ctrl.act(0.0)  # compile outside the timing
        noise = args.noise * np.random.default_rng(i).standard_normal(args.steps)
        w, c = timed_run(ctrl, plant, args.steps, noise)
        wall += w
        cpu += c
    on_wall, on_cpu = stats(wall), stats(cpu)
    text = json.dumps({**prov, "seconds": round(time.monotonic() - start, 1),
                      "model": shown(args.model), "blocks": list(opt.blocks), "tail": opt.tail,
                      "steps": len(wall), "setpoints": args.setpoints,
                      "load1_at_start": load1, "threads": os.environ["NUMBA_NUM_THREADS"],
                      "wall": on_wall, "thread_cpu": on_cpu, "floor": {"mean_ms": 2.0, "p99_ms": 4.0},
                      "within_floor_wall": on_wall["mean_ms"] <= 2.0 and on_wall["p99_ms"] <= 4.0,
                      "within_floor_cpu": on_cpu["mean_ms"] <= 2.0 and on_cpu["p99_ms"] <= 4.0},
                     indent=2)
    print(text)
    if args.out is not None:
        write(args.out, text)


if __name__ == "__main__":
    main()
