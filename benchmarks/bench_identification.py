"""Time GLM, PLM, NLARX (paper, improved) identification and print their fits as JSON.

Usage: ``.venv/bin/python benchmarks/bench_identification.py [--preset default|mild] [--seed 1]``

Every model is identified from its paper-sized record(s) on the emulated plant
and scored on separate validation records (other seeds): free-run simulation
and one-step Best-Fit on the broad multilevel record for every model, and for
the PLM also on its five bias validation records (concatenated). The budget
is 30 s for all identification together on the 2-core bench machine;
``budget_ratio`` is total / 30 s, and ``records_seconds`` (driving the plant to
make the records, measured in the same run) is a baseline to compare against.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import asdict

from msd_bench.core.identification.identify import (
    GlmConfig,
    PlmConfig,
    bias_record,
    broad_record,
    evaluate,
    identify_glm,
    identify_nlarx,
    identify_plm,
)
from msd_bench.core.identification.nlarx import NlarxConfig
from msd_bench.core.identification.plm import PLM_BIASES
from msd_bench.core.physics import plant

BUDGET_S = 30.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="default", choices=sorted(plant.PRESETS))
    ap.add_argument("--seed", type=int, default=1, help="training records use seed, validation seed+1000")
    args = ap.parse_args()
    params = plant.preset(args.preset)

    t0 = time.perf_counter()
    train = broad_record(params, args.seed)
    valid = broad_record(params, args.seed + 1000)
    bias_train = {b: bias_record(params, b, args.seed + 10 * i) for i, b in enumerate(PLM_BIASES)}
    bias_valid = [bias_record(params, b, args.seed + 1000 + 10 * i) for i, b in enumerate(PLM_BIASES)]
    records_s = time.perf_counter() - t0
    merged = bias_valid[0]
    for r in bias_valid[1:]:
        merged = merged.merge(r)

    models = {
        "glm": lambda: identify_glm(train, GlmConfig(stroke=params.L)),
        "plm": lambda: identify_plm(bias_train, PlmConfig(stroke=params.L)),
        "nlarx-paper": lambda: identify_nlarx(train, NlarxConfig(form="paper", seed=args.seed), params.L),
        "nlarx-improved": lambda: identify_nlarx(
            train, NlarxConfig(form="improved", seed=args.seed), params.L
        ),
    }
    out: dict[str, object] = {"preset": args.preset, "seed": args.seed, "records_seconds": records_s}
    total = 0.0
    for name, fit in models.items():
        t = time.perf_counter()
        model = fit()
        seconds = time.perf_counter() - t
        total += seconds
        report = asdict(evaluate(model, valid))
        entry = {"seconds": seconds, "sim_fit": report["sim_fit"], "one_step_fit": report["one_step_fit"]}
        if name == "plm":
            on_bias = evaluate(model, merged)
            entry.update(bias_sim_fit=on_bias.sim_fit, bias_one_step_fit=on_bias.one_step_fit)
        out[name] = entry
    out.update(total_seconds=total, budget_seconds=BUDGET_S, budget_ratio=total / BUDGET_S)
    out["within_budget"] = total < BUDGET_S
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
