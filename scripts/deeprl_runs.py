"""Deep-RL runs (DQN, PPO through MsdBench-v0): the design-seed grid, then held-out runs.

``tune``: every grid entry of each algorithm (:func:`msd_bench.core.deeprl.hyper.grid`)
trained on the plant on the design seeds at a reduced budget and scored on the
standard suite's five set-point cells; the entry holding the most set-points
(then the lowest summed median MAE) is ``chosen``. Design-seed numbers choose,
they are never results.

``validate``: a saved policy artifact (``--artifacts``) re-validated on the
plant without SB3 or torch; its cells equal the ones its run wrote.

``run``: each kind ``<surrogate>+<algo>`` (``plant+dqn``: model-free, every step
a real sample; ``greybox+ppo``: model-based on the surrogate identified with
``--id-seed``, zero real samples) trained on the held-out ``--seeds`` for
``--steps`` environment steps with the hyper-parameters ``chosen`` in
``--hyper-from`` (SB3's defaults without it), then validated greedily on the
true plant under the standard scenario suite, exactly as the Q-learners are.

``table``: the run documents (``--runs``) collected into one: a row per kind and
budget in Table 1's columns (fit, identification samples, real plant steps in
training, nominal success with n, SSE median), labelled as baselines, and the
on-plant kinds as points of the data-efficiency curve (real samples per agent vs
success); ``--figure`` also draws them over ``--efficiency``'s curves. A row whose
run predates the fit columns gets them from the same identification, recomputed.

Every sub-command refuses an existing ``--out`` before any work and write it atomically;
``--artifacts DIR`` also saves each kind's policy artifact there (new files only).
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import sys
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "scripts"))

from make_results import commit, machine  # noqa: E402

from msd_bench.core.deeprl import mlp  # noqa: E402
from msd_bench.core.deeprl.hyper import ALGOS, DEFAULTS, DESIGN_SEEDS, PAPER_STEPS, Hyper, from_dict, grid  # noqa: E402
from msd_bench.core.deeprl.validate import SETPOINT_IDS, setpoints_held  # noqa: E402
from msd_bench.core.errors import ConfigError, MsdBenchError  # noqa: E402
from msd_bench.core.evaluation.scenarios import parse, suite  # noqa: E402
from msd_bench.core.physics.model import StepModel, plant_model  # noqa: E402
from msd_bench.designs import AgentKind, agent_kind  # noqa: E402
from msd_bench.designs.deeprl import nets_policy  # noqa: E402
from msd_bench.designs.kinds import made_on_plant  # noqa: E402


def parse_kind(kind: str) -> AgentKind:
    """The registered deep-RL kind ``<surrogate>+<algo>``; anything else is one line."""
    try:
        k = agent_kind(kind)
    except ConfigError:
        k = None
    if k is None or algo_of(k) not in ALGOS:
        raise ConfigError(f"deep-RL kind {kind!r} must be <plant|model>+<{'|'.join(ALGOS)}>, "
                          "a registered model kind or plant")
    return k


def algo_of(k: AgentKind) -> str:
    """The SB3 algorithm of a deep-RL kind (``plant+dqn`` is made by design ``plant-dqn``, algorithm dqn)."""
    return str(getattr(k.design, "algo", k.agent))


def environment(k: AgentKind | None, id_seed: int) -> StepModel:
    """The plant (``k`` None or on the plant), or ``k``'s surrogate identified as ``msd-bench paper``
    identifies it for ``id_seed``."""
    return identified(k, id_seed)[0]


def identified(k: AgentKind | None, id_seed: int) -> tuple[StepModel, dict[str, Any]]:
    """:func:`environment` and its identification columns (Table 1's fit and samples; none on the plant).

    Why here: a results view places a surrogate-trained row beside the learners' in Table 1's
    columns, so the document must carry the fit of the model it trained on, not borrow another run's.
    """
    from msd_bench.app.config import RunConfig
    from msd_bench.app.pipeline import identify_surrogates, make_records

    cfg = RunConfig()
    if k is None or made_on_plant(k.kind):
        return plant_model(cfg.plant), {"identification_samples": 0, "fit_sim_percent": None,
                                         "fit_one_step_percent": None}
    models, fits = identify_surrogates(make_records(cfg, id_seed), [k.surrogate], id_seed, cfg.plant)
    fit = fits[k.surrogate]
    return models[k.surrogate], {"identification_samples": int(fit.n_identification),
                                 "fit_sim_percent": fit.sim_fit, "fit_one_step_percent": fit.one_step_fit}


def train_seeds(model: StepModel, hyper: Hyper, seeds: list[int],
                steps: int) -> tuple[mlp.Net, dict[str, Any]]:
    """Every seed trained on ``model``; the stacked networks and the timing."""
    from msd_bench.designs.deeprl_train import train

    nets, took, taken, versions = [], [], [], {}
    for s in seeds:
        t0 = time.perf_counter()
        res = train(model, hyper, s, steps)
        took.append(time.perf_counter() - t0)
        nets.append(res.net)
        taken.append(res.steps)
        versions = {"stable_baselines3": res.sb3_version, "torch": res.torch_version}
        print(f"  seed {s}: {steps} steps in {took[-1]:.0f} s ({steps / took[-1]:.0f} steps/s)", flush=True)
    return mlp.stack(nets), {"steps_taken": taken, "train_seconds": [round(t, 1) for t in took],
                             "steps_per_second": [round(steps / t, 1) for t in took], **versions}


def tune(args: argparse.Namespace) -> dict[str, Any]:
    """Score each grid entry on the design seeds (plant, reduced budget)."""
    plant = environment(None, 0)
    sps = [parse(s) for s in SETPOINT_IDS]
    out: dict[str, Any] = {"design_seeds": args.seeds, "steps": args.steps, "environment": "plant",
                           "scored_on": list(SETPOINT_IDS),
                           "rule": "most set-point cells held by every design seed, then the lowest summed "
                                   "median MAE", "note": "design-seed scores: they choose, never report",
                           "algos": {}}
    for algo in args.algos:
        rows = []
        for h in grid(algo):
            print(f"{algo} {h.as_dict()}", flush=True)
            net, timing = train_seeds(plant, h, args.seeds, args.steps)
            cells = scored(nets_policy(f"plant+{algo}", net, args.seeds), args.seeds, sps)
            mae = sum(c["median_mae"] for c in cells.values())
            rows.append({"hyper": h.as_dict(), "held": setpoints_held(cells), "sum_median_mae": round(mae, 4),
                         "cells": {k: _short(c) for k, c in cells.items()}, **timing})
            print(f"  held {rows[-1]['held']}/5, summed median MAE {mae:.3f} m", flush=True)
        best = max(rows, key=lambda r: (r["held"], -r["sum_median_mae"]))
        out["algos"][algo] = {"chosen": best["hyper"], "grid": rows}
    return out


def scored(policy: Any, seeds: list[int], scenarios: Any) -> dict[str, dict[str, Any]]:
    """The policy's cells on the plant under ``scenarios`` (the run's validation length and SSE window),
    by the one evaluator through app/scoring, as every kind's robustness cells are made."""
    from msd_bench.app.config import RunConfig
    from msd_bench.app.scoring import Validation, record_cells

    cfg = RunConfig()
    val = Validation(cfg.plant, list(scenarios), cfg.validation_steps, cfg.window)
    return record_cells(policy, seeds, val)


