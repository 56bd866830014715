"""The classical baselines on the 100 held-out rigs, beside the learned agents of the same rigs.

Why: ``docs/results/rigs_heldout100.json`` holds the Q-learning kinds on held-out rigs 1000-1099
(4 learning seeds each); a control engineer's first question is whether they beat a PID, an LQR or
an MPC on the same rigs. This script runs ``msd-bench rigs`` with the four baselines on exactly
those rigs and validation settings (identification-deterministic designs: one run per rig and
record seed), then writes one document: the Q kinds' rows copied unchanged from the stored sweep,
and the baselines' rows from the new one, each with its Wilson and bootstrap-over-rigs intervals
and its risk columns (``scripts/readme_results.py`` renders it on the results page).

    .venv/bin/python scripts/rigs_baselines.py --out docs/results/rigs_heldout100_baselines.json \
        [--sweep DIR] [--agents glm+pid,...]

``--sweep DIR`` is the baselines' run directory: a finished one (its ``rigs.json`` written) is read as
it is, an interrupted one resumed (finished rigs are not run again), a new one kept.
``--out`` must not exist; it is written atomically at the end.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from msd_bench.core.errors import ConfigError, MsdBenchError  # noqa: E402
from msd_bench.io.storage.atomic import write_text_atomic  # noqa: E402

sys.path.insert(0, str(REPO / "scripts"))
from make_results import provenance  # noqa: E402

STORED = REPO / "docs" / "results" / "rigs_heldout100.json"
BASELINES = "glm+pid,glm+pid-continuous,greybox+lqr,plm+mpc"
SAME = ("rig_set", "rigs_run", "validation", "success_sse_percent")
"""What both sweeps must share for their rows to stand in one table (and the population's seed ranges:
its module was renamed by the layout change, ``core.population`` -> ``core.rigs.population``)."""
KIND_KEYS = ("kind", "label", "n", "successes", "rate", "wilson95", "bootstrap95", "rigs",
             "measured_successes", "risk")
"""The per-kind summary kept (the per-scenario cells stay in the sweeps' own files)."""


def parse(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--sweep", type=Path, help="the baselines' run directory (resumed if it exists)")
    p.add_argument("--agents", default=BASELINES)
    p.add_argument("--stored", type=Path, default=STORED, help="the learned agents' sweep (rigs.json form)")
    args = p.parse_args(argv)
    if args.out.exists():
        raise ConfigError(f"--out {args.out} exists: this script never overwrites a result")
    if not args.stored.is_file():
        raise ConfigError(f"--stored {args.stored}: no such file")
    return args


def sweep_argv(stored: dict[str, Any], agents: str, out: Path) -> list[str]:
    """``msd-bench rigs`` on the stored sweep's rigs (consecutive held-out seeds) with ``agents``."""
    rigs = stored["rigs_run"]
    if rigs != list(range(rigs[0], rigs[0] + len(rigs))):
        raise ConfigError("the stored sweep's rigs are not consecutive seeds: cannot rerun them")
    return [sys.executable, "-m", "msd_bench.cli", "rigs", "--first-rig", str(rigs[0]), "--rigs",
            str(len(rigs)), "--agents", agents, "--out", str(out)]


def beside(stored: dict[str, Any], baselines: dict[str, Any]) -> dict[str, Any]:
    """One document: the stored kinds unchanged, then the baselines' (from ``baselines``, a rigs.json)."""
    for key in SAME:
        if stored.get(key) != baselines.get(key):
            raise ConfigError(f"the two sweeps differ in {key!r}: their rows cannot stand in one table")
    seeds = [{k: v for k, v in doc["population"].items() if k != "module"} for doc in (stored, baselines)]
    if seeds[0] != seeds[1]:
        raise ConfigError("the two sweeps differ in 'population': their rows cannot stand in one table")
    ours = {k["kind"] for k in stored["kinds"]}
    clash = [k["kind"] for k in baselines["kinds"] if k["kind"] in ours]
    if clash:
        raise ConfigError(f"kind {clash[0]!r} is in both sweeps")
    learned = [_row(k, sweep="learned") for k in stored["kinds"]]
    classical = [_row(k, sweep="baselines", not_run=_not_run(baselines, k["kind"]))
                 for k in baselines["kinds"]]
    return {
        "rigs_run": stored["rigs_run"], "validation": stored["validation"],
        "success_sse_percent": stored["success_sse_percent"], "kinds": learned + classical,
        "sweeps": {"learned": {"file": "docs/results/rigs_heldout100.json",
                               "learning_seeds": stored["learning_seeds"], "seconds": stored["seconds"]},
                   "baselines": _sweep_facts(baselines)},
    }


def _row(kind: dict[str, Any], **extra: Any) -> dict[str, Any]:
    """A kind's summary row (:data:`KIND_KEYS`) and which sweep it came from."""
    return {**{key: kind[key] for key in KIND_KEYS if key in kind}, **extra}


def _not_run(sweep: dict[str, Any], kind: str) -> int:
    """Runs of ``kind`` never made: its surrogate could not be identified or its design failed."""
    return sum(1 for r in sweep["rigs"] for o in r["outcomes"]
               if o["kind"] == kind and (not o.get("identified", True) or "design_failed" in o))


def _sweep_facts(sweep: dict[str, Any]) -> dict[str, Any]:
    """The baselines' sweep: its seeds, times and failures summed over the rigs."""
    return {"learning_seeds": sweep["learning_seeds"], "seconds": sweep["seconds"],
            "design_failed": sum(len(r.get("design_failed", {})) for r in sweep["rigs"]),
            "identification_failed": sum(len(r["identification_failed"]) for r in sweep["rigs"])}


def run_sweep(argv: list[str]) -> None:
    """Run (or resume) the baselines' sweep; its last error line if it fails."""
    proc = subprocess.run(argv, cwd=REPO, text=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    if proc.returncode != 0:
        last = proc.stderr.strip().splitlines()[-1:] or ["(no output)"]
        raise ConfigError(f"msd-bench rigs failed ({proc.returncode}): {last[0]}")


def main(argv: list[str] | None = None) -> int:
    try:
        args = parse(argv)
        stored = json.loads(args.stored.read_text())
        doc = provenance("rigs_baselines.py", argv)
        with tempfile.TemporaryDirectory(prefix="rigs-baselines-") as tmp:
            out = args.sweep or Path(tmp) / "sweep"
            if not (out / "rigs.json").is_file():  # a finished sweep is read as it is
                run_sweep(sweep_argv(stored, args.agents, out))
            doc.update(beside(stored, json.loads((out / "rigs.json").read_text())))
        write_text_atomic(args.out, json.dumps(doc, indent=1) + "\n", exclusive=True)
    except MsdBenchError as err:
        print(f"rigs_baselines: error: {err}", file=sys.stderr)
        return 2
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
