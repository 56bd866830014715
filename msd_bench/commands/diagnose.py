"""``msd-bench compare MODEL... --record R`` and ``msd-bench resid MODEL --record R``.

MATLAB's model checks on the bench's model files (:mod:`msd_bench.core.identification.diagnostics`):
``compare`` prints each model's free-run fit (%) and RMSE in the record's units (and its k-step
prediction's fit where it has a predictor), draws measured against each model into ``--png``
(with ``--band``, the 95 % simulation band of a grey-box model's parameter covariance, as
``simsd``) and writes ``--json``; ``resid`` prints a pass/fail line per residual test (whiteness,
independence of the input, 99 % bands) and draws both correlations into ``--png``.

A record is a bag (``joint_states`` of ``--namespace``) or an array file: ``.npz`` (members
``--u``/``--y``, default ``u``/``y``), ``.mat`` (variables ``--u``/``--y``) or ``.csv`` (columns
named ``--u``/``--y`` in a header line), sampled at the model's dt unless ``--dt`` says
otherwise; ``--range A:B`` takes samples [A, B). Every mistake is one ``error:`` line (exit 2);
no existing file is overwritten.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from msd_bench.commands.sample_range import sample_range
from msd_bench.core.errors import InvalidInputError
from msd_bench.core.identification import diagnostics, identify
from msd_bench.core.identification.data import Experiment
from msd_bench.core.physics.model import StepModel
from msd_bench.io.storage.array_file import read_signals


def register(sub: Any) -> None:
    """Add the ``compare`` and ``resid`` subcommands."""
    c = sub.add_parser("compare", help="models against a record: fit, RMSE, figure (MATLAB compare)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    c.add_argument("models", nargs="+", type=Path, help="model files (fit_<kind>.json)")
    _record_arguments(c)
    c.add_argument("--k", type=int, default=1, help="prediction horizon of ARX-type models (default 1)")
    c.add_argument("--band", action="store_true", help="draw the 95 %% simulation band from the covariance")
    c.add_argument("--json", action="store_true", help="print the results as JSON")
    c.set_defaults(func=_compare)
    r = sub.add_parser("resid", help="residual whiteness and input independence (MATLAB resid)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    r.add_argument("models", nargs=1, type=Path, help="a model file")
    _record_arguments(r)
    r.add_argument("--lags", type=int, default=25, help="largest lag tested (default 25)")
    r.add_argument("--json", action="store_true", help="print the results as JSON")
    r.set_defaults(func=_resid)


def _record_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--record", type=Path, required=True, help="a bag, or an .npz / .mat / .csv array file")
    p.add_argument("--u", default="u", help="input member / column of an array file (default u)")
    p.add_argument("--y", default="y", help="output member / column of an array file (default y)")
    p.add_argument("--range", default="", help="samples A:B of the record (default all)")
    p.add_argument("--dt", type=float, default=None, help="sample time of an array file, s (default: "
                   "the model's)")
    p.add_argument("--namespace", default="/msd", help="plant namespace of a bag (default /msd)")
    p.add_argument("--window", type=int, default=identify.INIT_HORIZON,
                   help=f"samples that set the initial state, left out of every score "
                        f"(default {identify.INIT_HORIZON})")
    p.add_argument("--png", type=Path, default=None, help="write the figure here (must not exist)")


def _load_models(paths: list[Path]) -> list[StepModel]:
    from msd_bench.io.storage.artifacts import load_model

    return [load_model(p) for p in paths]


def read_record(args: argparse.Namespace, model: StepModel) -> Experiment:
    """The record the arguments name, cut to ``--range``, at the model's sample time."""
    path = Path(args.record)
    if not path.exists():
        raise InvalidInputError(f"record {path} does not exist")
    if path.suffix in (".npz", ".mat", ".csv"):
        u, y = read_signals(path, path.suffix[1:], args.u, args.y)
        dt = model.dt if args.dt is None else float(args.dt)
    else:
        from msd_bench.io.bags.reader import read_experiment

        exp, _ = read_experiment(path, args.namespace)
        u, y, dt = exp.u, exp.y, model.dt if args.dt is None else float(args.dt)
    if not math.isclose(dt, model.dt, rel_tol=1e-9):
        raise InvalidInputError(f"record sampled at dt={dt} s, model {model.name!r} at {model.dt} s")
    a, b = sample_range(args.range, "range", u.size)
    return Experiment(u[a:b], y[a:b], path.name)


