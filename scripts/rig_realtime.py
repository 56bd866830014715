"""The real-time subset of the rig population: the same held-out rigs in real time and in-process.

Why: ``msd-bench rigs`` runs the method on each rig in-process, through the
rig's compiled transition. A rig owner runs it in real time instead:
``launch_scripts/rig.py -p population_seed:=N`` serves the rig, ``bench.py
--plant-ns`` records, identifies, trains and validates over ROS. This script
does both for each of a few held-out rigs, at one reduced size (:data:`SIZE`),
and writes one document that sets them side by side: the models' simulation
fit on the measured validation record, and each kind's nominal successes
judged on the measured position (the only one a real-time rig reports; the
in-process judgement on the true position is beside it). A real-time run also
says whether a supervisor guarded its validation runs (its report's ``run``).

    .venv/bin/python scripts/rig_realtime.py --out docs/results/rig_realtime.json \
        [--first-rig 1000] [--rigs 3] [--agents plm+robust,greybox+robust] [--work DIR]

``--out`` must not exist; it is written atomically at the end. ``--work`` (a
new directory; a temporary one by default) keeps both runs' directories.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from msd_bench.core.errors import ConfigError, MsdBenchError  # noqa: E402
from msd_bench.core.rigs.population import HELD_OUT_RIGS, check_seed, draw  # noqa: E402
from msd_bench.graph import launch  # noqa: E402
from msd_bench.graph.domains import claim_domain  # noqa: E402
from msd_bench.io.storage.atomic import write_text_atomic  # noqa: E402

sys.path.insert(0, str(REPO / "scripts"))
from make_results import provenance  # noqa: E402

SIZE = ("--samples", "600", "--val-samples", "400", "--seeds", "2", "--validation-steps", "1000")
"""The reduced size of both runs: the README's short records, two learning seeds, 10 s validation runs
(the in-process sweep's default is 4 seeds and the paper's records)."""
NODE_SCENARIOS = ("--node-scenarios", "setpoint=0.5")
"""The real-time run's scenarios beyond nominal: one set-point (the default set holds a disturbance at
15 s, after a 10 s run ends). The comparison reads the nominal runs only."""
DEFAULT_AGENTS = "plm+robust,greybox+robust"
BENCH_TIMEOUT_S = 3600.0
"""A real-time run at :data:`SIZE` spends about 5 min waiting for real time; an hour means it hung."""


def parse(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--first-rig", type=int, default=HELD_OUT_RIGS.start)
    p.add_argument("--rigs", type=int, default=3)
    p.add_argument("--agents", default=DEFAULT_AGENTS)
    p.add_argument("--work", type=Path, default=None, help="keep both runs here (a new directory)")
    p.add_argument("--out", type=Path, required=True)
    args = p.parse_args(argv)
    if args.out.exists():
        raise ConfigError(f"--out {args.out} exists: this script never overwrites a result")
    if args.work is not None and args.work.exists():
        raise ConfigError(f"--work {args.work} exists: give a new directory")
    if not 1 <= args.rigs <= 20:
        raise ConfigError(f"--rigs must be between 1 and 20, got {args.rigs}")
    first = check_seed(args.first_rig)
    if first not in HELD_OUT_RIGS or first + args.rigs - 1 not in HELD_OUT_RIGS:
        raise ConfigError(f"--first-rig {first}: report held-out rigs only ({HELD_OUT_RIGS.start} and up)")
    return args


def real_time(rig: int, agents: str, out: Path) -> dict[str, Any]:
    """``rig.py`` serving population member ``rig``; ``bench.py --plant-ns`` against it."""
    domain, lock = claim_domain(None)
    ns = f"/pop{rig}"
    started = time.monotonic()
    try:
        with launch.process_group(domain) as procs:
            node = procs.start("rig.py", ["-p", f"population_seed:={rig}", "-r", f"__ns:={ns}"], name="rig")
            node.wait_for_line(r"ready", timeout=120.0)
            argv = [sys.executable, "launch_scripts/bench.py", "--plant-ns", ns, "--out", str(out),
                    *SIZE, *NODE_SCENARIOS, "--agents", agents]
            proc = subprocess.run(argv, cwd=REPO, capture_output=True, text=True, env=launch.ros_env(domain),
                                  timeout=BENCH_TIMEOUT_S)
    finally:
        lock.close()
    seconds = round(time.monotonic() - started, 1)
    if proc.returncode != 0:
        last = proc.stderr.strip().splitlines()[-1:] or ["(no output)"]
        return {"completed": False, "exit": proc.returncode, "error": last[0], "seconds": seconds}
    table = json.loads((out / "report" / "table1.json").read_text())
    fits = json.loads((out / "models" / "fits.json").read_text())
    return {"completed": True, "seconds": seconds, "supervisor": table["run"].get("supervisor"),
            "drive_measured": _json_or_none(out / "models" / "drive.json", "drive"),
            "drive_told": {a["kind"]: _json_or_none(out / "agents" / a["kind"] / "result.json", "drive_told")
                           for a in table["agents"]},
            "fits": {kind: f.get("sim_fit") for kind, f in fits.items()},
            "kinds": {a["kind"]: {"n": a["n"], "n_success": a["n_success"]} for a in table["agents"]}}


def _json_or_none(path: Path, key: str) -> Any:
    """``path``'s ``key`` (None when the file is absent): what a run wrote about the drive."""
    return json.loads(path.read_text()).get(key) if path.is_file() else None