def plant_params() -> Any:
    from msd_bench.app.config import RunConfig

    return RunConfig().plant


def chosen(path: Path | None, algo: str) -> Hyper:
    """The tuned entry for ``algo`` from a ``tune`` document, or SB3's defaults without one."""
    if path is None:
        return DEFAULTS[algo]
    from msd_bench.io.storage.safe_read import read_json_bounded

    doc = read_json_bounded(path, MsdBenchError)
    try:
        return from_dict(doc["algos"][algo]["chosen"])
    except (KeyError, TypeError):
        raise ConfigError(f"{path}: no chosen hyper-parameters for {algo}") from None


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Train and validate every kind on the held-out seeds."""
    kinds: dict[str, Any] = {}
    for kind in args.kinds:
        k = parse_kind(kind)
        algo = algo_of(k)
        hyper = chosen(args.hyper_from, algo)
        print(f"{kind}: {hyper.as_dict()}", flush=True)
        model, ident = identified(k, args.id_seed)
        net, timing = train_seeds(model, hyper, args.seeds, args.steps)
        cells = scored(nets_policy(kind, net, args.seeds), args.seeds, suite())
        real = args.steps * len(args.seeds) if made_on_plant(kind) else 0
        kinds[kind] = {"surrogate": k.surrogate, "algo": algo, "hyper": hyper.as_dict(),
                       "id_seed": None if made_on_plant(kind) else args.id_seed,
                       **ident, "real_interactions": real, "setpoints_held": setpoints_held(cells),
                       "nominal": cells["nominal"], "cells": {k: _short(c) for k, c in cells.items()},
                       **timing}
        print(f"  {kind}: held {setpoints_held(cells)}/5 set-points; nominal "
              f"{cells['nominal']['n_success']}/{cells['nominal']['n']}", flush=True)
        if args.artifacts is not None:
            from msd_bench.io.storage.deeprl_artifact import save_policy

            save_policy(args.artifacts / kind.replace("+", "_"), net,
                        {"kind": kind, "algo": algo, "hyper": hyper.as_dict(), "seeds": args.seeds,
                         "steps": args.steps, "id_seed": kinds[kind]["id_seed"], **timing})
    return {"seeds": args.seeds, "steps": args.steps, "kinds": kinds}


def _run_doc(path: Path) -> dict[str, Any]:
    """A ``run`` document, checked for the fields the table reads (one line naming what is wrong)."""
    from msd_bench.io.storage.safe_read import read_json_bounded

    doc = read_json_bounded(path, MsdBenchError)
    if not isinstance(doc, dict) or not isinstance(doc.get("kinds"), dict) or not doc["kinds"]:
        raise MsdBenchError(f"{path}: not a deeprl_runs.py run document (no kinds)")
    seeds, steps = doc.get("seeds"), doc.get("steps")
    if not (isinstance(seeds, list) and seeds and all(type(v) is int for v in seeds)
            and type(steps) is int and steps > 0):
        raise MsdBenchError(f"{path}: a run document needs integer seeds and a positive steps")
    for kind, row in doc["kinds"].items():
        parse_kind(kind)
        nom = row.get("nominal") if isinstance(row, dict) else None
        if not (isinstance(nom, dict) and all(type(nom.get(f)) is int for f in ("n", "n_success"))
                and isinstance(nom.get("median_sse"), int | float) and 0 <= nom["n_success"] <= nom["n"]
                and nom["n"] > 0 and type(row.get("real_interactions")) is int):
            raise MsdBenchError(f"{path}: kind {kind!r} lacks its nominal cell or real_interactions")
    return doc


def _ident(kind: str, row: dict[str, Any], cache: dict[tuple[str, int], dict[str, Any]]) -> dict[str, Any]:
    """The row's identification columns: its own, or (a run older than them) recomputed identically."""
    k = parse_kind(kind)
    if "identification_samples" in row:
        return {f: row.get(f) for f in ("identification_samples", "fit_sim_percent")} | {"fit_from": "run"}
    if made_on_plant(kind):
        return {"identification_samples": 0, "fit_sim_percent": None, "fit_from": "run"}
    key = (k.surrogate, int(row.get("id_seed") or 0))
    if key not in cache:
        cache[key] = identified(k, key[1])[1]
    got = cache[key]
    return {"identification_samples": got["identification_samples"],
            "fit_sim_percent": got["fit_sim_percent"], "fit_from": "recomputed"}


