"""``identify``: fit model kinds from bags or from a CSV, NPZ or MAT record (docs/own-bags.md).

    msd-bench identify --npz rec.npz --u V1 --y V2 --ts 0.0016384 --train 40650:95000 \\
        --validation 95000:105712 --models glm,nlarx-improved --out models
    msd-bench identify --bags bags/run1 --out models
    msd-bench identify --broad-bag TRAIN --validation-bag TEST --namespace /rig --dt 0.001 --out models

Writes ``<kind>.json`` per fitted kind and ``fits.json`` under ``--out`` (created; no file
there is overwritten), printing a line per kind as it is written or fails. A kind that
cannot be fitted fails alone: the others are written and ``fits.json`` names it with its
reason; the exit status is then 1. A usage mistake is one line and exit status 2.
"""

from __future__ import annotations

import argparse
import datetime as dt
import math
from pathlib import Path
from typing import Any

import numpy as np

from msd_bench.commands.sample_range import sample_range
from msd_bench.core.errors import ConfigError, MsdBenchError
from msd_bench.core.identification.data import IOData
from msd_bench.core.identification.model_kinds import MODEL_KINDS, check_models, needs_bias_records
from msd_bench.core.identification.records import Records
from msd_bench.io.storage.array_file import FORMATS, read_signals
from msd_msgs_py.contract import PLANT_NAMESPACE


class IdentifyError(MsdBenchError):
    """An ``identify`` option is wrong."""


def register(subparsers: Any) -> None:
    """Add ``identify`` to an argparse subparsers object."""
    p = subparsers.add_parser("identify", help="fit model kinds from bags or a CSV/NPZ/MAT record",
                              description=__doc__.splitlines()[0])
    src = p.add_argument_group("a record in a file (one input and one output column)")
    for fmt in FORMATS:
        src.add_argument(f"--{fmt}", type=Path, metavar="FILE", help=f"a {fmt.upper()} file")
    src.add_argument("--u", help="the input column (force, voltage...)")
    src.add_argument("--y", help="the output column (position, voltage...)")
    src.add_argument("--ts", type=float, help="sample time of the record, s")
    src.add_argument("--train", help="training sample range A:B (B excluded)")
    src.add_argument("--validation", help="validation sample range C:D (the fits are reported on it)")
    src.add_argument("--units", default="", help="input and output units as INPUT,OUTPUT (e.g. V,V), "
                     "recorded in the model files (default N,m)")
    bags = p.add_argument_group("bags (roles as the identifier node takes them)")
    bags.add_argument("--bags", metavar="DIR", help="a directory of our recorder's self-describing bags")
    bags.add_argument("--broad-bag", help="a rig's broad-range training bag")
    bags.add_argument("--validation-bag", help="a rig's validation bag")
    bags.add_argument("--bias-bags", default="", help="a rig's PRBS bags as BIAS=PATH,... (for plm)")
    bags.add_argument("--settle-samples", type=int, default=0,
                      help="leading samples dropped from each bias bag (ours store their own)")
    bags.add_argument("--namespace", default=PLANT_NAMESPACE, help="namespace of the bags' topics")
    bags.add_argument("--dt", type=float, default=0.0,
                      help="the bags' sample time, s (default: the median interval of their stamps)")
    p.add_argument("--models", help="kinds to fit, comma-separated (default: every kind; from a file, "
                   "every kind but plm, which needs five bias records)")
    p.add_argument("--out", type=Path, required=True, help="output directory (created; nothing overwritten)")
    p.add_argument("--seed", type=int, default=0, help="seed of the NLARX training")
    p.add_argument("--stroke", type=float, help="stroke L (output units): outputs are kept in [-L/2, L/2] "
                   "(a file's default: 4 x its largest |y|, so the bound never acts on the record)")
    p.add_argument("--force", type=float, help="input limit F (input units): inputs saturate at +-F "
                   "(a file's default: 2 x its largest |u|)")
    p.add_argument("--nlarx-scale", type=float, default=1.0, help="multiplies the NLARX training iterations")
    p.add_argument("--rig", type=Path, metavar="FILE",
                   help="rig description (docs/rig-description.md): --stroke, --force, --units, the sample "
                        "time and the bags' namespace from it; explicit options win; a record or bags at "
                        "another sample time than the rig's are refused (their models would be)")
    p.set_defaults(func=run)


def apply_rig(args: argparse.Namespace) -> None:
    """Fill what the command line left unset from ``--rig``; one line when the record's sample time is
    not the rig's, before anything is read or written: a model identified at another rate would be
    refused on the rig (:meth:`RigDescription.check_model`), so it is not made."""
    if getattr(args, "rig", None) is None:
        return
    from msd_bench.io.rigs.rig_file import read_rig

    rig = read_rig(args.rig)
    args.stroke = rig.stroke if args.stroke is None else args.stroke
    args.force = rig.force_limit if args.force is None else args.force
    args.units = args.units or f"{rig.force_unit},{rig.position_unit}"
    if rig.plant_ns and args.namespace == PLANT_NAMESPACE:
        args.namespace = rig.plant_ns
    for option, value in (("--ts", args.ts), ("--dt", args.dt or None)):
        if value is not None and not math.isclose(value, rig.dt, rel_tol=1e-9):
            raise IdentifyError(f"{option} {value:g} s is not the sample time of the rig of {args.rig} "
                                f"({rig.dt:g} s, {rig.rate:g} Hz): its models would be refused on the rig; "
                                f"record at the rig's rate (models are never resampled)")
    if args.ts is None:
        args.ts = rig.dt
    if not args.dt:
        args.dt = rig.dt


