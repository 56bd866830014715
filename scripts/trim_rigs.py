"""A ``rigs.json`` made small enough to commit: each run's per-scenario cells left out.

A 100-rig x 4-seed x 8-kind run's ``rigs.json`` is about 3.5 MB, over the repository's 2 MiB per
file; the per-run scenario cells (``rigs[*].outcomes[*].scenarios``) are most of it, and every kind's
scenario cells pooled over all rigs (``kinds[*].scenarios``) stay, so every generated view renders
the same from the trimmed file. The file records that it was trimmed (``trimmed``) and, when the
source sits in its run directory, the options the sweep ran with (the manifest's ``config``, as
``run_config``), which ``rigs.json`` itself does not hold:

    python scripts/trim_rigs.py runs/rigs-heldout-100/rigs.json docs/results/rigs_heldout100.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from msd_bench.io.storage.atomic import write_text_atomic

DROPPED = "rigs[*].outcomes[*].scenarios"


def trimmed(doc: dict[str, Any], runs_of: list[str] | None = None) -> dict[str, Any]:
    """``doc`` without each run's scenario cells, saying so; with ``runs_of``, the runs of those kinds
    only (every kind's pooled row stays: a 100-rig sweep with the ceiling's rows is over 2 MiB even
    without the cells)."""
    rigs = [{**rig, "outcomes": [{k: v for k, v in o.items() if k != "scenarios"} for o in rig["outcomes"]
                                 if runs_of is None or o["kind"] in runs_of]}
            for rig in doc["rigs"]]
    note: dict[str, Any] = {"dropped": DROPPED}
    if runs_of is not None:
        note["runs_of"] = runs_of
    return {**doc, "rigs": rigs, "trimmed": note}


def run_config(source: Path) -> dict[str, Any] | None:
    """The options of the ``msd-bench rigs`` run that wrote ``source`` (its run directory's manifest), or
    None when the source is not in one."""
    try:
        manifest = json.loads((source.parent / "manifest.json").read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(manifest, dict) or manifest.get("command") != "rigs":
        return None
    config = manifest.get("config")
    return config if isinstance(config, dict) else None


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("source", type=Path, help="a rigs.json written by msd-bench rigs")
    p.add_argument("out", type=Path, help="where the trimmed copy goes (written atomically)")
    p.add_argument("--runs-of", default=None,
                   help="comma-separated kinds whose runs are kept per rig (default: every kind's)")
    args = p.parse_args(argv)
    try:
        doc = json.loads(args.source.read_text())
    except (OSError, ValueError) as exc:
        print(f"trim_rigs: error: {args.source}: {exc}", file=sys.stderr)
        return 2
    if doc.get("schema") != "msd-bench/rigs":
        print(f"trim_rigs: error: {args.source} is not a rigs.json (schema {doc.get('schema')!r})",
              file=sys.stderr)
        return 2
    runs_of = None if args.runs_of is None else [k.strip() for k in args.runs_of.split(",") if k.strip()]
    unknown = sorted(set(runs_of or []) - {k["kind"] for k in doc.get("kinds", [])})
    if unknown:
        print(f"trim_rigs: error: --runs-of {', '.join(unknown)}: not a kind of {args.source}",
              file=sys.stderr)
        return 2
    small = trimmed(doc, runs_of)
    config = run_config(args.source)
    if config is not None:
        small["run_config"] = config
    write_text_atomic(args.out, json.dumps(small, separators=(",", ":")) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
