"""Time identifying every model kind of one rig, earlier numerics beside the current, as JSON.

Usage: ``.venv/bin/python benchmarks/bench_identification_rig.py [--preset default | --rig N] [--seed 0]
[--repeats 3] [--out file.json]``

One thread (``OMP_NUM_THREADS=1`` before numpy loads, ``torch.set_num_threads(1)``),
imports excluded (torch's optimisers import ``torch._dynamo`` lazily on first
use: paid before any timing), median of ``--repeats`` runs per kind. One rig's
records are the paper plan of identification seed ``--seed`` on the preset's
plant, or with ``--rig N`` played through population rig ``N`` as ``msd-bench
rigs`` plays it (its friction, delay, lag and sensor: the records a rig's bags
would hold; a frictional rig is where the PLM used to take longest). ``new`` is the
product path (:func:`msd_bench.core.identification.model_kinds.fit_model` for every registered kind);
``old`` fits the same kinds with the earlier
numerics selected by their configs (the PLM's finite-difference Jacobian, the
NLARX's torch-autograd simulation stage; the other kinds did not change), so
both run on the same machine under the same load. ``per_rig_seconds`` is one
rig end to end on the new path: make its records, identify every kind, score
every kind on its validation records (median of the repeats).
``--out`` writes the JSON atomically to a new file (an existing one is refused
before any work).
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # before numpy and torch load their thread pools

import argparse
import json
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

import torch

from msd_bench.app.pipeline import records_from_plan
from msd_bench.app.plan import paper_plan
from msd_bench.core.errors import MsdBenchError
from msd_bench.core.identification.data import IOData
from msd_bench.core.identification.identify import PlmConfig, evaluate, identify_nlarx, identify_plm
from msd_bench.core.identification.model_kinds import MODEL_KINDS, FitRequest, fit_model
from msd_bench.core.identification.nlarx import NlarxConfig
from msd_bench.core.identification.records import Records
from msd_bench.core.physics import plant
from msd_bench.core.physics.model import StepModel
from msd_bench.core.rigs import population
from msd_bench.core.rigs.rig import Rig
from msd_bench.core.rigs.rig_play import play_plan, records_of
from msd_bench.io.storage.atomic import write_text_atomic

RIG_KINDS = ("plm", "nlarx-improved", "greybox", "greybox-rig")
"""The model kinds ``msd-bench rigs`` identifies per rig for issue 21's agents (their sum is reported)."""
TARGET_S = 5.0
"""Issue 21 item 5: every kind of one rig identified within this, one thread."""

Fitter = Callable[[FitRequest], StepModel]


def fail(message: str) -> NoReturn:
    """A usage mistake: one line on stderr, exit 2, no traceback."""
    print(f"bench_identification_rig: error: {message}", file=sys.stderr)
    raise SystemExit(2)


def refuse_existing(out: Path | None) -> None:
    """A one-line exit 2 before any work when ``--out`` exists or has no directory."""
    if out is None:
        return
    if out.exists() or out.is_symlink():
        fail(f"{out} exists; not overwriting it")
    if not out.parent.is_dir():
        fail(f"{out}: directory {out.parent} does not exist")


def old_fitters() -> dict[str, Fitter]:
    """The kinds whose numerics changed, fitted the earlier way (configs as the registry's)."""

    def plm(req: FitRequest) -> StepModel:
        cfg = PlmConfig(stroke=req.stroke, jacobian="finite-difference")
        return identify_plm(req.records.bias_train, cfg)

    def nlarx(form: str) -> Fitter:
        def fit(req: FitRequest) -> StepModel:
            cfg = NlarxConfig(form=form, seed=req.seed, numerics="torch")
            return identify_nlarx(req.records.broad_train, cfg, req.stroke)

        return fit

    return {"plm": plm, "nlarx-paper": nlarx("paper"), "nlarx-improved": nlarx("improved")}


def merged_bias(records: Records) -> IOData | None:
    """The five bias validation records as one (the PLM's own figure), None without them."""
    parts = list(records.bias_val.values())
    if not parts:
        return None
    out = parts[0]
    for r in parts[1:]:
        out = out.merge(r)
    return out


def scores(name: str, model: StepModel, records: Records) -> dict[str, float]:
    """Free-run fit on the broad validation record, and on the bias ones for a bias-trained kind."""
    out = {"sim_fit": evaluate(model, records.broad_val).sim_fit}
    bias = merged_bias(records)
    if MODEL_KINDS[name].records == "bias" and bias is not None:
        out["bias_sim_fit"] = evaluate(model, bias).sim_fit
    return out


