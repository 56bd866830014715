"""Classical baselines on the design identification seeds: nominal successes and scenario cells.

For each identification seed (default 90, 91, 92: design seeds, never the
reported ones) the paper's records are made and the surrogates identified
exactly as ``msd-bench paper`` does (app.pipeline), or the pinned models are
used (``--pinned``). Each baseline kind (``glm+pid``, ``glm+pid-continuous``,
``greybox+lqr``, ``plm+mpc`` by default) is designed per set-point and
validated on the true plant under the scenario suite; a deterministic design
has one run per identification seed and condition, and one per noise draw
under sensor noise (``--draws`` draws per id seed). Prints per kind the
nominal successes at ±0.5, ±1, ±1.5 m and every scenario cell, and (``--json``)
writes them. Design options are passed as ``--opt kind key=value`` (e.g.
``--opt glm+pid crossover=3``).

    .venv/bin/python scripts/baselines_check.py [--id-seeds 90 91 92] [--pinned] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from msd_bench.app.config import RunConfig
from msd_bench.app.pipeline import identify_surrogates, make_records
from msd_bench.core.baselines import designs
from msd_bench.core.errors import ConfigError, MsdBenchError
from msd_bench.core.model import StepModel
from msd_bench.core.robustness import merge
from msd_bench.core.scenarios import parse, suite
from msd_bench.io.artifacts import load_model

KINDS = ("glm+pid", "glm+pid-continuous", "greybox+lqr", "plm+mpc")
SETPOINTS = (-1.5, -1.0, -0.5, 0.5, 1.0, 1.5)
PINNED = Path(__file__).resolve().parents[1] / "tests" / "data" / "pinned"


def models_for(id_seed: int, surrogates: Sequence[str], pinned: bool) -> dict[str, StepModel]:
    """The surrogates of one identification seed (or the pinned ones)."""
    if pinned:
        return {s: load_model(PINNED / f"{s}.json") for s in surrogates}
    cfg = RunConfig()
    models, _ = identify_surrogates(make_records(cfg, id_seed), list(surrogates), id_seed, cfg.plant)
    return models


def options(pairs: Sequence[Sequence[str]]) -> dict[str, dict[str, Any]]:
    """``--opt kind key=value`` items as per-kind keyword options (numbers, or tuples of ints for blocks)."""
    out: dict[str, dict[str, Any]] = {}
    for kind, item in pairs:
        key, _, raw = item.partition("=")
        try:
            value: Any = tuple(int(v) for v in raw.split("/")) if "/" in raw else float(raw)
        except ValueError:
            raise ConfigError(f"--opt {kind} {item!r}: need key=number or key=n1/n2/... (blocks)") from None
        out.setdefault(kind, {})[key] = value
    return out


def run(kinds: Sequence[str], id_seeds: Sequence[int], pinned: bool, draws: int,
        opts: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Per kind: nominal set-point cells and scenario cells pooled over identification seeds."""
    cfg = RunConfig()
    scenarios = suite(tuple(f"setpoint={s:g}" for s in SETPOINTS if s != 1.0))
    parsed = [designs.parse_kind(k) for k in kinds]
    parts: dict[str, list[dict[str, dict[str, Any]]]] = {k: [] for k in kinds}
    for id_seed in id_seeds:
        models = models_for(id_seed, sorted({s for s, _ in parsed}), pinned)
        noise_seeds = [id_seed * 1000 + i for i in range(draws)]
        for kind, (surrogate, name) in zip(kinds, parsed, strict=True):
            cells = designs.evaluate(name, models[surrogate], cfg.plant, noise_seeds, scenarios,
                                     cfg.validation_steps, **opts.get(kind, {}))
            parts[kind].append(cells)
            print(f"id seed {id_seed} {kind}: nominal set-points "
                  + " ".join(f"{s:+g}:{_sid(s)}={cells[_sid(s)]['median_sse']:.2f}%" for s in SETPOINTS),
                  file=sys.stderr, flush=True)
    return {k: merge(p) for k, p in parts.items()}


def _sid(setpoint: float) -> str:
    return "nominal" if setpoint == 1.0 else parse(f"setpoint={setpoint:g}").id


def report(result: dict[str, dict[str, Any]]) -> None:
    """Per kind: nominal successes over the six set-points, then every scenario cell."""
    for kind, cells in result.items():
        nominal = [cells[_sid(s)] for s in SETPOINTS]
        wins, n = sum(c["n_success"] for c in nominal), sum(c["n"] for c in nominal)
        print(f"\n{kind}: nominal set-points ±0.5, ±1, ±1.5 m: {wins}/{n} successes")
        for sid, c in cells.items():
            print(f"  {sid:38s} {c['n_success']:3d}/{c['n']:<3d} median SSE {c['median_sse']:7.2f} %  "
                  f"median MAE {c['median_mae']:.3f} m")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kinds", nargs="+", default=list(KINDS))
    ap.add_argument("--id-seeds", nargs="+", type=int, default=[90, 91, 92])
    ap.add_argument("--pinned", action="store_true", help="use tests/data/pinned instead of identifying")
    ap.add_argument("--draws", type=int, default=4, help="sensor-noise draws per id seed and noisy scenario")
    ap.add_argument("--opt", nargs=2, action="append", default=[], metavar=("KIND", "KEY=VALUE"))
    ap.add_argument("--json", type=Path, help="also write the cells here (must not exist)")
    args = ap.parse_args()
    try:
        if args.json is not None and args.json.exists():
            raise MsdBenchError(f"{args.json} exists; not overwriting it")
        result = run(args.kinds, args.id_seeds, args.pinned, args.draws, options(args.opt))
    except MsdBenchError as e:
        print(f"baselines_check: {e}", file=sys.stderr)
        return 2
    report(result)
    if args.json is not None:
        with args.json.open("x") as f:
            json.dump(result, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
