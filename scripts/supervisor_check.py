"""The adversarial controllers with and without the supervisor: hard-stop contacts and envelope exits.

Each adversary of ``core/safety/adversaries.py`` runs one 30 s episode from rest on
the ideal plant (the random one over ``--seeds`` seeds) and on the rig emulator
(the rig preset's plant under each imperfection set of ``RIGS``; the random
one over the first ``--rig-seeds`` seeds), once behind the supervisor and once
without. The supervisor is always told the nominal plant, never the rig's.
Prints one line per cell; ``--out`` writes one provenance-stamped JSON document
(must not exist). ``--options FILE`` reads the supervisor's options (a JSON
object of ``SupervisorOptions`` fields); the limits in force are printed first.

    .venv/bin/python scripts/supervisor_check.py [--options FILE] [--out docs/results/supervisor_check.json]

Two more measurements of issue 23's done-when, each its own document:

``population`` runs the deterministic adversaries on ``--rigs`` held-out rigs of
the population (``core/rigs/population.py``, seeds from 1000) and the random one over
``--random-seeds`` seeds spread over the same rigs, with and without the
supervisor (told the nominal plant only), and lists any rig it failed on.

``good-kinds`` trains and designs the good kinds (the robust agent, the glm+pid
and greybox+lqr baselines) as the in-process run does, validates each policy on
Table 1's nominal run and the robustness suite twice, same seeds, supervisor off
and on, and counts per kind the runs the supervisor lost (paired) and the good
nominal runs it never overrode.

    .venv/bin/python scripts/supervisor_check.py population --out docs/results/supervisor_population.json
    .venv/bin/python scripts/supervisor_check.py good-kinds --out docs/results/supervisor_good_kinds.json
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from supervisor_good_kinds import GOOD_KINDS, good_kinds_check

from msd_bench.app.agents import parse_agents
from msd_bench.core.errors import MsdBenchError
from msd_bench.core.evaluation.risk import RunRisk, run_risk
from msd_bench.core.physics.plant import PRESETS, PlantParams
from msd_bench.core.rigs import population
from msd_bench.core.rigs.population import RigSpec
from msd_bench.core.rigs.rig import RigImperfections
from msd_bench.core.safety.adversaries import ADVERSARIES, Runs, adversary, run_on_plant, run_on_rig
from msd_bench.core.safety.supervisor import Limits, SupervisorOptions
from msd_bench.io.storage.supervisor_file import read_options

REPO = Path(__file__).resolve().parents[1]
STEPS = 3000
RIGS = {
    "defaults": RigImperfections(),
    "ideal": RigImperfections.none(),
    "laggy": RigImperfections(delay_samples=2, actuator_tau=0.05, friction=0.0),
    "noisy": RigImperfections(sensor_noise=0.005, sensor_quant=0.001, friction=0.5),
}


def cell(risks: list[RunRisk]) -> dict[str, Any]:
    """The totals of a list of runs (one cell of the document)."""
    return {"runs": len(risks), "contacts": sum(r.contacts for r in risks),
            "runs_with_contact": sum(r.contacts > 0 for r in risks),
            "time_at_stop": round(sum(r.time_at_stop for r in risks), 2),
            "exits_beyond_margin": sum(r.exits_beyond_margin for r in risks),
            "peak_x": round(max(r.peak_x for r in risks), 4),
            "peak_v": round(max(r.peak_v for r in risks), 3),
            "time_outside": round(sum(r.time_outside for r in risks), 2),
            "override_share": round(float(np.mean([r.override_share for r in risks])), 4),
            "aborts": {a: sum(r.aborted == a for r in risks) for a in sorted({str(r.aborted) for r in risks
                                                                              if r.aborted})}}


def _risks(runs: Runs, plant: PlantParams, lim: Limits) -> list[RunRisk]:
    return [run_risk(runs.x[j], runs.v[j], dt=plant.dt, half_stroke=plant.x_max, envelope=lim.envelope,
                     margin=lim.margin, reasons=runs.reason[j], abort=int(runs.aborts[j]))
            for j in range(runs.x.shape[0])]


def on_plant(opts: SupervisorOptions, name: str, seeds: list[int]) -> dict[str, Any]:
    plant = PRESETS["default"]
    lim = opts.limits(plant)
    adv = adversary(name, plant, STEPS, seeds)
    noise = np.zeros((len(seeds) if name == "random" else 1, STEPS))
    return {side: cell(_risks(run_on_plant(plant, lim, adv, noise, supervised=side == "supervised"),
                              plant, lim)) for side in ("unsupervised", "supervised")}


def on_rig(opts: SupervisorOptions, name: str, rig: str, seeds: list[int]) -> dict[str, Any]:
    plant, nominal = PRESETS["rig"], PRESETS["default"]
    lim = opts.limits(nominal)
    adv = adversary(name, plant, STEPS, seeds)
    runs = seeds if name == "random" else seeds[:1]
    out = {}
    for side in ("unsupervised", "supervised"):
        risks = []
        for j, seed in enumerate(runs):
            sup = opts.limits(nominal) if side == "supervised" else None
            risks += _risks(run_on_rig(plant, RIGS[rig], sup, adv, STEPS, seed=seed, run=j), plant, lim)
        out[side] = cell(risks)
    return out


def on_population(opts: SupervisorOptions, name: str, specs: list[RigSpec],
                  seeds: list[int]) -> dict[str, Any]:
    """One adversary on each rig of ``specs`` (the random one: seed j on rig j mod n), both sides;
    the supervisor is told the nominal plant, never the rig's."""
    nominal = PRESETS["default"]
    lim = opts.limits(nominal)
    runs = ([(j, specs[j % len(specs)]) for j in range(len(seeds))] if name == "random"
            else list(enumerate(specs)))
    out: dict[str, Any] = {}
    for side in ("unsupervised", "supervised"):
        risks, failed = [], []
        for j, spec in runs:
            adv = adversary(name, spec.params, STEPS, seeds)
            sup = opts.limits(nominal) if side == "supervised" else None
            got = _risks(run_on_rig(spec.params, spec.imperfections, sup, adv, STEPS, seed=spec.seed, run=j),
                         spec.params, lim)
            risks += got
            if any(r.contacts or r.exits_beyond_margin for r in got):
                failed.append(spec.seed)
        out[side] = {**cell(risks), "rigs_with_contact_or_exit": sorted(set(failed))}
    return out


