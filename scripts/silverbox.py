"""The Silverbox record under its benchmark protocol: every model kind's RMSE (mV) on the three test sets.

Prints one JSON object (``scripts/make_results.py silverbox`` stores it as docs/results/silverbox.json;
``scripts/readme_results.py`` renders it into docs/results.md). The record is the repository's
``data/silverbox.npz`` (V1 input, V2 output, float32); the protocol is
:data:`msd_bench.core.identification.protocol.SILVERBOX`: each kind is fitted on the training
range less its last 20 % (held out for the validation column), nothing is chosen on a test set,
free-run simulation, the first 50 samples of a set initialise the state, RMSE over the rest.

    python scripts/silverbox.py [--kinds glm,greybox-rk4] [--samples N]
    python scripts/silverbox.py --write-rig config/rigs/silverbox.yaml

``--write-rig FILE`` writes the Silverbox as a rig description (docs/rig-description.md) from the
record's training range alone (its rate, the stroke that holds its output, its largest input as
the force limit; :func:`msd_bench.core.rigs.description.record_parameters`), never over a file.

``--samples N`` fits on the first N estimation samples only and scores the first N+50 of each
set (a quick check, not the result).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from msd_bench.core.errors import MsdBenchError  # noqa: E402
from msd_bench.core.identification import diagnostics, protocol  # noqa: E402
from msd_bench.core.identification.data import Experiment, IOData  # noqa: E402
from msd_bench.core.identification.model_kinds import MODEL_KINDS, FitRequest, fit_model  # noqa: E402
from msd_bench.core.identification.records import Records  # noqa: E402

DATA = REPO / "data" / "silverbox.npz"
KINDS = ("glm", "nlarx-paper", "nlarx-improved", "greybox", "greybox-rig", "greybox-rk4", "plm")
RESID_LAGS = 25
"""Lags of the residual tests (``msd-bench resid``'s default) on the multisine test set."""
NOT_APPLICABLE = {"plm": "not applicable: needs five bias records (one per operating force)"}
PUBLISHED = [
    {"method": "deep state-space encoder (SUBNET), nx = 4",
     "source": "Beintema, Tóth, Schoukens, \"Nonlinear state-space identification using deep encoder "
               "networks\", L4DC 2021",
     "rmse_mv": {"multisine": 0.36, "arrow_full": 1.4, "arrow_no_extrapolation": 0.32}},
    {"method": "polynomial NARX by FROLS",
     "source": "SysIdentPy documentation, \"Silver box system\" example",
     "rmse_mv": {"multisine": 7.7, "arrow_full": 4.1, "arrow_no_extrapolation": 2.2}},
]
"""Published free-run results on the same protocol (RMSE, mV), cited as their sources state them."""


def load(path: Path = DATA) -> tuple[np.ndarray, np.ndarray]:
    """(V1, V2) of the committed record as float64."""
    with np.load(path) as d:
        return np.asarray(d["V1"], dtype=float), np.asarray(d["V2"], dtype=float)


def _mv(value: float) -> float | None:
    return round(1000.0 * value, 4) if math.isfinite(value) else None


def run_kind(kind: str, est: IOData, val: IOData, u: np.ndarray, y: np.ndarray,
             proto: protocol.Protocol) -> dict[str, Any]:
    """Fit one kind and score it; a kind that fails is recorded with its one-line reason."""
    if kind in NOT_APPLICABLE:
        return {"kind": kind, "label": MODEL_KINDS[kind].label, "status": NOT_APPLICABLE[kind]}
    y_est = est.experiments[0].y
    u_est = est.experiments[0].u
    # Stroke and force limit only clip: set wide of the training range (no test set consulted).
    req = FitRequest(Records({}, {}, est, val), seed=0, stroke=8.0 * float(np.max(np.abs(y_est))),
                     force=4.0 * float(np.max(np.abs(u_est))), dt=est.dt, units=("V", "V"))
    t0 = time.perf_counter()
    try:
        model = fit_model(kind, req)
    except MsdBenchError as err:
        return {"kind": kind, "label": MODEL_KINDS[kind].label, "status": f"fit failed: {err}"}
    seconds = time.perf_counter() - t0
    scores = protocol.score_tests(model, proto, u, y)
    row: dict[str, Any] = {
        "kind": kind, "label": MODEL_KINDS[kind].label, "status": "ok", "fit_seconds": round(seconds, 2),
        "rmse_mv": {name: _mv(v) for name, v in scores.items()},
        "validation_rmse_mv": _mv(protocol.rmse_after_window(model, val.experiments[0], proto.window)),
    }
    a, b = proto.tests["multisine"]
    res = diagnostics.resid(model, Experiment(u[a:b], y[a:b], "multisine"), RESID_LAGS, proto.window)
    row["resid_multisine"] = {"residuals": res.source, "lags": res.lags, "whiteness_pass": res.whiteness_pass,
                              "independence_pass": res.independence_pass,
                              "auto_outside": int(np.sum(np.abs(res.auto) > res.band)),
                              "cross_outside": int(np.sum(np.abs(res.cross) > res.band))}
    choice = model.info.get("integrator_choice")
    if isinstance(choice, dict):  # greybox, greybox-rig: which kernel the fast resonance chose
        row["integrator_choice"] = {k: choice[k] for k in ("chosen", "omega_dt", "euler_limit", "train_rms")
                                    if k in choice}
    if kind == "greybox-rk4":
        row["model"] = {k: model.info[k] for k in ("structure", "input_lead", "integrator", "parameters",
                                                   "stderr", "fixed")}
    return row


def rig_parameters() -> dict[str, object]:
    """The Silverbox as a rig, from its training range only (no test set read): volts in and out."""
    from msd_bench.core.rigs.description import record_parameters
    u, y = load()
    a, b = protocol.SILVERBOX.train
    return record_parameters(u[a:b], y[a:b], protocol.SILVERBOX.dt, ("V", "V"))


def write_rig_description(path: Path) -> int:
    """``--write-rig``: the description, written atomically to a new file (one line if it exists)."""
    from msd_bench.core.errors import ConfigError
    from msd_bench.io.rigs.rig_file import write_rig
    header = ["The Silverbox (data/silverbox.npz) as a rig description: written by",
              "`python scripts/silverbox.py --write-rig` from the record's training range (never typed).",
              "Volts in and out; the stroke holds every measured output;",
              "the largest input is the force limit."]
    try:
        write_rig(path, rig_parameters(), header)
    except ConfigError as err:
        print(f"silverbox: error: {err}", file=sys.stderr)
        return 2
    print(f"wrote {path}")
    return 0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--kinds", default=",".join(KINDS), help="comma-separated model kinds")
    p.add_argument("--samples", type=int, default=0, help="quick check: estimation samples (0 = all)")
    p.add_argument("--write-rig", type=Path, metavar="FILE",
                   help="write the record as a rig description to the new FILE instead, and exit")
    args = p.parse_args(argv)
    if args.write_rig is not None:
        return write_rig_description(args.write_rig)
    kinds = [k for k in args.kinds.split(",") if k]
    unknown = [k for k in kinds if k not in MODEL_KINDS]
    if unknown:
        print(f"silverbox: error: unknown model kind {unknown[0]!r}; choose from {', '.join(MODEL_KINDS)}",
              file=sys.stderr)
        return 2
    proto = protocol.SILVERBOX
    u, y = load()
    est, val = protocol.estimation_and_validation(proto, u, y)
    if args.samples > 0:
        n = args.samples
        e = est.experiments[0]
        est = IOData((Experiment(e.u[:n], e.y[:n], e.name),), est.dt)
        proto = protocol.Protocol(proto.name, proto.dt, proto.train, proto.validation_split,
                                  {k: (a, min(b, a + n + proto.window)) for k, (a, b) in proto.tests.items()},
                                  proto.window)
    rows = [run_kind(k, est, val, u, y, proto) for k in kinds]
    doc = {
        "record": "data/silverbox.npz (Silverbox, SNLS80mV; V1 input, V2 output; float32)",
        "protocol": {"train": list(proto.train), "estimation_samples": est.n_samples,
                     "validation_samples": val.n_samples,
                     "tests": {k: list(v) for k, v in proto.tests.items()},
                     "window": proto.window, "dt": proto.dt, "score": "1000 * RMSE(y[window:]) mV, free run"},
        "kinds": rows,
        "published": PUBLISHED,
    }
    print(json.dumps(doc, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
