"""No loop steps a plant outside the one loop module (issue 34 item 1).

Why a test: a controller's closed loop written again next to its design (the
plant step, the actuator queue, the noise and quantisation) drifts from the
others, and two evaluators of one design can then disagree. The rule: outside
:data:`LOOP_MODULES`, no function calls a step kernel (:data:`KERNELS`, or
``.step`` on a rig or a model) inside a ``for``/``while`` loop or a comprehension.

:data:`EXCEPTIONS` names every function that still does, each with why. Two kinds:

- ``FIT``: the function steps a *model* open loop or one step ahead, to fit or
  to predict (identification, the model's own rollout, an MPC's plan, a
  Q-learner's model step) — not a controller against the plant under test;
- ``TODO``: a closed loop not yet folded into the one loop (none is left: every
  design's rollout, the rig runs and the adversaries run in it). The list may
  only shrink (a stale entry fails too).

The scan is proven on planted cases, as tests/designs/test_no_switches.py proves its own.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from tests.syntax import parse_source

ROOT = Path(__file__).resolve().parents[2]

KERNELS = frozenset({
    "plant_step", "plant_step_loaded", "plant_step_batch", "advance", "advance_loaded", "advance_rig",
    "_advance", "rk4_advance", "rk4_motion", "_rig_step", "_arx_step", "transition", "plant_side"})
"""The step kernels: physics.kernels' plant and model steps, the rig's and the baselines' plant half."""

STEPPERS = ("rig", "model")
"""``<x>.step(...)`` is a plant step when ``x``'s name holds one of these (``Rig``, ``StepModel``)."""

LOOP_MODULES = frozenset({"msd_bench/core/evaluation/closed_loop.py"})
"""The one loop module: the compiled closed loops every design's rollout is to run."""

FIT = "steps a model to fit or predict, not a controller against the plant under test"
TODO = "issue 34 item 1: a closed loop of its own, not yet folded into the one loop"

EXCEPTIONS: dict[str, str] = {
    # the model's own simulation and one-step prediction (physics.kernels), for fitting and checks
    "msd_bench/core/physics/kernels.py::plant_step_batch": FIT + " (independent plants, element-wise)",
    "msd_bench/core/physics/kernels.py::rk4_simulate": FIT,
    "msd_bench/core/physics/kernels.py::rollout": FIT + " (open-loop rollout of a model)",
    "msd_bench/core/physics/kernels.py::_rig_rollout": FIT,
    "msd_bench/core/physics/kernels.py::simulate_plant": FIT,
    "msd_bench/core/physics/kernels.py::one_step": FIT + " (one-step-ahead prediction)",
    "msd_bench/core/physics/kernels.py::rig_one_step": FIT + " (one-step-ahead prediction)",
    # identification: predictions of a candidate model on recorded data
    "msd_bench/core/identification/diagnostics.py::k_step": FIT + " (k-step-ahead prediction)",
    "msd_bench/core/identification/greybox.py::one_step": FIT,
    "msd_bench/core/identification/greybox_rk4.py::one_step": FIT,
    "msd_bench/core/identification/greybox_rig.py::record_through_rig": FIT + " (records excitation data "
    "through a rig, open loop)",
    "msd_bench/core/rigs/rig_play.py::play": FIT + " (plays a record's signal, open loop or under the stated "
    "hold loop: an excitation, no controller under test; its rests step through the same helper)",
    # a controller's internal model: prediction inside the decision, not the plant under test
    "msd_bench/core/baselines/mpc.py::_hold_tail": FIT + " (the MPC's prediction model)",
    "msd_bench/core/baselines/mpc.py::plan": FIT + " (the MPC's prediction model)",
    # Q-learning: the learner steps the model it learns on (a surrogate, or the plant's own model for the
    # on-plant learners), exploring ε-greedily and updating its table every step; the evaluation of
    # what it learned runs in the one loop (closed_loop.greedy_under)
    "msd_bench/core/learning/q_kernels.py::q_episode": FIT + " (Q-learning episode on a model)",
    "msd_bench/core/learning/q_kernels.py::learn_one": FIT + " (Q-learning / Dyna-Q episodes on a model)",
    "msd_bench/core/learning/q_kernels.py::learn_observed": FIT + " (Q-learning on a model under "
    "training-time noise and delay drawn from the agent's own stream)",
}


