"""Measure the open choices docs/decisions.md discusses, and write the numbers to JSON.

Three measurements on the default plant, all in-process (no ROS), each over the
same learning seeds:

* ``shaping`` — the paper agent under three readings of the shaping term
  ``η φ(s, a)``: none (η = 0); ``away`` (the code's reading: penalise a force
  that pushes away from the target, outside the two zero-error bins); and
  ``not_toward`` (penalise every action that does not push toward the target,
  u = 0 included, in every bin). Trained on the true plant and on a PLM
  identified from the paper's five bias records, validated on the true plant.
  The code offers only ``away``; ``not_toward`` is measured here by swapping the
  φ table the kernels receive, nothing else.
* ``noise`` — the paper agent and the improved agent trained on the true plant,
  validated with Gaussian noise of σ on the position they observe (the plant
  and the metrics use the true position). The improved agent's lead error
  ``e + 50 (x_k - x_{k-1})`` differences raw samples, so it multiplies σ by
  about 50·√2 ≈ 71.
* ``reward`` and ``targets`` — the paper agent trained on the true plant with
  other values of ζ, and with other ranges of training set-points.
* ``fit`` — what one-step fit means at 100 Hz: the Best-Fit of two predictors
  that know nothing about the plant (hold the last sample; extrapolate
  ``2 y[k-1] - y[k-2]``) on the broad validation record `msd-bench paper` uses.
* ``metrics`` — how the paper agent's success count on the true plant depends
  on the SSE window, and how often ts is defined under a 2 % and a 5 % band.

    .venv/bin/python scripts/measure_decisions.py [--seeds 64] [--out docs/results/decisions.json]
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import platform
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from msd_bench.core.evaluation.metrics import SUCCESS_SSE, compute  # noqa: E402
from msd_bench.core.identification import identify  # noqa: E402
from msd_bench.core.identification.excitation import MultilevelConfig  # noqa: E402
from msd_bench.core.identification.fit import fit_percent  # noqa: E402
from msd_bench.core.identification.plm import PLM_BIASES  # noqa: E402
from msd_bench.core.learning import qtrain  # noqa: E402
from msd_bench.core.learning.learner import GreedyPolicy  # noqa: E402
from msd_bench.core.learning.qconfig import QConfig, improved_config  # noqa: E402
from msd_bench.core.physics import plant  # noqa: E402
from msd_bench.core.physics.model import StepModel, plant_model  # noqa: E402

NOISE_MM = (0.0, 0.2, 0.5, 1.0, 2.0, 5.0)
"""Sensor noise levels, standard deviation in mm."""


def validate(q: np.ndarray, cfg: QConfig, truth: StepModel, window: int = 500) -> list[Any]:
    """Metrics of each greedy table on the true plant (unit step, 3,000 steps)."""
    xs, _ = qtrain.greedy_rollouts(truth, q, cfg, 1.0, 3000)
    return [compute(x, 1.0, 0.01, window) for x in xs]


def counts(results: list[Any]) -> dict[str, Any]:
    """n, successes and the median SSE of a batch of validation runs."""
    sse = [m.sse for m in results]
    return {"n": len(sse), "n_success": int(sum(s < SUCCESS_SSE for s in sse)),
            "median_sse": round(float(np.median(sse)), 3)}


def identified_plm(params: plant.PlantParams) -> StepModel:
    """The PLM of identification seed 0 (the records `msd-bench paper` uses for it)."""
    records = {b: identify.bias_record(params, b, 1000 + i) for i, b in enumerate(PLM_BIASES)}
    return identify.identify_plm(records)


def measure_shaping(seeds: list[int], params: plant.PlantParams) -> dict[str, Any]:
    """Paper agent under each reading, trained on the plant and on the PLM."""
    truth = plant_model(params)
    out: dict[str, Any] = {}
    for name, model in (("plant", truth), ("plm", identified_plm(params))):
        for reading in ("none", "away", "not_toward"):
            cfg = QConfig(eta=0.0) if reading == "none" else QConfig(
                shaping="toward" if reading == "not_toward" else "away")
            q = qtrain.train(model, cfg, seeds).q
            out[f"{name}/{reading}"] = counts(validate(q, cfg, truth))
    return out


def measure_learner(seeds: list[int], params: plant.PlantParams) -> dict[str, Any]:
    """Paper agent on the true plant: ζ in {0, 10, 50, 200}; training targets over four ranges."""
    truth = plant_model(params)
    reward = {}
    for zeta in (0.0, 10.0, 50.0, 200.0):
        cfg = QConfig(zeta=zeta)
        reward[f"zeta_{zeta:g}"] = counts(validate(qtrain.train(truth, cfg, seeds).q, cfg, truth))
    targets = {}
    for lo, hi in ((1.0, 1.0), (0.5, 1.5), (-2.0, 2.0), (-2.5, 2.5)):
        cfg = QConfig(target_low=lo, target_high=hi)
        targets[f"{lo:g}..{hi:g}"] = counts(validate(qtrain.train(truth, cfg, seeds).q, cfg, truth))
    return {"reward": reward, "targets": targets}


def noisy_run(policy: GreedyPolicy, params: plant.PlantParams, sigma: float,
              rng: np.random.Generator) -> np.ndarray:
    """3,000 greedy steps on the true plant, the policy seeing position + N(0, σ²)."""
    x, v = 0.0, 0.0
    xs = np.empty(3000)
    for k in range(3000):
        xs[k] = x
        seen = x + sigma * rng.standard_normal() if sigma > 0 else x
        x, v = plant.step(x, v, policy.force(seen), params)
    return xs


def measure_noise(seeds: list[int], params: plant.PlantParams) -> dict[str, Any]:
    """Success of both agents (trained on the true plant) under sensor noise."""
    truth = plant_model(params)
    out: dict[str, Any] = {}
    for agent, cfg in (("paper", QConfig()), ("improved", improved_config())):
        q = qtrain.train(truth, cfg, seeds).q
        for level, mm in enumerate(NOISE_MM):
            results = []
            for i, seed in enumerate(seeds):
                rng = np.random.default_rng(10_000 * seed + level)
                x = noisy_run(GreedyPolicy(cfg, q[i], 1.0), params, mm / 1000.0, rng)
                results.append(compute(x, 1.0, 0.01, 500))
            out[f"{agent}/{mm:g}mm"] = counts(results)
    return out


def measure_metrics(seeds: list[int], params: plant.PlantParams) -> dict[str, Any]:
    """Paper agent on the true plant: success per SSE window; ts defined at 2 % and 5 %."""
    truth = plant_model(params)
    cfg = QConfig()
    q = qtrain.train(truth, cfg, seeds).q
    out: dict[str, Any] = {f"window_{w}": counts(validate(q, cfg, truth, w)) for w in (300, 500, 1000)}
    runs = validate(q, cfg, truth)
    out["ts2_defined"] = int(sum(np.isfinite(m.ts2) for m in runs))
    out["ts5_defined"] = int(sum(np.isfinite(m.ts5) for m in runs))
    out["ts2_defined_among_successes"] = int(sum(np.isfinite(m.ts2) for m in runs if m.success))
    out["n_success"] = int(sum(m.success for m in runs))
    return out


def measure_fit_baselines(params: plant.PlantParams) -> dict[str, float]:
    """One-step Best-Fit of model-free predictors on the broad validation record of id seed 0."""
    y = identify.broad_record(params, 5007, MultilevelConfig(n_samples=4000)).experiments[0].y
    hold, extrapolate = y.copy(), y.copy()
    hold[1:] = y[:-1]
    extrapolate[2:] = 2 * y[1:-1] - y[:-2]
    return {"hold_last_sample": round(fit_percent(y, hold), 2),
            "linear_extrapolation": round(fit_percent(y, extrapolate), 2)}


def facts(argv: list[str]) -> dict[str, Any]:
    """Command, commit and machine, so a number can be traced and re-measured."""
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True).stdout.strip()
    cpu = next((ln.split(":", 1)[1].strip() for ln in Path("/proc/cpuinfo").read_text().splitlines()
                if ln.startswith("model name")), platform.processor()) if Path("/proc/cpuinfo").exists() \
        else platform.processor()
    return {"command": " ".join([".venv/bin/python", "scripts/measure_decisions.py", *argv]),
            "commit": git("rev-parse", "HEAD"), "dirty": bool(git("status", "--porcelain")),
            "machine": {"cpu": cpu, "platform": platform.platform(), "python": platform.python_version(),
                        "numpy": np.__version__},
            "date": dt.datetime.now(dt.UTC).isoformat(timespec="seconds")}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=64, help="learning seeds per measurement (64)")
    p.add_argument("--first-seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=REPO / "docs" / "results" / "decisions.json")
    args = p.parse_args()
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    params = plant.preset("default")
    t0 = time.perf_counter()
    doc = {"schema": "msd-bench/decisions", **facts(sys.argv[1:]), "preset": "default",
           "seeds": f"{seeds[0]}..{seeds[-1]}", "success": f"SSE < {SUCCESS_SSE:g} % over the last 500 "
           "of 3,000 validation steps on the true plant, unit step",
           "shaping": measure_shaping(seeds, params), **measure_learner(seeds, params),
           "noise": measure_noise(seeds, params),
           "fit": measure_fit_baselines(params), "metrics": measure_metrics(seeds, params)}
    doc["seconds"] = round(time.perf_counter() - t0, 1)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=1) + "\n")
    print(json.dumps(doc, indent=1))


if __name__ == "__main__":
    main()
