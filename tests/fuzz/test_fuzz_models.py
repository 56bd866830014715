"""Fuzz: model JSON, read and stepped by the compiled kernels, in a forked child so a crash shows.

Property: whatever the document, ``load_model`` then 200 steps of the kernel
end cleanly (positions on the stroke) or with one MsdBenchError line; never a
signal death (the issue's NLARX file segfaulted), a hang (a 20 s alarm in the
child) or an allocation of more than 512 MiB beyond what the child inherited
(``RLIMIT_AS``). Each case runs in ``os.fork()``: cheap, because the kernels
were compiled in the parent before the first case.

Documents are generated near the valid space (each kind's pinned fit with its
vector mutated: wrong lengths, NaN, inf, huge, negative or zero values,
NLARX unit counts around and far from the right one, wrong-typed fields) and
far from it (random JSON as the document or as one of its fields).
"""

from __future__ import annotations

import faulthandler
import json
import math
import os
import resource
import signal
import sys
import tempfile
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from msd_bench.core.errors import MsdBenchError
from msd_bench.core.identification.model_kinds import KERNEL_LAYOUTS
from msd_bench.io.storage.artifacts import load_model
from tests.fuzz.json_values import JSON, nested

PINNED = Path(__file__).resolve().parents[1] / "data" / "pinned"
BASES = {name: json.loads((PINNED / f"{name}.json").read_text())
         for name in ("glm", "plm", "nlarx-paper", "nlarx-improved", "greybox")}
STEPS = 200
HEADROOM = 512 << 20
"""The child may map at most this much beyond its inherited address space (RLIMIT_AS)."""
HANG_S = 20
"""Wall-clock guard of one case (a load and 200 steps take milliseconds)."""

CLEAN, REFUSED = 0, 3
"""Child exit codes: stepped cleanly; refused with one MsdBenchError line. Anything else fails."""
CODES = {4: "another exception", 5: "MemoryError: allocation beyond the bound",
         6: "output off the stroke", 7: "error message of several lines"}


@pytest.fixture(scope="module", autouse=True)
def compiled() -> None:
    """Compile every kernel in the parent, so a forked child only runs them."""
    for name in BASES:
        load_model(PINNED / f"{name}.json").simulate(np.ones(3))


def _load_and_step(path: str, forces: list[float]) -> int:
    """What the forked child does: load, step, classify. Returns its exit code."""
    try:
        model = load_model(Path(path))
        x = model.simulate(np.resize(np.asarray(forces, dtype=float), STEPS))
        return CLEAN if np.all(np.abs(x) <= model.x_max) else 6
    except MsdBenchError as exc:
        return REFUSED if "\n" not in str(exc) else 7
    except MemoryError:
        return 5
    except Exception:  # the property's verdict: any other exception is the failure reported
        traceback.print_exc()
        return 4


Child = Callable[[str, list[float]], int]


def run_forked(doc: Any, forces: list[float], child: Child = _load_and_step, hang_s: int = HANG_S) -> str:
    """Run one case in a forked child; ``"clean"``, ``"refused"``, or what went wrong."""
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as fh:
        fh.write(doc if isinstance(doc, str) else json.dumps(doc, allow_nan=True))
    try:
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:  # the child: never returns into pytest
            code = 4
            try:
                faulthandler.disable()  # a crash is the verdict, reported by the parent, not a dump
                vm = int(Path("/proc/self/status").read_text().split("VmSize:")[1].split()[0]) << 10
                resource.setrlimit(resource.RLIMIT_AS, (vm + HEADROOM, resource.RLIM_INFINITY))
                signal.alarm(hang_s)
                code = child(fh.name, forces)
            finally:
                os._exit(code)
        _, status = os.waitpid(pid, 0)
    finally:
        os.unlink(fh.name)
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        return "hang (alarm)" if sig == signal.SIGALRM else f"killed by {signal.Signals(sig).name}"
    code = os.WEXITSTATUS(status)
    return {CLEAN: "clean", REFUSED: "refused"}.get(code, CODES.get(code, f"exit {code}"))


SPECIAL = st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -0.0, -1.0, 1e-300, 1e300, -1e300, 5e7,
                           1e9, 1e9 + 1, 2.0**53, 0.5, 1024.0, 1025.0, -5.0])
NUMBER = st.one_of(SPECIAL, st.floats(allow_nan=True, allow_infinity=True),
                   st.integers(min_value=-(10**20), max_value=10**20))
UNIT_COUNTS = [-1, 0, 1, 9, 10, 11, 1024, 1025, 10.5, math.nan, 1e5, 1e6, 5e7, 2**31 - 1, 2**40, 1e300]
"""NLARX unit counts around the right one and far from it (5e7 read the heap until it segfaulted)."""
FORCES = st.lists(st.one_of(st.floats(-20, 20), st.sampled_from([10.0, -10.0, 1e9])), min_size=1, max_size=8)