def population_check(args: argparse.Namespace, opts: SupervisorOptions, start: float) -> dict[str, Any]:
    """``population``: the deterministic adversaries on ``--rigs`` held-out rigs, the random one over
    ``--random-seeds`` seeds on them."""
    prov = provenance() if args.out is not None else {}
    first = args.first_rig
    specs = [population.draw(first + i) for i in range(args.rigs)]
    cells: dict[str, Any] = {}
    for name in ADVERSARIES:
        seeds = list(range(args.random_seeds)) if name == "random" else [0]
        cells[name] = on_population(opts, name, specs, seeds)
        print(line(f"{args.rigs} rigs", name, cells[name]))
    return {**prov, "seconds": round(time.monotonic() - start, 1), "steps": STEPS,
            "limits": opts.limits(PRESETS["default"])._asdict(), "options": dict(vars(opts)),
            "rig_seeds": [s.seed for s in specs], "random_seeds": args.random_seeds,
            "population": {"module": population.__name__, "first_rig": first,
                           "held_out": first in population.HELD_OUT_RIGS,
                           "mass_range": [min(s.params.m for s in specs), max(s.params.m for s in specs)]},
            "adversaries": cells}


def provenance() -> dict[str, Any]:
    """Command, commit and machine, taken before the run (the commit is the code that ran)."""
    sys.path.insert(0, str(REPO / "scripts"))
    from make_results import commit, machine

    return {"command": "scripts/supervisor_check.py " + shlex.join(sys.argv[1:]), "commit": commit(),
            "machine": machine()}


def line(where: str, name: str, c: dict[str, Any]) -> str:
    u, s = c["unsupervised"], c["supervised"]
    return (f"{where:14s} {name:13s} runs {u['runs']:3d}  without: {u['contacts']:4d} contacts "
            f"peak {u['peak_x']:.3f} m   with: {s['contacts']} contacts, {s['exits_beyond_margin']} exits, "
            f"peak {s['peak_x']:.3f} m, overrides {100 * s['override_share']:.1f} %")