def steps_taken(row: dict[str, Any], steps: int, n_seeds: int) -> int:
    """The environment steps a run really took over all seeds: its record, or for a run from before the
    budget cap (``train.Budget``) the whole rollouts SB3 finished past ``steps`` (PPO ``n_steps``, 2,048
    by default; DQN ``train_freq``, 4)."""
    if isinstance(row.get("steps_taken"), list):
        return sum(int(v) for v in row["steps_taken"])
    hyper: dict[str, Any] = row["hyper"] if isinstance(row.get("hyper"), dict) else {}
    extra: dict[str, Any] = hyper["extra"] if isinstance(hyper.get("extra"), dict) else {}
    chunk = extra.get("n_steps", 2048) if hyper.get("algo") == "ppo" else extra.get("train_freq", 4)
    chunk = chunk if type(chunk) is int and chunk > 0 else 1
    return -(-steps // chunk) * chunk * n_seeds


def table_rows(paths: list[Path]) -> list[dict[str, Any]]:
    """One row per (run document, kind), in Table 1's columns, budget and seeds stated."""
    from msd_bench.core.evaluation.stats import wilson

    rows: list[dict[str, Any]] = []
    cache: dict[tuple[str, int], dict[str, Any]] = {}
    for path in paths:
        doc = _run_doc(path)
        for kind, row in doc["kinds"].items():
            nom = row["nominal"]
            rows.append({"file": path.name, "kind": kind, "label": parse_kind(kind).label, "baseline": True,
                         "steps_per_seed": doc["steps"], "seeds": doc["seeds"], "id_seed": row.get("id_seed"),
                         **_ident(kind, row, cache), "real_interactions": row["real_interactions"],
                         "real_taken": (steps_taken(row, doc["steps"], len(doc["seeds"]))
                                        if row["real_interactions"] else 0),
                         "n": nom["n"], "n_success": nom["n_success"],
                         "ci95": list(wilson(nom["n_success"], nom["n"])), "median_sse": nom["median_sse"],
                         "setpoints_held": row.get("setpoints_held")})
    return rows


def efficiency_methods(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The on-plant kinds as methods of the efficiency curve: real samples per agent vs success."""
    from msd_bench.core.evaluation.stats import wilson

    methods: dict[str, dict[str, Any]] = {}
    for r in sorted(rows, key=lambda r: r["steps_per_seed"]):
        if r["real_interactions"] == 0:
            continue
        seeds = ",".join(str(s) for s in r["seeds"])
        m = methods.setdefault(r["kind"], {"name": r["kind"], "label": f"{r['label']}, seed(s) {seeds}",
                                           "seeds": r["seeds"], "points": []})
        m["points"].append({"real_samples": r["real_taken"] // len(r["seeds"]), "n": r["n"],
                            "n_success": r["n_success"], "ci95": list(wilson(r["n_success"], r["n"])),
                            "file": r["file"]})
    return list(methods.values())


def table(args: argparse.Namespace) -> dict[str, Any]:
    """The run documents as one table (and the efficiency figure with the deep-RL points on it)."""
    rows = table_rows(args.runs)
    methods = efficiency_methods(rows)
    out: dict[str, Any] = {"rows": rows, "efficiency_methods": methods}
    if args.figure is not None:
        from msd_bench.io.reports.figures import efficiency_figure
        from msd_bench.io.storage.safe_read import read_json_bounded

        curve = read_json_bounded(args.efficiency, MsdBenchError)
        if isinstance(curve, dict) and isinstance(curve.get("efficiency"), dict):
            curve = curve["efficiency"]  # docs/results/ wraps the command's document with its provenance
        if not isinstance(curve, dict) or not isinstance(curve.get("methods"), list):
            raise MsdBenchError(f"{args.efficiency}: not an efficiency.json (no methods)")
        efficiency_figure(args.figure, [*curve["methods"], *methods], root=args.figure.parent)
        out["figure"] = {"path": str(args.figure), "curves_from": str(args.efficiency)}
    return out


def validate(args: argparse.Namespace) -> dict[str, Any]:
    """Re-validate a saved policy artifact (no SB3, no torch): the same cells its run wrote."""
    from msd_bench.io.storage.deeprl_artifact import load_policy

    net, meta = load_policy(args.policy)
    seeds = meta.get("seeds")
    if not isinstance(seeds, list) or len(seeds) != net.w1.shape[0] or not all(
            isinstance(s, int) and not isinstance(s, bool) for s in seeds):
        raise MsdBenchError(f"{args.policy}: meta must list one integer learning seed per policy")
    kind = meta.get("kind")
    if not isinstance(kind, str):
        raise MsdBenchError(f"{args.policy}: meta must name the policy's kind")
    cells = scored(nets_policy(kind, net, seeds), seeds, suite())
    return {"policy": str(args.policy), "kind": kind, "seeds": seeds,
            "setpoints_held": setpoints_held(cells), "cells": {k: _short(c) for k, c in cells.items()}}


def _short(c: dict[str, Any]) -> dict[str, Any]:
    return {k: c[k] for k in ("n", "n_success", "ci95", "median_sse", "median_mae", "sse")}


def _ints(text: str) -> list[int]:
    try:
        vals = [int(t) for t in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"need comma-separated integers, got {text!r}") from None
    return vals


def _paths(text: str) -> list[Path]:
    return [Path(t) for t in text.split(",") if t.strip()]


def _steps(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise argparse.ArgumentTypeError(f"--steps must be a positive integer, got {text!r}")
    return n


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("tune", help="the design-seed grid at a reduced budget")
    t.add_argument("--algos", type=lambda s: s.split(","), default=list(ALGOS))
    t.add_argument("--seeds", type=_ints, default=list(DESIGN_SEEDS))
    t.add_argument("--steps", type=_steps, default=90_000)
    r = sub.add_parser("run", help="held-out runs of deep-RL kinds")
    r.add_argument("--kinds", type=lambda s: s.split(","), required=True)
    r.add_argument("--seeds", type=_ints, default=[0])
    r.add_argument("--steps", type=_steps, default=PAPER_STEPS)
    r.add_argument("--id-seed", type=int, default=0, help="identification seed of a surrogate kind")
    r.add_argument("--hyper-from", type=Path, help="a tune document; its chosen entry per algorithm")
    r.add_argument("--artifacts", type=Path, help="also save each kind's policy artifact in this directory")
    v = sub.add_parser("validate", help="re-validate a saved policy artifact on the plant (no SB3)")
    v.add_argument("--policy", type=Path, required=True, help="the artifact's stem (<stem>.json, <stem>.npz)")
    b = sub.add_parser("table", help="collect run documents into one table (and the efficiency figure)")
    b.add_argument("--runs", type=_paths, required=True, help="comma-separated run documents")
    b.add_argument("--efficiency", type=Path, default=REPO / "docs" / "results" / "efficiency.json",
                   help="the curves the figure draws the deep-RL points over")
    b.add_argument("--figure", type=Path, help="also draw the efficiency curves with the deep-RL points")
    for p in (t, r, v, b):
        p.add_argument("--out", type=Path, required=True, help="the result JSON (must not exist)")
    return ap


def check(args: argparse.Namespace) -> None:
    """Every usage mistake before any work: an existing --out, a missing directory, a bad kind."""
    if args.out.exists() or args.out.is_symlink():
        raise MsdBenchError(f"{args.out} exists; not overwriting it")
    if not args.out.parent.is_dir():
        raise MsdBenchError(f"{args.out}: directory {args.out.parent} does not exist")
    if args.cmd == "validate":
        return
    if args.cmd == "table":
        _check_table(args)
        return
    if args.cmd == "tune":
        for a in args.algos:
            if a not in ALGOS:
                raise ConfigError(f"unknown algorithm {a!r}; known: {', '.join(ALGOS)}")
        if set(args.seeds) - set(DESIGN_SEEDS):
            raise ConfigError(f"tune runs on design seeds only ({DESIGN_SEEDS}), got {args.seeds}")
    else:
        for k in args.kinds:
            parse_kind(k)
            if args.hyper_from is not None:
                chosen(args.hyper_from, algo_of(parse_kind(k)))
        if set(args.seeds) & set(DESIGN_SEEDS):
            used = sorted(set(args.seeds) & set(DESIGN_SEEDS))
            raise ConfigError(f"run reports held-out seeds only; {used} are design seeds")
        if args.artifacts is not None and not args.artifacts.is_dir():
            raise MsdBenchError(f"--artifacts {args.artifacts} is not a directory")


def _check_table(args: argparse.Namespace) -> None:
    """``table``'s inputs exist and its figure would write nothing over a file it did not write."""
    if not args.runs:
        raise MsdBenchError("--runs names no run document")
    for p in args.runs:
        if not p.is_file():
            raise MsdBenchError(f"--runs: {p} is not a file")
    if args.figure is not None:
        if args.figure.exists() or args.figure.is_symlink():
            raise MsdBenchError(f"{args.figure} exists; not overwriting it")
        if not args.figure.parent.is_dir():
            raise MsdBenchError(f"--figure: directory {args.figure.parent} does not exist")
        if not args.efficiency.is_file():
            raise MsdBenchError(f"--efficiency: {args.efficiency} is not a file")


def main() -> int:
    args = parser().parse_args()
    try:
        check(args)
        prov = {"command": "scripts/deeprl_runs.py " + shlex.join(sys.argv[1:]), "commit": commit(),
                "machine": machine(), "load_at_start": os.getloadavg()[0]}
        t0 = time.perf_counter()
        doc = {**prov, **{"tune": tune, "run": run, "validate": validate, "table": table}[args.cmd](args)}
        doc["seconds"] = round(time.perf_counter() - t0, 1)
        from msd_bench.io.storage.artifacts import jsonable
        from msd_bench.io.storage.atomic import write_text_atomic

        write_text_atomic(args.out, json.dumps(jsonable(doc), indent=1) + "\n", exclusive=True,
                          error=MsdBenchError)
    except MsdBenchError as e:
        print(f"deeprl_runs: {e}", file=sys.stderr)
        return 2
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