def _compare(args: argparse.Namespace) -> int:
    models = _load_models(args.models)
    odd = [m.name for m in models if not math.isclose(m.dt, models[0].dt, rel_tol=1e-9)]
    if odd:
        raise InvalidInputError(f"models sample at different dt: {odd[0]!r} differs from {models[0].name!r}")
    exp = read_record(args, models[0])
    results = [diagnostics.compare(m, exp, args.window, args.k) for m in models]
    bands = {m.name: diagnostics.sim_band(m, exp, window=args.window) for m in models} if args.band else {}
    rows = [{"model": r.model, "fit_percent": r.fit, "rmse": r.rmse,
             "prediction_fit_percent": r.predicted_fit, "prediction": r.note} for r in results]
    if args.png is not None:
        _compare_figure(args.png, exp, results, bands, args.window)
    if args.json:
        for row, model in zip(rows, models, strict=True):
            if "stderr" in model.info:
                row["parameters"] = model.info.get("parameters")
                row["stderr"] = model.info["stderr"]
        print(json.dumps({"record": str(args.record), "samples": len(exp), "window": args.window,
                          "models": rows}, indent=1))
    else:
        for row, model in zip(rows, models, strict=True):
            pred = "" if row["prediction_fit_percent"] is None else \
                f"; {args.k}-step prediction fit {row['prediction_fit_percent']:.2f} %"
            print(f"{row['model']}: fit {row['fit_percent']:.2f} %, RMSE {row['rmse']:.6g} "
                  f"(record units){pred}")
            for line in diagnostics.parameter_lines(model):
                print(line)
    return 0


def _resid(args: argparse.Namespace) -> int:
    model = _load_models(args.models)[0]
    exp = read_record(args, model)
    res = diagnostics.resid(model, exp, args.lags, args.window)
    if args.png is not None:
        _resid_figure(args.png, res)
    if args.json:
        print(json.dumps({"model": res.model, "residuals": res.source, "lags": res.lags, "band99": res.band,
                          "whiteness_pass": res.whiteness_pass, "independence_pass": res.independence_pass,
                          "autocorrelation": res.auto.tolist(), "cross_correlation": res.cross.tolist()},
                         indent=1))
    else:
        print("\n".join(res.lines()))
    return 0


def _compare_figure(path: Path, exp: Experiment, results: list[diagnostics.Comparison],
                    bands: dict[str, tuple[np.ndarray, np.ndarray]], window: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from msd_bench.io.storage.atomic import save_figure_atomic

    fig, (ax, err) = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    t = np.arange(len(exp))
    ax.plot(t, exp.y, color="black", lw=1.0, label="measured")
    for r in results:
        ax.plot(t, r.sim, lw=0.8, label=f"{r.model}: fit {r.fit:.1f} %")
        err.plot(t[window:], (exp.y - r.sim)[window:], lw=0.6, label=f"{r.model}: RMSE {r.rmse:.3g}")
        if r.model in bands:
            lo, hi = bands[r.model]
            ax.fill_between(t, lo, hi, alpha=0.3, label=f"{r.model}: 95 % band")
            err.fill_between(t[window:], (lo - r.sim)[window:], (hi - r.sim)[window:], alpha=0.3,
                             label=f"{r.model}: 95 % band about its simulation")
    ax.axvline(window, color="grey", ls=":", lw=0.8)
    ax.set_ylabel("output")
    err.set_ylabel("measured - simulated")
    err.set_xlabel("sample")
    ax.legend(loc="upper right", fontsize=8)
    err.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    save_figure_atomic(fig, path, exclusive=True)
    plt.close(fig)


def _resid_figure(path: Path, res: diagnostics.Residuals) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from msd_bench.io.storage.atomic import save_figure_atomic

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6))
    a1.stem(np.arange(1, res.lags + 1), res.auto)
    a1.set_title(f"{res.model}: autocorrelation of the {res.source} residuals")
    a2.stem(np.arange(-res.lags, res.lags + 1), res.cross)
    a2.set_title("cross-correlation of residuals and input")
    for ax in (a1, a2):
        ax.axhspan(-res.band, res.band, color="tab:blue", alpha=0.15, label="99 % band")
        ax.set_xlabel("lag (samples)")
        ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure_atomic(fig, path, exclusive=True)
    plt.close(fig)
