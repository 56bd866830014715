"""Success rate of an agent trained and validated on the true plant, shared by the floor test.

The learning-floor test (:mod:`tests.core.test_learning_floor`) and the
measurement that chose its N and K run exactly this code, so the rate the
test's arithmetic rests on is the rate of the procedure the test runs. The
validation is the pipeline's: each fixed greedy table runs 3000 steps from rest
toward a 1 m set-point on the true plant, scored by :func:`metrics.compute`
with the 500-sample SSE window; success is SSE below ``results.SUCCESS_SSE``.

Measure (writes a JSON record beside the other results)::

    .venv/bin/python -m tests.core.learning_floor --agent improved --first-seed 10000 --n 200 \
        --out docs/results/learning_floor_improved.json
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from msd_bench.core.evaluation.metrics import compute
from msd_bench.core.evaluation.results import SUCCESS_SSE
from msd_bench.core.learning.qconfig import QConfig, improved_config
from msd_bench.core.learning.qtrain import greedy_rollouts, train
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import preset

AGENTS: dict[str, Callable[[], QConfig]] = {"improved": improved_config, "paper": QConfig}
"""Learner config per agent kind, at the paper's budget (300 episodes x 3000 steps)."""
TARGET, VALIDATION_STEPS, WINDOW = 1.0, 3000, 500


def validation_sse(q_tables: np.ndarray, cfg: QConfig) -> list[float]:
    """SSE (%) of each fixed table's greedy run on the default true plant."""
    params = preset("default")
    xs, _ = greedy_rollouts(plant_model(params), q_tables, cfg, TARGET, VALIDATION_STEPS)
    return [compute(x, TARGET, params.dt, WINDOW).sse for x in xs]


def trained_sse(agent: str, seeds: Sequence[int]) -> list[float]:
    """Train one ``agent`` per seed on the default true plant; their validation SSEs."""
    cfg = AGENTS[agent]()
    return validation_sse(train(plant_model(preset("default")), cfg, seeds).q, cfg)


def successes(sse: Sequence[float]) -> int:
    """How many runs meet the success criterion of Table 1."""
    return int(sum(s < SUCCESS_SSE for s in sse))


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agent", choices=sorted(AGENTS), default="improved")
    parser.add_argument("--first-seed", type=int, default=10_000)
    parser.add_argument("--n", type=int, default=200)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    seeds = list(range(args.first_seed, args.first_seed + args.n))
    start = time.perf_counter()
    sse = trained_sse(args.agent, seeds)
    commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                            check=False).stdout.strip()
    record = {
        "what": f"success rate (SSE < {SUCCESS_SSE} %) of the {args.agent} agent, trained "
                "300 x 3000 on the default true plant, greedy 3000-step validation at 1 m",
        "agent": args.agent, "seeds": f"{seeds[0]}..{seeds[-1]}", "n": len(sse),
        "n_success": successes(sse), "success_rate": successes(sse) / len(sse),
        "sse": [round(s, 4) for s in sse],
        "command": " ".join([Path(sys.executable).name, "-m", "tests.core.learning_floor",
                             *(argv if argv is not None else sys.argv[1:])]),
        "commit": commit, "machine": f"{platform.node()} {platform.machine()} "
                                     f"{platform.python_version()}",
        "seconds": round(time.perf_counter() - start, 1),
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(record, indent=1) + "\n")
    print(json.dumps({k: v for k, v in record.items() if k != "sse"}))


if __name__ == "__main__":
    main()
