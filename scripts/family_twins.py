"""Compare a rig family's population run with its default-family twins, rig by rig, run by run.

    python scripts/family_twins.py runs/rigs-scaled-100/rigs.json runs/rigs-default-100/rigs.json \
        --out docs/results/rigs_scaled_twins.json

Why: the ``scaled`` family's rig N is default-family rig N in other units (docs/rig-families.md), so a
bench that is free of scale gives every run on it the outcome of its twin. The population tables
say how often each kind succeeds; only a pairing of the same rig, kind and learning seed says whether
the two runs agree, and which ones part. Both runs must be of the same rigs, seeds and kinds, made at
the same commit (so the two sides share every line of code); this script refuses them otherwise,
in one line. It computes nothing new: it reads the two ``rigs.json`` and writes the pairing,
atomically, with each side's success per kind (Wilson 95 % interval) and every pair that parts.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "scripts"))
sys.path.insert(0, str(REPO))

from make_results import commit, machine  # noqa: E402

from msd_bench.core.evaluation.stats import wilson  # noqa: E402
from msd_bench.io.storage.atomic import write_text_atomic  # noqa: E402

Key = tuple[int, str, int]
"""A run: (rig, kind, learning seed)."""


class Mismatch(ValueError):
    """The two runs are not of the same rigs, seeds and kinds: no pairing is meaningful."""


def load(path: Path) -> dict[str, Any]:
    """A ``rigs.json``, or one line naming what is wrong with it."""
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise Mismatch(f"{path}: not a readable rigs.json ({err})") from None
    if not isinstance(doc, dict) or "rigs" not in doc or "population" not in doc:
        raise Mismatch(f"{path}: not a rigs.json (no 'rigs' or 'population')")
    return doc


def family_of(doc: dict[str, Any]) -> str:
    """The family a run drew its rigs from (the default family's record predates the name)."""
    return str(doc["population"].get("family", "default"))


def successes(doc: dict[str, Any]) -> dict[Key, bool]:
    """Every run's success (judged on the true position), keyed by rig, kind and seed."""
    return {(int(r["rig"]), str(o["kind"]), int(o["seed"])): bool(o["success"])
            for r in doc["rigs"] for o in r["outcomes"]}


def check_same_runs(family: dict[str, Any], twin: dict[str, Any]) -> None:
    """Refuse a pairing of runs that are not the same rigs, seeds and kinds of two families."""
    for field in ("rigs_run", "learning_seeds", "agents"):
        if family.get(field) != twin.get(field):
            raise Mismatch(f"the two runs differ in {field}: {family.get(field)} vs {twin.get(field)}")
    if family_of(twin) != "default":
        raise Mismatch(f"the twin run is of family {family_of(twin)!r}, not 'default'")
    if family_of(family) == "default":
        raise Mismatch("the family run is of the default family: nothing to compare it with")
    if set(successes(family)) != set(successes(twin)):
        raise Mismatch("the two runs do not hold the same (rig, kind, seed) outcomes")


def _rate(k: int, n: int) -> dict[str, Any]:
    lo, hi = wilson(k, n)
    return {"successes": k, "n": n, "percent": 100.0 * k / n, "wilson95": [100.0 * lo, 100.0 * hi]}


def mcnemar_p(only_family: int, only_twin: int) -> float:
    """Exact two-sided McNemar p-value of the discordant pairs: the chance, were parting a coin flip
    with no side favoured (rounding, not a scale the bench forgot), of a split at least this uneven.
    A small p says one family is systematically better or worse; equality needs only the counts."""
    n = only_family + only_twin
    if n == 0:
        return 1.0
    tail: float = sum(math.comb(n, i) for i in range(min(only_family, only_twin) + 1)) / 2 ** n
    return min(1.0, 2 * tail)


def per_kind(fam: dict[Key, bool], twin: dict[Key, bool], kinds: list[str]) -> dict[str, Any]:
    """Per kind: how many pairs agree, and each side's success with its interval."""
    out = {}
    for kind in kinds:
        keys = [k for k in fam if k[1] == kind]
        only_family = sum(fam[k] and not twin[k] for k in keys)
        only_twin = sum(twin[k] and not fam[k] for k in keys)
        out[kind] = {"pairs": len(keys), "equal": sum(fam[k] == twin[k] for k in keys),
                     "only_family": only_family, "only_twin": only_twin,
                     "mcnemar_p": mcnemar_p(only_family, only_twin),
                     "family": _rate(sum(fam[k] for k in keys), len(keys)),
                     "twin": _rate(sum(twin[k] for k in keys), len(keys))}
    return out


def parted(fam: dict[Key, bool], twin: dict[Key, bool]) -> list[dict[str, Any]]:
    """Every pair whose outcomes differ, in rig, kind, seed order."""
    return [{"rig": r, "kind": k, "seed": s, "family": fam[(r, k, s)], "twin": twin[(r, k, s)]}
            for (r, k, s) in sorted(fam) if fam[(r, k, s)] != twin[(r, k, s)]]


def _command(doc: dict[str, Any]) -> str:
    """The ``msd-bench rigs`` command that makes a run of these rigs, seeds and kinds."""
    rigs = doc["rigs_run"]
    fam = family_of(doc)
    return (f"msd-bench rigs {'' if fam == 'default' else f'--family {fam} '}--rigs {len(rigs)} "
            f"--first-rig {rigs[0]} --seeds {len(doc['learning_seeds'])} --agents {','.join(doc['agents'])}")


def pairing(family: dict[str, Any], twin: dict[str, Any]) -> dict[str, Any]:
    """The comparison document (without provenance)."""
    check_same_runs(family, twin)
    fam, tw = successes(family), successes(twin)
    differing = parted(fam, tw)
    return {"family": family_of(family), "rigs_run": family["rigs_run"],
            "learning_seeds": family["learning_seeds"], "agents": family["agents"],
            "pairs": len(fam), "equal": len(fam) - len(differing),
            "kinds": per_kind(fam, tw, list(family["agents"])), "parted": differing,
            "rigs_parted": sorted({d["rig"] for d in differing}),
            "runs": {"family": {"command": _command(family), "wall_seconds": family["sweep"]["wall_seconds"],
                                "workers": family["sweep"]["workers"]},
                     "twin": {"command": _command(twin), "wall_seconds": twin["sweep"]["wall_seconds"],
                              "workers": twin["sweep"]["workers"]}}}


def reproduces(twin: dict[str, Any], reference: dict[str, Any], name: str) -> dict[str, Any]:
    """Whether the twin run equals a committed run of the same rigs, run by run (success and SSE
    bit for bit): then the family's runs share the code the committed table was made with."""
    def runs(doc: dict[str, Any]) -> dict[Key, tuple[bool, Any]]:
        return {(int(r["rig"]), str(o["kind"]), int(o["seed"])): (bool(o["success"]), o.get("sse"))
                for r in doc["rigs"] for o in r["outcomes"]}
    mine, ref = runs(twin), runs(reference)
    if set(mine) != set(ref):
        raise Mismatch(f"{name} does not hold the twin run's (rig, kind, seed) outcomes")
    return {"reference": name, "runs": len(mine), "equal_success": sum(mine[k][0] == ref[k][0] for k in mine),
            "equal_sse": sum(mine[k][1] == ref[k][1] for k in mine)}


def ours(path: Path) -> bool:
    """Whether a file is a comparison this script wrote (the only kind it may replace)."""
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError):
        return False
    return isinstance(doc, dict) and str(doc.get("command", "")).startswith("python scripts/family_twins.py")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("family_run", type=Path, help="rigs.json of the family's run")
    p.add_argument("twin_run", type=Path, help="rigs.json of the default family's run of the same rigs")
    p.add_argument("--out", type=Path, required=True, help="the comparison JSON to write (atomically)")
    p.add_argument("--twin-reference", type=Path, default=None,
                   help="a committed rigs.json of the same default-family runs: says whether the twin run "
                        "reproduces it (success and SSE, run by run)")
    p.add_argument("--runs-at", default=None,
                   help="the commit both runs were made at, if not this checkout's (recorded as runs_commit)")
    args = p.parse_args(argv)
    if args.out.exists() and not ours(args.out):
        print(f"family_twins: {args.out} exists and is not a comparison this script wrote; "
              "not overwriting it", file=sys.stderr)
        return 2
    try:
        twin = load(args.twin_run)
        doc = pairing(load(args.family_run), twin)
        if args.twin_reference is not None:
            doc["twin_reproduces"] = reproduces(twin, load(args.twin_reference), str(args.twin_reference))
    except Mismatch as err:
        print(f"family_twins: {err}", file=sys.stderr)
        return 2
    ref = f" --twin-reference {args.twin_reference}" if args.twin_reference is not None else ""
    said = f"python scripts/family_twins.py {args.family_run} {args.twin_run}{ref} --out {args.out}"
    doc = {"command": said,
           "commit": commit(), "runs_commit": args.runs_at or commit(), "machine": machine(), **doc}
    write_text_atomic(args.out, json.dumps(doc, indent=1) + "\n")
    print(f"family_twins: {doc['equal']} of {doc['pairs']} runs equal to their twins -> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