def in_process(rig: int, agents: str, out: Path) -> dict[str, Any]:
    """``msd-bench rigs`` on the same one rig, at the same size, with the robust agent told the drive
    measured from the rig's broad record, as ``bench.py --plant-ns`` tells it from its own bags
    (docs/rigs.md §The robust agent told the drive's delay)."""
    argv = [sys.executable, "-m", "msd_bench.cli", "rigs", "--first-rig", str(rig), "--rigs", "1", *SIZE,
            "--agents", agents, "--robust-actuator", "measured", "--out", str(out)]
    started = time.monotonic()
    proc = subprocess.run(argv, cwd=REPO, capture_output=True, text=True, timeout=BENCH_TIMEOUT_S)
    seconds = round(time.monotonic() - started, 1)
    if proc.returncode != 0:
        last = proc.stderr.strip().splitlines()[-1:] or ["(no output)"]
        return {"completed": False, "exit": proc.returncode, "error": last[0], "seconds": seconds}
    doc = json.loads((out / "rigs.json").read_text())
    (entry,) = doc["rigs"]
    kinds: dict[str, dict[str, int]] = {}
    for o in entry["outcomes"]:
        k = kinds.setdefault(o["kind"], {"n": 0, "n_success": 0, "n_success_true": 0})
        k["n"] += 1
        k["n_success"] += int(bool(o.get("success_measured")))
        k["n_success_true"] += int(bool(o.get("success")))
    fits = {kind: f.get("fit_sim_percent") for kind, f in entry["fits"].items()}
    return {"completed": True, "seconds": seconds, "drive": entry["actuator"], "fits": fits, "kinds": kinds}


def main(argv: list[str] | None = None) -> int:
    try:
        args = parse(argv)
        doc: dict[str, Any] = {**provenance("rig_realtime.py", argv),
                               "load_at_start": round(os.getloadavg()[0], 2), "size": list(SIZE),
                               "agents": args.agents.split(","), "rigs": []}
        started = time.monotonic()
        with tempfile.TemporaryDirectory(prefix="rig-realtime-") as tmp:
            work = args.work or Path(tmp)
            work.mkdir(parents=True, exist_ok=args.work is None)
            for rig in range(args.first_rig, args.first_rig + args.rigs):
                print(f"rig {rig}: {draw(rig).line()}", file=sys.stderr, flush=True)
                rt = real_time(rig, args.agents, work / f"rig{rig}" / "realtime")
                print(f"rig {rig}: real time {json.dumps(rt)}", file=sys.stderr, flush=True)
                ip = in_process(rig, args.agents, work / f"rig{rig}" / "inprocess")
                print(f"rig {rig}: in-process {json.dumps(ip)}", file=sys.stderr, flush=True)
                doc["rigs"].append({"rig": rig, "line": draw(rig).line(), "real_time": rt, "in_process": ip})
        doc["seconds"] = round(time.monotonic() - started, 1)
        write_text_atomic(args.out, json.dumps(doc, indent=2) + "\n", exclusive=True)
    except MsdBenchError as err:
        print(f"rig_realtime: error: {err}", file=sys.stderr)
        return 2
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