def _write(out: Path | None, doc: dict[str, Any]) -> int:
    """Write ``doc`` to ``out`` (created, never overwritten); 0, or 2 with one line."""
    if out is None:
        return 0
    try:
        with out.open("x") as f:
            json.dump(doc, f, indent=1)
            f.write("\n")
    except OSError as e:
        print(f"supervisor_check: error: cannot write {e.filename}: {e.strerror}", file=sys.stderr)
        return 2
    return 0


def _options(args: argparse.Namespace) -> SupervisorOptions:
    """The checked output path and the supervisor's options (one-line MsdBenchError otherwise)."""
    if args.out is not None and args.out.exists():
        raise MsdBenchError(f"{args.out} exists; not overwriting it")
    if args.out is not None and not args.out.parent.is_dir():
        raise MsdBenchError(f"{args.out}: directory {args.out.parent} does not exist")
    for name in ("seeds", "rig_seeds", "rigs", "random_seeds", "id_seeds"):
        if getattr(args, name, 1) < 1:
            raise MsdBenchError(f"--{name.replace('_', '-')} must be >= 1")
    opts = SupervisorOptions() if args.options is None else read_options(args.options)
    opts.limits(PRESETS["default"])
    return opts


def check(args: argparse.Namespace, opts: SupervisorOptions, start: float) -> dict[str, Any]:
    """The adversaries on the plant and on the rig emulator (the original document)."""
    lim = opts.limits(PRESETS["default"])
    prov = provenance() if args.out is not None else {}
    plant = {name: on_plant(opts, name, list(range(args.seeds))) for name in ADVERSARIES}
    for name, c in plant.items():
        print(line("plant", name, c))
    rigs: dict[str, dict[str, Any]] = {}
    for rig in RIGS:
        rigs[rig] = {name: on_rig(opts, name, rig, list(range(args.rig_seeds))) for name in ADVERSARIES}
        for name, c in rigs[rig].items():
            print(line(f"rig:{rig}", name, c))
    return {**prov, "seconds": round(time.monotonic() - start, 1), "steps": STEPS,
            "limits": lim._asdict(), "options": {k: v for k, v in vars(opts).items()},
            "rigs": {k: vars(v) for k, v in RIGS.items()}, "plant": plant, "rig": rigs}


def _parser() -> argparse.ArgumentParser:
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--options", type=Path, help="supervisor options, a JSON object")
    common.add_argument("--out", type=Path,
                        help="write the provenance-stamped document here (must not exist)")
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], parents=[common])
    ap.add_argument("--seeds", type=int, default=100, help="random-alphabet seeds on the plant")
    ap.add_argument("--rig-seeds", type=int, default=20, help="random-alphabet seeds on each rig")
    sub = ap.add_subparsers(dest="command")
    pop = sub.add_parser("population", parents=[common], help="the adversaries on held-out population rigs")
    pop.add_argument("--rigs", type=int, default=50, help="rigs, seeds from --first-rig (50)")
    pop.add_argument("--first-rig", type=int, default=population.HELD_OUT_RIGS.start,
                     help="first rig seed (1000: held out; design rigs are 1-999, for choosing options)")
    pop.add_argument("--random-seeds", type=int, default=100, help="random-alphabet seeds over them (100)")
    good = sub.add_parser("good-kinds", parents=[common], help="good kinds, supervisor off vs on, paired")
    good.add_argument("--seeds", type=int, default=16, help="learning seeds per identification seed (16)")
    good.add_argument("--id-seeds", type=int, default=3, help="identification seeds (3)")
    good.add_argument("--kinds", default=",".join(GOOD_KINDS), help=f"agent kinds ({','.join(GOOD_KINDS)})")
    return ap


def main() -> int:
    args = _parser().parse_args()
    start = time.monotonic()
    try:
        opts = _options(args)
        if args.command == "good-kinds":
            kinds = parse_agents(str(args.kinds))
    except MsdBenchError as e:
        print(f"supervisor_check: error: {e}", file=sys.stderr)
        return 2
    print(opts.limits(PRESETS["default"]).describe())
    if args.command == "population":
        doc = population_check(args, opts, start)
    elif args.command == "good-kinds":
        doc = good_kinds_check(args, opts, kinds, start, provenance() if args.out is not None else {})
    else:
        doc = check(args, opts, start)
    return _write(args.out, doc)


if __name__ == "__main__":
    sys.exit(main())
