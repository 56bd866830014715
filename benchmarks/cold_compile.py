"""Processes starting together on a cold kernel cache, with the compile lock and without it.

    python benchmarks/cold_compile.py [--processes 3] [--rounds 1] [--out FILE]

Each round starts ``--processes`` tiny ``msd-bench paper`` runs at once (identification, training,
validation, the report: most kernels), each on a fresh numba cache shared by the round's processes,
first with ``MSD_KERNEL_LOCK=0`` (numba's own compile: every process compiles every kernel it needs
before any has written the cache; the baseline), then with the lock (msd_bench/core/kernel_cache.py),
then once more on the lock's now-warm cache (what is left when nothing compiles). Prints one JSON
object: each mode's wall time (the slowest process) and summed process time, and
``locked_over_unlocked``, the ratio of wall times (below 1: the lock saves). No floor.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
TINY = ["paper", "--seeds", "1", "--id-seeds", "1", "--episodes", "2", "--steps", "100",
        "--validation-steps", "200", "--samples", "300", "--agents", "glm,plm,nlarx-improved,glm+improved",
        "--no-figures", "--workers", "1"]


def one_round(processes: int, cache: Path, lock: bool, scratch: Path) -> dict[str, float]:
    """``processes`` tiny paper runs started together; their wall time and summed process time."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "MSD_KERNEL_LOCK": "1" if lock else "0"}
    start = time.perf_counter()
    before = os.times()
    procs = [subprocess.Popen([sys.executable, "-m", "msd_bench.cli", *TINY, "--out", str(scratch / f"r{i}")],
                              cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
             for i in range(processes)]
    errors = [p.communicate()[1] for p in procs]
    wall = time.perf_counter() - start
    after = os.times()
    failed = [e[-400:] for p, e in zip(procs, errors, strict=True) if p.returncode != 0]
    if failed:
        raise SystemExit(f"cold_compile.py: a paper run failed: {failed[0]}")
    cpu = (after.children_user - before.children_user) + (after.children_system - before.children_system)
    return {"wall_s": round(wall, 2), "process_s": round(cpu, 2)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--processes", type=int, default=3)
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    rounds = []
    for _ in range(args.rounds):
        with tempfile.TemporaryDirectory() as tmp:
            root = Path(tmp)
            unlocked = one_round(args.processes, root / "cache-unlocked", False, root / "u")
            locked = one_round(args.processes, root / "cache-locked", True, root / "l")
            warm = one_round(args.processes, root / "cache-locked", True, root / "w")
            rounds.append({"unlocked": unlocked, "locked": locked, "warm": warm,
                           "locked_over_unlocked": round(locked["wall_s"] / unlocked["wall_s"], 3)})
    result = {"benchmark": "cold_compile", "processes": args.processes, "command": TINY, "rounds": rounds,
              "cpu": platform.processor() or platform.machine(), "cores": os.cpu_count()}
    text = json.dumps(result, indent=2)
    if args.out is not None:
        args.out.write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
