"""Wall time of ``msd-bench paper`` at the paper's budgets, and where that time goes.

Runs the real console command (``python -m msd_bench.cli paper --seeds N``,
default budgets: 300 episodes × 3,000 steps, Dyna-Q 300 episodes with 100
planning steps, 12,000-sample records) as a subprocess in a temporary
directory, then reads its ``table1.json`` for the success rate and median SSE
of every agent kind. The floor is 600 s for 20 seeds on the 2-core machine.

In the same run, the pipeline's stage functions (:func:`make_records`,
:func:`identify_surrogates` one surrogate at a time, :func:`train_and_validate`
per agent kind) are timed in this process, after a tiny warm-up that loads the
compiled kernels, so the report shows which stage dominates and how much the
command adds on top (imports, compilation, writing files and figures). The
in-process per-seed SSE is also checked against the command's table: the same
config must give the same numbers in another process.

    .venv/bin/python benchmarks/bench_paper.py [--seeds 20] [--preset default|mild]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from msd_bench.app.agents import agent_kind
from msd_bench.app.config import RunConfig as PaperConfig
from msd_bench.app.pipeline import Trained, identify_surrogates, make_records, train_and_validate
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.physics.plant import PRESETS

FLOOR_S = 600.0
"""Whole command, 20 seeds, default budgets, 2-core machine."""


def run_command(seeds: int, preset: str, out: Path) -> tuple[float, dict[str, Any]]:
    """Wall time of the console command and the table it wrote."""
    cmd = [sys.executable, "-m", "msd_bench.cli", "paper", "--seeds", str(seeds), "--preset", preset,
           "--out", str(out), "--first-seed", "0"]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=out.parent)
    seconds = time.perf_counter() - t0
    if proc.returncode != 0:
        sys.exit(f"msd-bench paper failed ({proc.returncode}): {proc.stderr.strip()[-1000:]}")
    return seconds, json.loads((out / "table1.json").read_text())


def table_summary(table: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """Per agent kind: n, success rate and median SSE (%), from table1.json."""
    return {
        a["kind"]: {"n": a["n"], "success_rate": round(a["success_rate"], 3),
                    "median_sse_percent": _round(a["summary"]["sse"]["median"]),
                    "fit_sim_percent": _round(a["fit_sim_percent"])}
        for a in table["agents"]
    }


def warm_up(cfg: PaperConfig) -> float:
    """Load (or compile) the kernels on a tiny budget so stage timings are steady-state."""
    t0 = time.perf_counter()
    tiny = PaperConfig(preset=cfg.preset, seeds=1, episodes=1, steps=10, dyna_episodes=1,
                       planning_steps=1, validation_steps=10, window=5, samples=1000, val_samples=1000)
    make_records(tiny, 0)
    plant = plant_model(tiny.plant)
    for kind in ("plant", "dyna-q"):
        train_and_validate(kind, plant, tiny, [0])
    return time.perf_counter() - t0


def time_stages(cfg: PaperConfig) -> tuple[dict[str, Any], dict[str, Trained]]:
    """Each stage of one identification seed, timed separately in this process."""
    seeds = cfg.learning_seeds(0)
    stages: dict[str, Any] = {"warmup_s": round(warm_up(cfg), 2)}
    t0 = time.perf_counter()
    records = make_records(cfg, 0)
    stages["records_s"] = round(time.perf_counter() - t0, 3)
    models: dict[str, StepModel] = {"plant": plant_model(cfg.plant)}
    stages["identification_s"] = {}
    for name in cfg.surrogates_needed():
        t0 = time.perf_counter()
        fitted, _ = identify_surrogates(records, [name], 0, cfg.plant, cfg.nlarx_scale)
        stages["identification_s"][name] = round(time.perf_counter() - t0, 2)
        models.update(fitted)
    stages["training_s"] = {}
    trained: dict[str, Trained] = {}
    for kind_name in cfg.agents:
        t0 = time.perf_counter()
        surrogate = models[agent_kind(kind_name).surrogate]
        trained[kind_name] = train_and_validate(kind_name, surrogate, cfg, seeds)
        stages["training_s"][kind_name] = round(time.perf_counter() - t0, 2)
    stages["total_s"] = round(stages["records_s"] + sum(stages["identification_s"].values())
                              + sum(stages["training_s"].values()), 2)
    return stages, trained


def same_as_table(trained: dict[str, Trained], table: dict[str, Any]) -> bool:
    """Per-seed SSE of the in-process stages equals the command's, kind by kind."""
    rows = {a["kind"]: a for a in table["agents"]}
    for kind, t in trained.items():
        theirs = [np.nan if s["sse"] is None else s["sse"] for s in rows[kind]["per_seed"]]
        if not np.array_equal([m["sse"] for m in t.metrics], theirs, equal_nan=True):
            return False
    return True


def _round(v: float | None) -> float | None:
    return None if v is None else round(float(v), 2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20, help="learning seeds per agent kind (20)")
    parser.add_argument("--preset", default="default", choices=sorted(PRESETS))
    args = parser.parse_args()
    cfg = PaperConfig(preset=args.preset, seeds=args.seeds)
    with tempfile.TemporaryDirectory(prefix="bench_paper_") as tmp:
        seconds, table = run_command(args.seeds, args.preset, Path(tmp) / "out")
    stages, trained = time_stages(cfg)
    run_s = float(table["run"]["seconds"])
    print(json.dumps({
        "benchmark": "paper",
        "preset": args.preset,
        "seeds": args.seeds,
        "seconds": round(seconds, 2),
        "floor_seconds": FLOOR_S,
        "floor_ratio": round(seconds / FLOOR_S, 3),
        "meets_floor": seconds <= FLOOR_S,
        "pipeline_seconds_reported_by_command": run_s,
        "startup_and_writing_seconds": round(seconds - run_s, 2),
        "agents": table_summary(table),
        "stages_in_process": stages,
        "command_over_stages": round(seconds / stages["total_s"], 2),
        "in_process_matches_command": same_as_table(trained, table),
    }, indent=2))


if __name__ == "__main__":
    main()
