"""Recording the paper's plan through node processes, beside the in-process baseline (same run).

* ``processes``: a lock-step plant process, then :func:`record_experiments` on
  :func:`paper_plan` (one served recorder and one served excitation process,
  a job per experiment, each bag verified bit for bit), with the stage's
  window of commands in flight (``record.RECORD_WINDOW``). Split into start-up
  (discovery, settle: job start until the first command) and sample time.
* ``processes_window_1``: the same with one exchange per command, the baseline
  of ``window_speedup`` (sample rates, same run).
* ``in_process``: ``plant.simulate`` + ``write_experiment`` of the same signals,
  the floor that no middleware pays.

    .venv/bin/python benchmarks/bench_record.py [--scale 1.0] [--seed 0]

``--scale`` shrinks the plan (e.g. 0.1 for a quick look). Prints JSON.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from msd_bench.core.physics.plant import preset, simulate
from msd_bench.graph import launch, record
from msd_bench.graph.jobs import JobFiles
from msd_bench.io.bags.reader import write_experiment


def through_processes(plan: list[record.ExperimentSpec], out: Path, window: int) -> dict[str, float]:
    """Wall time of recording ``plan`` from a lock-step plant process, split by phase."""
    record.TIMINGS.clear()
    with launch.process_group() as procs:
        t0 = time.perf_counter()
        plant = procs.start("plant.py", ["-p", "lockstep:=true"])
        plant.wait_for_line("ready", timeout=30.0)
        t_plant = time.perf_counter() - t0
        jobs = JobFiles(out.parent / f"jobs-{out.name}")  # each node's job file, beside the bags
        record.record_experiments(plan, out, procs, window=window, jobs=jobs)
        wall = time.perf_counter() - t0
    startup = sum(t.startup_s for t in record.TIMINGS)
    samples = sum(t.samples for t in record.TIMINGS if t.name in {s.name for s in plan})
    body = wall - t_plant - startup
    return {
        "wall_s": round(wall, 2), "plant_start_s": round(t_plant, 2),
        "startup_discovery_s": round(startup, 2), "samples_and_verify_s": round(body, 2),
        "experiments_recorded": len(record.TIMINGS), "samples": samples,
        "samples_per_s": round(samples / body, 1),
        "startup_per_experiment_s": round(startup / len(record.TIMINGS), 2), "window": window,
    }


def in_process(plan: list[record.ExperimentSpec], out: Path) -> dict[str, float]:
    """The same signals simulated and written without ROS."""
    t0 = time.perf_counter()
    params = preset("default")
    samples = 0
    for spec in plan:
        x, v, u = simulate(spec.force(), params)
        t_ns = np.arange(u.size, dtype=np.int64) * round(params.dt * 1e9)
        write_experiment(out / spec.name, t_ns, u, x, v, params=spec.bag_params())
        samples += u.size
    wall = time.perf_counter() - t0
    return {"wall_s": round(wall, 2), "samples": samples, "samples_per_s": round(samples / wall, 1)}


def main() -> None:
    """Run both and print JSON."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=float, default=1.0)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    plan = record.paper_plan(args.seed, round(12_000 * args.scale), round(4_000 * args.scale))
    with tempfile.TemporaryDirectory() as tmp:
        one = through_processes(plan, Path(tmp) / "window_1", 1)
        procs = through_processes(plan, Path(tmp) / "processes", record.RECORD_WINDOW)
        base = in_process(plan, Path(tmp) / "in_process")
    print(json.dumps({
        "plan": {"experiments": len(plan), "samples": int(sum(s.force().size for s in plan))},
        "processes": procs, "processes_window_1": one, "in_process": base,
        "window_speedup": round(procs["samples_per_s"] / one["samples_per_s"], 2),
        "ratio_wall_processes_over_in_process": round(procs["wall_s"] / base["wall_s"], 1),
    }, indent=1))


if __name__ == "__main__":
    main()
