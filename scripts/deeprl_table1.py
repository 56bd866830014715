"""Table 1 and robustness of the saved deep-RL policies beside learners, through the one assembly.

The deep-RL runs (``scripts/deeprl_runs.py run``) take about an hour per kind at the paper's 900,000
steps on this machine; they saved their greedy networks in ``docs/results/deeprl_policies``. This
script loads those networks as the deep-RL design's policies and hands them, beside the robust and
on-plant Q-learners made here on the same identification seed and learning seed, to
:func:`msd_bench.app.scoring.assemble` — the function that builds every Table 1 row and robustness
cell of ``msd-bench paper`` and ``bench.py`` — so a deep-RL row means exactly what a learner's does:

    python scripts/deeprl_table1.py --out docs/results/table1_deeprl.json

The document has ``table1`` and ``robustness`` like ``scripts/make_results.py``'s, rendered by
``scripts/readme_results.py`` into docs/results.md.
"""

from __future__ import annotations

import argparse
import functools
import json
import time
from pathlib import Path
from typing import Any

from make_results import RESULTS, commit, machine

from msd_bench.app import scoring
from msd_bench.app.config import RunConfig
from msd_bench.app.pipeline import (
    identify_surrogates,
    make_records,
    settings,
    train_and_validate,
    validate_policy,
)
from msd_bench.core.physics.model import plant_model
from msd_bench.designs.deeprl import DeepPolicy
from msd_bench.designs.protocol import Facts
from msd_bench.io.reports.report import robustness_json, table_json
from msd_bench.io.storage.deeprl_artifact import load_policy

POLICIES = RESULTS / "deeprl_policies"
SAVED = {"plant+dqn": ("plant_dqn", "plant-dqn"), "plant+ppo": ("plant_ppo", "plant-ppo"),
         "greybox+dqn": ("greybox_dqn", "dqn")}
"""Each saved deep-RL kind: its artifact stem and the design that made it."""
LEARNERS = ("plant", "plm+robust", "greybox+robust")
"""The Q-learners beside them, made here at the same seeds."""
PAPER_STEPS = 900_000


@functools.cache
def paper_budget_rows() -> dict[str, dict[str, Any]]:
    """``deeprl_table.json``'s row of each kind at the paper's budget (read once)."""
    rows = json.loads((RESULTS / "deeprl_table.json").read_text())["rows"]
    return {r["kind"]: r for r in rows if r["steps_per_seed"] == PAPER_STEPS}


def taken(kind: str) -> int:
    """The plant steps the saved run of ``kind`` really took (``deeprl_table.json``), 0 on a surrogate."""
    return int(paper_budget_rows()[kind]["real_taken"])


def saved_policy(kind: str) -> tuple[DeepPolicy, int | None, str]:
    """The network saved for ``kind`` as the deep-RL design's policy, its id seed and a note."""
    stem, design = SAVED[kind]
    net, meta = load_policy(POLICIES / stem)
    if meta["kind"] != kind or int(meta["steps"]) != PAPER_STEPS:
        raise SystemExit(f"deeprl_table1: error: {stem} holds {meta['kind']} at {meta['steps']} steps")
    real = taken(kind)
    seeds = tuple(int(s) for s in meta["seeds"])
    note = (f"{meta['algo'].upper()} (Stable-Baselines3 {meta['stable_baselines3']}) trained by "
            f"scripts/deeprl_runs.py at {PAPER_STEPS:,} environment steps per seed, learning seed(s) "
            f"{', '.join(map(str, seeds))}; loaded from docs/results/deeprl_policies/{stem}")
    if real and real != PAPER_STEPS * len(seeds):
        note += f"; the plant gave {real:,} steps (SB3 finished its last rollout past the budget)"
    policy = DeepPolicy(kind, seeds, Facts(design, True, False, real), net, meta)
    return policy, meta.get("id_seed"), note


def build(cfg: RunConfig) -> tuple[list[Any], dict[str, Any]]:
    """Every row and its robustness cells: the saved deep-RL kinds, then the learners."""
    id_seed = cfg.id_first_seed
    models, fits = identify_surrogates(make_records(cfg, id_seed), ["plm", "greybox"], id_seed, cfg.plant)
    val, s = scoring.Validation.of(cfg), settings(cfg)
    results, cells = [], {}
    for kind in SAVED:
        policy, made_on, note = saved_policy(kind)
        fit = None if made_on is None else fits[kind.split("+")[0]]
        record = validate_policy(policy, cfg, policy.members, id_seed).record(fit)
        row, kind_cells = scoring.assemble(kind, [record], s, val, notes=[note])
        results.append(row)
        cells[kind] = kind_cells
    for kind in LEARNERS:
        surrogate = plant_model(cfg.plant) if kind == "plant" else models[kind.split("+")[0]]
        fit = None if kind == "plant" else fits[kind.split("+")[0]]
        trained = train_and_validate(kind, surrogate, cfg, cfg.learning_seeds(0), id_seed)
        row, kind_cells = scoring.assemble(kind, [trained.record(fit)], s, val)
        results.append(row)
        cells[kind] = kind_cells
    return results, cells


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", type=Path, required=True, help="the JSON document to write (must not exist)")
    args = p.parse_args()
    if args.out.exists():
        p.error(f"{args.out} exists; not overwriting it")
    cfg = RunConfig(seeds=1)
    t0 = time.perf_counter()
    results, cells = build(cfg)
    seconds = round(time.perf_counter() - t0, 1)
    labels = {r.kind: r.label for r in results}
    run = {"mode": "in-process", "preset": cfg.preset, "id_seeds": [cfg.id_first_seed],
           "learning_seeds": cfg.learning_seeds(0), "validation_steps": cfg.validation_steps,
           "window": cfg.window, "seconds": seconds}
    table = table_json(results, run)
    for agent in table["agents"]:
        agent.pop("per_seed", None)
    rob = robustness_json(cells, labels)
    for agent in rob["agents"]:
        for cell in agent["cells"].values():
            for key in ("sse", "mae", "risks"):
                cell.pop(key, None)
    doc = {"name": "table1_deeprl", "command": "scripts/deeprl_table1.py", "commit": commit(),
           "machine": machine(), "seconds": seconds, "table1": table, "robustness": rob}
    tmp = args.out.with_name(args.out.name + ".tmp")
    tmp.write_text(json.dumps(doc, indent=1) + "\n")
    tmp.rename(args.out)
    print(args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