def time_path(req: FitRequest, fitters: dict[str, Fitter], repeats: int) -> dict[str, Any]:
    """Median seconds and fits of every kind; the fits of the last repeat (a seed gives one model)."""
    kinds: dict[str, Any] = {}
    for name in MODEL_KINDS:
        seconds, model = [], None
        for _ in range(repeats):
            t = time.perf_counter()
            model = fitters[name](req) if name in fitters else fit_model(name, req)
            seconds.append(time.perf_counter() - t)
        assert model is not None
        kinds[name] = {"median_seconds": statistics.median(seconds), "seconds": seconds,
                       **scores(name, model, req.records)}
    total = sum(k["median_seconds"] for k in kinds.values())
    return {"kinds": kinds, "total_seconds": total}


def make_records(params: plant.PlantParams, seed: int, rig: int | None) -> Records:
    """The paper plan of ``seed`` on the plant, or played through population rig ``rig``."""
    if rig is None:
        return records_from_plan(params, paper_plan(seed))
    drawn = population.draw(rig)
    played = play_plan(Rig(drawn.params, drawn.imperfections, seed=rig), paper_plan(seed))
    return records_of(played, drawn.params.dt)


def per_rig(params: plant.PlantParams, seed: int, repeats: int, rig: int | None) -> dict[str, Any]:
    """One rig end to end on the new path: records, every kind identified and scored."""
    runs = []
    for _ in range(repeats):
        t = time.perf_counter()
        records = make_records(params, seed, rig)
        req = FitRequest(records, seed, params.L, params.F)
        for name in MODEL_KINDS:
            scores(name, fit_model(name, req), records)
        runs.append(time.perf_counter() - t)
    return {"per_rig_seconds": statistics.median(runs), "per_rig_runs": runs}


def provenance() -> dict[str, Any]:
    """Commit and machine, taken before the run (scripts/make_results.py's helpers)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
    from make_results import commit, machine

    return {"commit": commit(), "machine": machine()}


def warm_up() -> None:
    """Pay the imports torch defers to the first optimiser, outside every timing."""
    torch.optim.Adam([torch.zeros(1, requires_grad=True)])
    torch.optim.LBFGS([torch.zeros(1, requires_grad=True)])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="default", choices=sorted(plant.PRESETS))
    ap.add_argument("--rig", type=int,
                    help="play the records through this population rig (core/rigs/population.py)")
    ap.add_argument("--seed", type=int, default=0, help="identification seed of the rig's records")
    ap.add_argument("--repeats", type=int, default=3, help="runs per kind and path (the median is reported)")
    ap.add_argument("--out", type=Path, help="also write the JSON here (must not exist)")
    args = ap.parse_args()
    if args.repeats < 1:
        fail(f"--repeats must be >= 1, got {args.repeats}")
    refuse_existing(args.out)
    if args.rig is not None and not 0 <= args.rig <= population.MAX_SEED:
        fail(f"--rig must be a population seed in 0..{population.MAX_SEED}, got {args.rig}")
    load = os.getloadavg()
    wall = time.monotonic()
    prov = provenance()
    torch.set_num_threads(1)
    warm_up()
    params = plant.preset(args.preset) if args.rig is None else population.draw(args.rig).params
    records = make_records(params, args.seed, args.rig)
    req = FitRequest(records, args.seed, params.L, params.F)
    new = time_path(req, {}, args.repeats)
    old = time_path(req, old_fitters(), args.repeats)
    out: dict[str, Any] = {
        "command": "benchmarks/bench_identification_rig.py " + " ".join(sys.argv[1:]), **prov,
        "preset": args.preset if args.rig is None else None, "rig": args.rig, "seed": args.seed,
        "repeats": args.repeats,
        "threads": {"torch": torch.get_num_threads(), "OMP_NUM_THREADS": os.environ["OMP_NUM_THREADS"]},
        "cpus": os.cpu_count(), "load_at_start": {"1min": load[0], "5min": load[1], "15min": load[2]},
        "new": new, "old": old,
        "ratio_old_over_new": old["total_seconds"] / new["total_seconds"],
        "fit_change": {k: {f: new["kinds"][k][f] - old["kinds"][k][f] for f in new["kinds"][k]
                           if f.endswith("fit")} for k in MODEL_KINDS},
        "target_seconds": TARGET_S, "within_target": new["total_seconds"] <= TARGET_S,
        **per_rig(params, args.seed, args.repeats, args.rig),
        "load_at_end": {"1min": os.getloadavg()[0]},
        "rig_kinds": list(RIG_KINDS),
        "rig_kinds_seconds": sum(new["kinds"][k]["median_seconds"] for k in RIG_KINDS),
    }
    out["seconds"] = round(time.monotonic() - wall, 1)
    text = json.dumps(out, indent=2)
    print(text)
    if args.out is not None:
        try:
            write_text_atomic(args.out, text + "\n", exclusive=True)
        except MsdBenchError as e:
            fail(str(e))


if __name__ == "__main__":
    main()
