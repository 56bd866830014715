"""Which input a ros2_control bag should identify from: the applied force, the held commands, or the effort.

Drives the rig emulator's model in process (``core.rigs.rig.Rig``, preset ``rig``,
default imperfections: sensor noise, 1 sample of dead time, 20 ms lag,
friction) with the paper's experiment plan, and identifies every model kind
three ways from the same runs (docs/ros2-control.md §Force):

* ``msd``: the msd face's input, the applied force (``joint_states.effort``);
* ``r2c_applied``: the ros2_control face's default, the held commands through
  the actuator fitted to the measured effort (plus ``--effort-noise`` N of
  effort-sensor noise);
* ``r2c_held``: the held commands themselves.

Writes the simulation fits (and the fitted actuator) with the command, commit
and machine to ``docs/results/force_input.json``.

    .venv/bin/python scripts/measure_force_input.py [--samples 12000 --val-samples 4000]
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

from msd_bench.app.pipeline import identify_surrogates
from msd_bench.app.plan import paper_plan
from msd_bench.core.identification import excitation as exc
from msd_bench.core.identification.data import Experiment, IOData
from msd_bench.core.identification.model_kinds import MODEL_KINDS
from msd_bench.core.identification.records import Records
from msd_bench.core.physics.plant import preset
from msd_bench.core.rigs.actuation import actuator_force, effort_agreement
from msd_bench.core.rigs.rig import Rig, RigImperfections

REPO = Path(__file__).resolve().parents[1]
FACES = ("msd", "r2c_applied", "r2c_held")


def facts(argv: list[str]) -> dict[str, Any]:
    """Command, commit and machine, so the numbers can be traced and re-measured."""
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True).stdout.strip()
    return {"command": " ".join([".venv/bin/python", "scripts/measure_force_input.py", *argv]),
            "commit": git("rev-parse", "HEAD"), "dirty": bool(git("status", "--porcelain")),
            "machine": {"platform": platform.platform(), "python": platform.python_version(),
                        "numpy": np.__version__},
            "date": dt.datetime.now(dt.UTC).isoformat(timespec="seconds")}


def inputs(u: np.ndarray, seed: int, effort_noise: float,
           actuators: list[dict[str, float]]) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Measured positions and the three candidate inputs of one run of the rig."""
    p = preset("rig")
    rig = Rig(p, RigImperfections(), seed)
    rows = [rig.step(float(c)) for c in u]
    y = np.array([r.measured for r in rows])
    applied = np.array([r.effort for r in rows])
    held = np.clip(u, -p.F, p.F)
    measured = applied + np.random.default_rng(seed).normal(0.0, effort_noise, u.size)
    fit = effort_agreement(held, measured, p.dt)
    actuators.append({"delay_samples": fit.delay_samples, "tau_s": round(fit.time_constant_s, 5),
                      "fit_percent": round(fit.fit_percent, 2)})
    rebuilt = actuator_force(held, fit.delay_samples, fit.time_constant_s, p.dt)
    return y, {"msd": applied, "r2c_applied": rebuilt, "r2c_held": held}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=12_000)
    ap.add_argument("--val-samples", type=int, default=4_000)
    ap.add_argument("--models", default=",".join(MODEL_KINDS))
    ap.add_argument("--effort-noise", type=float, default=0.1, help="effort sensor noise, N (std)")
    ap.add_argument("--nlarx-scale", type=float, default=1.0)
    ap.add_argument("--out", type=Path, default=REPO / "docs" / "results" / "force_input.json")
    args = ap.parse_args()
    t0 = time.perf_counter()
    models = [m.strip() for m in args.models.split(",") if m.strip()]
    bias: dict[str, dict[str, dict[float, IOData]]] = {f: {"train": {}, "validation": {}} for f in FACES}
    broad: dict[str, dict[str, IOData]] = {f: {} for f in FACES}
    actuators: list[dict[str, float]] = []
    for e in paper_plan(0, args.samples, args.val_samples):
        multilevel = isinstance(e.signal, exc.MultilevelConfig)
        if isinstance(e.signal, exc.MultilevelConfig):
            u, settle = exc.multilevel(e.signal, e.seed), 0
        else:
            u, settle = exc.prbs(e.signal, e.seed), e.signal.settle
        y, candidates = inputs(u, e.seed, args.effort_noise, actuators)
        for face, inp in candidates.items():
            record = IOData((Experiment(inp[settle:], y[settle:]),), 0.01, {})
            if multilevel:
                broad[face][e.role] = record
            elif e.bias is not None:
                bias[face][e.role][e.bias] = record
    fits: dict[str, dict[str, float]] = {}
    for face in FACES:
        records = Records(bias[face]["train"], bias[face]["validation"], broad[face]["train"],
                          broad[face]["validation"])
        _, reports = identify_surrogates(records, models, 0, preset("rig"), args.nlarx_scale)
        fits[face] = {name: round(r.sim_fit, 2) for name, r in reports.items()}
        print(face, fits[face], flush=True)
    doc = {"schema": "msd-bench/force-input", **facts(sys.argv[1:]), "preset": "rig",
           "imperfections": "RigImperfections() defaults", "effort_noise_n": args.effort_noise,
           "samples": args.samples, "val_samples": args.val_samples, "sim_fit": fits,
           "gap_r2c_applied_vs_msd": {m: round(fits["r2c_applied"][m] - fits["msd"][m], 2) for m in models},
           "gap_r2c_held_vs_msd": {m: round(fits["r2c_held"][m] - fits["msd"][m], 2) for m in models},
           "actuator_fits": actuators, "seconds": round(time.perf_counter() - t0, 1)}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=1) + "\n")
    print(json.dumps({k: doc[k] for k in ("gap_r2c_applied_vs_msd", "gap_r2c_held_vs_msd")}, indent=1))


if __name__ == "__main__":
    main()
