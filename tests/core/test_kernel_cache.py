"""Processes that need one kernel together compile it once; the others load it from numba's cache
(msd_bench/core/kernel_cache.py)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from msd_bench.core import kernel_cache
from msd_bench.core.learning import rng

REPO = Path(__file__).resolve().parents[2]
CHILD = """
import json, sys
import numpy as np
from msd_bench.core.learning import rng
print("ready", flush=True)
sys.stdin.readline()  # every process waits here, so they all call the cold kernel together
out = rng.split(np.uint64(12345))
stats = rng.split.stats
print(json.dumps({"out": [int(v) for v in out], "misses": sum(stats.cache_misses.values()),
                  "hits": sum(stats.cache_hits.values())}), flush=True)
"""


def _started(cache_dir: Path) -> subprocess.Popen[str]:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache_dir)}
    proc = subprocess.Popen([sys.executable, "-c", CHILD], cwd=REPO, env=env, text=True,
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "ready"
    return proc


def test_processes_starting_together_on_a_cold_cache_compile_a_kernel_once(tmp_path: Path) -> None:
    procs = [_started(tmp_path / "numba") for _ in range(3)]
    for proc in procs:  # released within a few milliseconds of each other
        assert proc.stdin is not None
        proc.stdin.write("go\n")
        proc.stdin.flush()
    reports = [json.loads(proc.communicate(timeout=300)[0]) for proc in procs]
    assert all(proc.returncode == 0 for proc in procs)
    assert sum(r["misses"] for r in reports) == 1, reports
    assert sum(r["hits"] for r in reports) == 2, reports
    assert len({tuple(r["out"]) for r in reports}) == 1
    assert list(tmp_path.rglob("rng.split-*.nbi.lock")), "the lock lies beside the kernel's cache index"


def _not_ours(x: float) -> float:
    return x + 1.0


def test_a_kernel_is_locked_only_if_it_is_ours_and_cached() -> None:
    rng.split(np.uint64(1))
    path = kernel_cache.lock_path(rng.split)
    assert path is not None and path.endswith(".nbi.lock")
    assert kernel_cache.lock_path(kernel_cache.numba.njit(cache=True)(_not_ours)) is None


def test_a_nested_compile_of_a_held_kernel_does_not_wait_on_itself(tmp_path: Path) -> None:
    path = str(tmp_path / "k.lock")
    with kernel_cache.compiling(path), kernel_cache.compiling(path):
        pass
    with kernel_cache.compiling(path):  # released: taken again at once
        pass


def test_an_unwritable_lock_place_compiles_unlocked(tmp_path: Path) -> None:
    ran = False
    with kernel_cache.compiling(str(tmp_path / "missing" / "k.lock")):
        ran = True
    assert ran


@pytest.mark.parametrize("options", [{}, {"nogil": True}])
def test_kernel_is_numba_njit_with_its_cache(options: dict[str, bool]) -> None:
    def add(x: float) -> float:
        return x + 1.0

    compiled = kernel_cache.kernel(**options)(add) if options else kernel_cache.kernel(add)
    assert compiled.py_func is add and type(compiled._cache).__name__ == "FunctionCache"
    assert compiled.targetoptions.get("nogil", False) == bool(options)