def run(args: argparse.Namespace) -> int:
    """Identify from the file or the bags given; 1 if any kind failed (the others are written)."""
    apply_rig(args)
    files = [(fmt, getattr(args, fmt)) for fmt in FORMATS if getattr(args, fmt) is not None]
    default = [k for k in MODEL_KINDS if not (files and needs_bias_records([k]))]
    models = tuple(m.strip() for m in (args.models or ",".join(default)).split(",") if m.strip())
    check_models(models)
    if len(files) > 1 or (files and (args.bags or args.broad_bag)):
        raise IdentifyError("give one record: --csv, --npz or --mat FILE, or --bags/--broad-bag")
    if files:
        failed = _from_file(args, files[0][0], files[0][1], models)
    elif args.bags or args.broad_bag:
        failed = _from_bags(args, models)
    else:
        raise IdentifyError("give a record: --csv, --npz or --mat FILE (with --u, --y, --ts, --train, "
                            "--validation), or --bags DIR, or --broad-bag and --validation-bag")
    return 1 if failed else 0


def _progress(name: str, path: Path) -> None:
    print(f"{name}: written to {path}", flush=True)


def _failed(name: str, why: str) -> None:
    print(f"{name}: FAILED: {why}", flush=True)


def _from_file(args: argparse.Namespace, fmt: str, path: Path, models: tuple[str, ...]) -> dict[str, str]:
    from msd_bench.app.identification import IdentifyJob, identify_and_write
    from msd_bench.io.storage import artifacts
    from msd_bench.io.storage.paths import writable_dir

    for opt in ("u", "y", "ts", "train", "validation"):
        if getattr(args, opt) is None:
            raise IdentifyError(f"--{fmt} needs --{opt}")
    if needs_bias_records(models):
        raise IdentifyError("plm needs five bias records (bags); fit it from bags, not from one record")
    if not (np.isfinite(args.ts) and args.ts > 0):
        raise IdentifyError(f"--ts must be finite and > 0, got {args.ts}")
    u, y = read_signals(path, fmt, args.u, args.y)
    train, val = (sample_range(getattr(args, o), o, u.size, min_samples=3) for o in ("train", "validation"))
    units = _units(args.units)
    stroke = args.stroke if args.stroke is not None else 4 * float(np.max(np.abs(y)))
    force = args.force if args.force is not None else 2 * float(np.max(np.abs(u)))
    out = writable_dir(str(args.out), "--out")
    broad = IOData.single(u[slice(*train)], y[slice(*train)], args.ts, "train")
    records = Records({}, {}, broad, IOData.single(u[slice(*val)], y[slice(*val)], args.ts, "validation"))
    params = {"file": str(path), "format": fmt, "u": args.u, "y": args.y, "ts": args.ts, "train": list(train),
              "validation": list(val), "models": list(models), "seed": args.seed, "stroke": stroke,
              "force": force, "units": list(units), "nlarx_scale": args.nlarx_scale,
              "created_utc": dt.datetime.now(dt.UTC).isoformat(timespec="seconds")}
    prov = artifacts.Provenance((artifacts.source(path),), params, args.seed)
    job = IdentifyJob(models, args.seed, stroke, force, args.ts, args.nlarx_scale, units)
    done = identify_and_write(records, job, out, prov, _progress, _failed)
    _summary(done.fits, done.failed, out)
    return done.failed


def _from_bags(args: argparse.Namespace, models: tuple[str, ...]) -> dict[str, str]:
    from msd_bench.app.bag_identification import IdentifierConfig, identify_from_bags
    from msd_bench.core.errors import IdentificationError

    bias = tuple(b.strip() for b in args.bias_bags.split(",") if b.strip())
    cfg = IdentifierConfig(bags_dir=args.bags or "", broad_bag=args.broad_bag or "",
                           validation_bag=args.validation_bag or "", bias_bags=bias, models=models,
                           settle_samples=args.settle_samples,
                           seed=args.seed, namespace=args.namespace, dt=args.dt, out_dir=str(args.out),
                           nlarx_scale=args.nlarx_scale,
                           **{k: getattr(args, k) for k in ("stroke", "force")
                              if getattr(args, k) is not None})
    failed: dict[str, str] = {}
    try:
        fits = identify_from_bags(cfg, on_saved=_progress, on_failed=lambda n, w: failed.update({n: w}))
    except IdentificationError:
        if not failed:  # not a kind's failure: the bags themselves
            raise
        fits = {}
    for name, why in failed.items():
        _failed(name, why)
    _summary(fits, failed, Path(args.out))
    return failed


def _summary(fits: dict[str, Any], failed: dict[str, str], out: Path) -> None:
    for name, f in fits.items():
        print(f"{name}: fit {f['sim_fit']:.2f} % (simulation), {f['one_step_fit']:.2f} % (one-step) "
              "on the validation range", flush=True)
    if failed:
        print(f"{len(failed)} kind(s) failed ({', '.join(failed)}); the others and fits.json are in {out}",
              flush=True)


def _units(text: str) -> tuple[str, str]:
    if not text:
        return ("N", "m")
    parts = [p.strip() for p in text.split(",")]
    if len(parts) != 2 or not all(parts):
        raise ConfigError(f"--units must be INPUT,OUTPUT (e.g. V,V), got {text!r}")
    return parts[0], parts[1]


__all__ = ["IdentifyError", "register", "run"]