@st.composite
def mutated_params(draw: st.DrawFn, params: list[float], kind: str) -> list[Any]:
    """The kind's honest vector with a few slots set to special values, or cut, or extended."""
    p: list[Any] = list(params)
    for _ in range(draw(st.integers(0, 3))):
        p[draw(st.integers(0, len(p) - 1))] = draw(NUMBER)
    hows = ["keep", "cut", "extend", "type"] + ["units"] * (4 if kind == "nlarx" else 0)
    how = draw(st.sampled_from(hows))
    if how == "cut":
        p = p[: draw(st.integers(0, len(p)))]
    elif how == "extend":
        p += draw(st.lists(NUMBER, min_size=1, max_size=12))
    elif how == "units" and kind == "nlarx":
        p[1] = draw(st.one_of(st.sampled_from(UNIT_COUNTS), st.integers(-5, 2000), st.integers(2000, 2**40)))
        if draw(st.booleans()) and isinstance(p[1], int) and 0 < p[1] <= 1100:  # length made consistent
            p = (p[:9] + p[9:15] * p[1])[: 9 + 6 * p[1]]
    elif how == "type":
        p[draw(st.integers(0, len(p) - 1))] = draw(JSON)
    return p


@st.composite
def near_documents(draw: st.DrawFn) -> dict[str, Any]:
    """A pinned model file of some kind with its vector and maybe one other field mutated."""
    base = dict(BASES[draw(st.sampled_from(sorted(BASES)))])
    base["params"] = draw(mutated_params(base["params"], base["kind"]))
    if draw(st.booleans()):
        field = draw(st.sampled_from(["dt", "force_limit", "kind", "name", "info", "schema_version"]))
        base[field] = draw(st.one_of(NUMBER, JSON, st.sampled_from(list(KERNEL_LAYOUTS))))
    return base


@st.composite
def far_documents(draw: st.DrawFn) -> Any:
    """Random JSON: as the whole file, as a field of a schema-valid header, or deeply nested."""
    how = draw(st.sampled_from(["whole", "field", "deep", "text"]))
    if how == "whole":
        return draw(JSON)
    if how == "deep":
        depth = draw(st.integers(1, 5000))
        return nested('{"schema": "msd-bench/model", "schema_version": 1, "params": ', depth)
    if how == "text":
        return draw(st.text(max_size=200))
    kind = draw(st.sampled_from(list(KERNEL_LAYOUTS)))
    doc = {"schema": "msd-bench/model", "schema_version": 1, "kind": kind}
    doc.update(draw(st.dictionaries(st.sampled_from(["params", "name", "info", "dt", "force_limit"]), JSON)))
    return doc


@given(doc=near_documents(), forces=FORCES)
def test_a_mutated_model_steps_cleanly_or_is_refused(doc: dict[str, Any], forces: list[float]) -> None:
    assert run_forked(doc, forces) in ("clean", "refused")


@given(doc=far_documents(), forces=FORCES)
def test_random_json_as_a_model_is_refused_cleanly(doc: Any, forces: list[float]) -> None:
    assert run_forked(doc, forces) in ("clean", "refused")


def test_the_issue_reproductions_are_refused_not_crashed() -> None:
    head = {"schema": "msd-bench/model", "schema_version": 1, "name": "x", "info": {}}
    nlarx = {**head, "kind": "nlarx", "params": [1, 5e7, 1, 1, 0, 0, 0, 0, 0]}
    linear = {**head, "kind": "linear", "params": [0.5]}
    assert run_forked(nlarx, [1.0]) == "refused" and run_forked(linear, [1.0]) == "refused"
    assert run_forked(BASES["nlarx-paper"], [1.0]) == "clean"


def _segfault(path: str, forces: list[float]) -> int:
    os.kill(os.getpid(), signal.SIGSEGV)
    return CLEAN


def _hang(path: str, forces: list[float]) -> int:
    signal.pause()
    return CLEAN


def _allocate(path: str, forces: list[float]) -> int:
    try:
        np.ones(2 * HEADROOM // 8)  # twice the headroom
    except MemoryError:
        return 5
    return CLEAN


@pytest.mark.parametrize(("child", "verdict"), [
    (_segfault, "killed by SIGSEGV"), (_hang, "hang (alarm)"), (_allocate, CODES[5])])
def test_the_harness_sees_a_crash_a_hang_and_a_big_allocation(child: Child, verdict: str) -> None:
    """The harness itself: what the old kernel did to the issue's file would be reported, not hidden."""
    assert run_forked({}, [1.0], child, hang_s=1) == verdict
