"""Which robust-agent runs fail, on design seeds only: the diagnosis behind round 5 (decisions.md §Robust).

Round 4's robust agent (no selection) is trained on the PLM of each design
identification seed (90, 91, 92; learning seeds 90,000 + i·64 …, as in
``robust_design.py``) and each final table is run greedily on the improved
NLARX standing in for the plant (nominal, 5 mm noise, one sample of delay) and
on the PLM it trained on. Printed per id seed, as JSON lines:

* ``own`` / ``stand_in``: successes of the final tables on the training PLM and
  on the stand-in, by condition;
* ``p_stand_in_given_own_success`` / ``..._failure``: how well the training
  surrogate tells a failing table;
* ``stand_in_per_snapshot``: stand-in successes of the snapshots every 10
  episodes over the second half (episodes 150 … 300);
* ``selected``: stand-in successes of the tables rehearsal selection keeps
  (``select_every`` = 10, :mod:`msd_bench.core.learning.selection`);
* with ``--episodes-600``: the stand-in successes of the same seeds trained
  for 600 episodes.

    python scripts/robust_diagnosis.py [--episodes-600]
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "scripts"))

from robust_design import DESIGN_FIRST_SEED, DESIGN_ID_SEEDS, stand_ins, successes  # noqa: E402

from msd_bench.app.agents import robust_config  # noqa: E402
from msd_bench.app.config import RunConfig  # noqa: E402
from msd_bench.core.learning.qconfig import QConfig  # noqa: E402
from msd_bench.core.learning.qtrain import train  # noqa: E402
from msd_bench.core.learning.selection import select_tables  # noqa: E402
from msd_bench.core.physics.model import StepModel  # noqa: E402

SEEDS = 64
CONDITIONS = ("nominal", "noise=0.005", "delay=1")


def diagnose(cfg: QConfig, plm: StepModel, nlarx: StepModel, seeds: list[int]) -> dict[str, object]:
    """One id seed's row (module docstring)."""
    res = train(plm, cfg, seeds)
    where = {e: i for i, e in enumerate(res.snapshot_episodes)}
    final = res.snapshots[:, where[cfg.episodes]]  # res.q is the selected table; the final one is this
    own = successes(cfg, final, plm, plm, seeds, "nominal")
    stand = {c: successes(cfg, final, nlarx, plm, seeds, c) for c in CONDITIONS}
    per_snapshot = {e: int(successes(cfg, res.snapshots[:, where[e]], nlarx, plm, seeds, "nominal").sum())
                    for e in sorted(cfg.selection_episodes())}
    kept = select_tables(plm, cfg, res.snapshots, res.snapshot_episodes)
    nominal = stand["nominal"]
    return {
        "own": int(own.sum()), "stand_in": {c: int(v.sum()) for c, v in stand.items()},
        "p_stand_in_given_own_success": round(float(nominal[own].mean()), 3) if own.any() else None,
        "p_stand_in_given_own_failure": round(float(nominal[~own].mean()), 3) if (~own).any() else None,
        "stand_in_per_snapshot": per_snapshot,
        "selected": int(successes(cfg, kept.q, nlarx, plm, seeds, "nominal").sum()),
    }


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--episodes-600", action="store_true", help="also train the same seeds for 600 episodes")
    args = p.parse_args()
    run = RunConfig()
    models = stand_ins(list(DESIGN_ID_SEEDS), run)
    # round 4's agent; snapshots every 10 episodes over the second half, for the per-snapshot counts
    cfg = replace(robust_config(), force=run.plant.F, select_every=10)
    for i, s in enumerate(DESIGN_ID_SEEDS):
        seeds = list(range(DESIGN_FIRST_SEED + i * SEEDS, DESIGN_FIRST_SEED + (i + 1) * SEEDS))
        row: dict[str, object] = {"id_seed": s, "n": SEEDS,
                                  **diagnose(cfg, models[s]["plm"], models[s]["nlarx-improved"], seeds)}
        if args.episodes_600:
            long = replace(cfg, episodes=600, select_every=0)
            q = train(models[s]["plm"], long, seeds).q
            row["stand_in_600_episodes"] = int(
                successes(long, q, models[s]["nlarx-improved"], models[s]["plm"], seeds, "nominal").sum())
        print(json.dumps(row), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