def _called(func: ast.expr) -> tuple[str, str]:
    """(name called, name of what it is called on) for ``f(...)`` / ``x.f(...)`` ("" where none)."""
    if isinstance(func, ast.Name):
        return func.id, ""
    if isinstance(func, ast.Attribute):
        owner = func.value
        if isinstance(owner, ast.Name):
            return func.attr, owner.id
        return func.attr, owner.attr if isinstance(owner, ast.Attribute) else ""
    return "", ""


def _is_step(call: ast.Call) -> bool:
    name, on = _called(call.func)
    return name in KERNELS or (name == "step" and any(s in on.lower() for s in STEPPERS))


def stepping_loops(tree: ast.AST) -> list[tuple[str, int, str]]:
    """(enclosing function, line, kernel) of every step-kernel call inside a loop of ``tree``.

    A loop is a ``for``, a ``while`` or a comprehension; a function defined
    inside a loop starts afresh (its body is not the loop's).
    """
    found: list[tuple[str, int, str]] = []

    def visit(node: ast.AST, fn: str, in_loop: bool) -> None:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            fn, in_loop = node.name, False
        if in_loop and isinstance(node, ast.Call) and _is_step(node):
            found.append((fn, node.lineno, _called(node.func)[0]))
        loop = isinstance(node, ast.For | ast.AsyncFor | ast.While | ast.ListComp | ast.SetComp
                          | ast.DictComp | ast.GeneratorExp)
        for child in ast.iter_child_nodes(node):
            visit(child, fn, in_loop or loop)

    visit(tree, "<module>", False)
    return found


def scan(root: Path = ROOT) -> dict[str, list[str]]:
    """``path::function`` -> the step calls in its loops, for every product module but the loop module."""
    hits: dict[str, list[str]] = {}
    for path in sorted((root / "msd_bench").rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        if rel in LOOP_MODULES:
            continue
        for fn, line, kernel in stepping_loops(parse_source(path.read_text(), rel)):
            hits.setdefault(f"{rel}::{fn}", []).append(f"{rel}:{line}: {kernel}")
    return hits


def test_the_scan_finds_each_kind_of_stepping_loop() -> None:
    planted = (
        "def a(plant, xs):\n    for x in xs:\n        plant_step(plant, x, 0.0, 1.0)\n"
        "def b(m, s):\n    while True:\n        kernels.advance(m, s, 0.0)\n"
        "def c(rig, us):\n    return [rig.step(u) for u in us]\n"
        "def d(self, us):\n    for u in us:\n        self.model.step(u)\n"
        "def e(m, s):\n    for _ in range(3):\n        def inner():\n            return advance(m, s, 0.0)\n"
        "def f(m, s, opt):\n    advance(m, s, 0.0)\n    for _ in range(3):\n        opt.step()\n")
    assert stepping_loops(parse_source(planted)) == [
        ("a", 3, "plant_step"), ("b", 6, "advance"), ("c", 8, "step"), ("d", 11, "step")]


def test_a_planted_loop_outside_the_loop_module_fails_the_check(tmp_path: Path) -> None:
    pkg = tmp_path / "msd_bench" / "core" / "evaluation"
    pkg.mkdir(parents=True)
    (pkg / "closed_loop.py").write_text("def ok(m, s):\n    for _ in range(2):\n        advance(m, s, 0.0)\n")
    (pkg / "robustness.py").write_text("def again(m, s):\n    for _ in range(2):\n        transition(m, s)\n")
    assert scan(tmp_path) == {"msd_bench/core/evaluation/robustness.py::again":
                      ["msd_bench/core/evaluation/robustness.py:3: transition"]}


@pytest.fixture(scope="module")
def found() -> dict[str, list[str]]:
    """The product's scan, once for both checks below."""
    return scan()


def test_no_loop_steps_a_plant_outside_the_loop_module_but_the_named_exceptions(
        found: dict[str, list[str]]) -> None:
    new = sorted(set(found) - set(EXCEPTIONS))
    assert not new, "step kernels in loops outside the loop module:\n" + "\n".join(
        line for key in new for line in found[key])


def test_every_exception_is_still_needed(found: dict[str, list[str]]) -> None:
    stale = sorted(set(EXCEPTIONS) - set(found))
    assert not stale, "exceptions that no longer step in a loop (drop them):\n" + "\n".join(stale)


def test_no_closed_loop_is_left_to_fold() -> None:
    """Item 1 done: every exception left steps a model to fit, predict or learn (the ratchet is at zero)."""
    assert not [key for key, why in EXCEPTIONS.items() if why.startswith(TODO)]
