"""docs/design.md's lists agree with the code: layers, nodes, designs, model kinds, faces, tasks, commands.

Why a test: the design page drifted from the code in seven places before
(issue 31) — a run-directory task list from before the tasks existed, designs
and nodes missing, a command left out. Each list on the page is a table (or,
for the layers, the layout block) that this test parses and compares with the
registry it describes: the model kinds with ``MODEL_KINDS``, the designs with
the design registry, the faces with ``msd_msgs_py.interface``, the nodes with
``launch_scripts/``, the commands with ``cli.py``'s parser, the run tasks with
the task lists the commands build. Each checker returns its problems as lines;
the last tests plant a stale entry in (and drop a real one from) every list and
prove the checker names it, as tests/designs/test_no_switches.py proves its scan.
"""

from __future__ import annotations

import argparse
import functools
import importlib
import re
from collections.abc import Callable
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "design.md"
_CODE = re.compile(r"`([^`]+)`")


def table(text: str, header: tuple[str, ...]) -> list[list[str]]:
    """The body rows (cells stripped) of the one Markdown table whose header row is ``header``."""
    lines = text.splitlines()
    want = "| " + " | ".join(header) + " |"
    starts = [i for i, line in enumerate(lines) if line.strip() == want]
    assert len(starts) == 1, f"docs/design.md has {len(starts)} tables headed {want!r}"
    rows = []
    for line in lines[starts[0] + 2:]:
        if not line.strip().startswith("|"):
            break
        rows.append([c.strip() for c in line.strip().strip("|").split("|")])
    return rows


def code(cell: str) -> str:
    """The first ``code`` span of a cell (a cell without one is returned as it is)."""
    m = _CODE.search(cell)
    return m.group(1) if m else cell


def compare(what: str, page: list[str], code_side: list[str], ordered: bool = True) -> list[str]:
    """Lines naming every entry the page has and the code lacks, and the other way round."""
    problems = [f"{what}: {x!r} is on the page but not in the code" for x in page if x not in code_side]
    problems += [f"{what}: {x!r} is in the code but not on the page" for x in code_side if x not in page]
    if not problems and ordered and page != code_side:
        problems.append(f"{what}: the page's order {page} is not the code's {code_side}")
    return problems


# --- the checkers -------------------------------------------------------------------------------

def check_layers(text: str) -> list[str]:
    """Every package of msd_bench/ is in §Layers' layout block, and every folder the block names exists."""
    block = text.split("## Layers", 1)[1].split("```", 2)[1]
    named = sorted({m.rstrip("/") for m in re.findall(r"^(msd_bench/[\w/]*/)\s", block, re.M)})
    packages = sorted(str(p.parent.relative_to(ROOT)) for p in (ROOT / "msd_bench").rglob("__init__.py")
                      if "__pycache__" not in p.parts and p.parent != ROOT / "msd_bench")
    return compare("layers", named, packages, ordered=False)


def check_nodes(text: str) -> list[str]:
    """§Nodes lists one row per node's launch script (bench.py is the main job, not a node)."""
    cells = [r[0] for r in table(text, ("node (launch script)", "does"))]
    found = [re.search(r"\(`(\w+\.py)`\)", c) for c in cells]
    page = [m.group(1) if m is not None else c for m, c in zip(found, cells, strict=True)]
    scripts = sorted(p.name for p in (ROOT / "launch_scripts").glob("*.py")
                     if not p.name.startswith("_") and p.name != "bench.py")
    return compare("nodes", sorted(page), scripts, ordered=False)


def check_designs(text: str) -> list[str]:
    """§Controllers' table: every registered design in report order, each in the module that defines it."""
    from msd_bench.designs import registry

    rows = table(text, ("design", "module", "what it is"))
    problems = compare("designs", [code(r[0]) for r in rows], list(registry.DESIGNS))
    home = {d.name: "designs/" + module.rsplit(".", 1)[1] + ".py"
            for module, attr in registry._BUILTIN for d in getattr(importlib.import_module(module), attr)}
    problems += [f"designs: {code(r[0])!r} is said to live in {code(r[1])}, not {home[code(r[0])]}"
                 for r in rows if code(r[0]) in home and code(r[1]) != home[code(r[0])]]
    return problems


def check_model_kinds(text: str) -> list[str]:
    """§Model kinds: every entry of MODEL_KINDS with its label, kernel, training record and figure."""
    from msd_bench.core.identification.model_kinds import MODEL_KINDS

    rows = table(text, ("kind", "label", "kernel", "trains on", "figure"))
    problems = compare("model kinds", [code(r[0]) for r in rows], list(MODEL_KINDS))
    for r in rows:
        k = MODEL_KINDS.get(code(r[0]))
        facts = (k.label, k.kernel, k.records, k.figure) if k is not None else ()
        if k is not None and (r[1], code(r[2]), code(r[3]), code(r[4])) != facts:
            problems.append(f"model kinds: {k.name!r} on the page is {r[1:]}, in the code "
                            f"{[k.label, k.kernel, k.records, k.figure]}")
    return problems


def check_faces(text: str) -> list[str]:
    """§Contract's faces: every face with its command topic and type, position, reset and effort default."""
    from msd_msgs_py import interface

    rows = table(text, ("face", "commands on", "command type", "`position`", "`reset`", "effort (default)"))
    problems = compare("faces", [code(r[0]) for r in rows], list(interface.FACES))
    for r in rows:
        if code(r[0]) not in interface.FACES:
            continue
        face = interface.make(code(r[0]))
        actual = [face.command.name.replace(face.controller, "<controller>") if face.controller
                  else face.command.name, face.command.ros_type, "yes" if face.position else "no",
                  "yes" if face.reset else "no", face.effort]
        shown = [code(r[1]), code(r[2]), r[3], r[4], code(r[5])]
        if shown != actual:
            problems.append(f"faces: {code(r[0])!r} on the page is {shown}, in the code {actual}")
    return problems


def _parse(*argv: str) -> argparse.Namespace:
    from msd_bench.cli import build_parser

    return build_parser().parse_args(list(argv))


def code_tasks() -> dict[str, list[str]]:
    """Each run-directory command's task ids, as its ``run`` hands them to ``RunDir.open``, for a run
    with every agent kind (so every kind of task occurs)."""
    return {command: list(tasks) for command, tasks in _code_tasks().items()}


@functools.cache
def _code_tasks() -> dict[str, list[str]]:
    from msd_bench.app.options import run_config_from_args
    from msd_bench.commands import efficiency, paper, rigs
    from msd_bench.designs import registry

    every = ",".join(registry.AGENT_KINDS)
    return {
        "paper": paper.paper_tasks(run_config_from_args(_parse("paper", "--out", "x", "--agents", every)),
                                   figures=True),
        "efficiency": efficiency.efficiency_tasks(efficiency.efficiency_config(
            _parse("efficiency", "--out", "x", "--agents", every))),
        "efficiency --rigs": efficiency.rig_efficiency_tasks(efficiency.rig_efficiency_config(
            _parse("efficiency", "--out", "x", "--rigs", "2", "--record-samples", "300,1000"))),
        "rigs": rigs.rigs_tasks(rigs.rigs_config(_parse("rigs", "--out", "x"))),
    }


def _pattern(task: str) -> re.Pattern[str]:
    """A documented task id as a regex: each ``<placeholder>`` stands for a non-empty run of characters."""
    parts = re.split(r"<[^>]+>", task)
    return re.compile(".+".join(re.escape(p) for p in parts))


def check_run_tasks(text: str, actual: dict[str, list[str]] | None = None) -> list[str]:
    """§Runs on disk: per command, every task id the command builds matches a row, in the rows' order,
    and every row matches at least one."""
    actual = code_tasks() if actual is None else actual
    rows = table(text, ("command", "task", "writes"))
    documented: dict[str, list[str]] = {}
    for r in rows:
        documented.setdefault(code(r[0]), []).append(code(r[1]))
    problems = compare("run-task commands", sorted(documented), sorted(actual), ordered=False)
    for command, tasks in actual.items():
        patterns = [_pattern(t) for t in documented.get(command, [])]
        last = 0
        used: set[int] = set()
        for task in tasks:
            hits = [i for i, p in enumerate(patterns) if p.fullmatch(task)]
            if not hits:
                problems.append(f"run tasks: {command}'s task {task!r} matches no row on the page")
                continue
            if hits[0] < last:
                problems.append(f"run tasks: {command}'s task {task!r} comes after a later row's task")
            last = max(last, hits[0])
            used.add(hits[0])
        problems += [f"run tasks: {command}'s row {documented[command][i]!r} is on the page but "
                     "matches no task the command writes"
                     for i in range(len(patterns)) if i not in used]
    return problems


def _command_module(parser: argparse.ArgumentParser) -> str:
    """The module of a command's ``func`` (on the parser itself or on its subcommands')."""
    func = parser.get_default("func")
    if func is None:
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                func = next(iter(action.choices.values())).get_default("func")
    return "commands/" + str(func.__module__).rsplit(".", 1)[1] + ".py"


def check_commands(text: str) -> list[str]:
    """§Commands: cli.py's commands in its order, each in its module; the console's own help names them."""
    from msd_bench import cli

    parser = cli.build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    rows = table(text, ("command", "module", "does"))
    problems = compare("commands", [code(r[0]) for r in rows], list(sub.choices))
    for r in rows:
        if code(r[0]) in sub.choices and code(r[1]) != _command_module(sub.choices[code(r[0])]):
            problems.append(f"commands: {code(r[0])!r} is said to live in {code(r[1])}, not "
                            f"{_command_module(sub.choices[code(r[0])])}")
    head = (cli.__doc__ or "").splitlines()[0]
    problems += [f"commands: cli.py's help line does not name {c!r}"
                 for c in sub.choices if not re.search(rf"(?<![\w-]){re.escape(c)}(?![\w-])", head)]
    return problems


CHECKERS: dict[str, Callable[[str], list[str]]] = {
    "layers": check_layers, "nodes": check_nodes, "designs": check_designs,
    "model kinds": check_model_kinds, "faces": check_faces, "run tasks": check_run_tasks,
    "commands": check_commands,
}


# --- the page against the code ----------------------------------------------------------------

@pytest.mark.parametrize("name", list(CHECKERS))
def test_page_list_matches_code(name: str) -> None:
    assert CHECKERS[name](PAGE.read_text()) == []


# --- each checker catches a stale entry -------------------------------------------------------

STALE_ROWS: dict[str, tuple[str, str, str]] = {
    # list: (a line of the real page to plant next to, the planted stale line, what the checker must name)
    "nodes": ("| plant (`plant.py`) |", "| tuner (`tuner.py`) | a node that no longer exists |", "tuner.py"),
    "designs": ("| `pid` | `designs/baselines.py` |", "| `h-infinity` | `designs/baselines.py` | gone |",
                "h-infinity"),
    "model kinds": ("| `glm` | GLM |", "| `arx` | ARX | `linear` | `broad` | `broad` |", "arx"),
    "faces": ("| `msd` | `force` |", "| `gazebo` | `cmd` | `std_msgs/msg/Float64` | no | no | `measured` |",
              "gazebo"),
    "run tasks": ("| `paper` | `table1` |", "| `paper` | `qtables` | the old Q-table task |", "qtables"),
    "commands": ("| `paper` | `commands/paper.py` |", "| `train` | `commands/train.py` | an old command |",
                 "train"),
}


def _plant(text: str, anchor: str, line: str) -> str:
    """``text`` with ``line`` inserted after the one line starting with ``anchor``."""
    lines = text.splitlines()
    at = [i for i, x in enumerate(lines) if x.lstrip().startswith(anchor)]
    assert len(at) == 1, f"anchor {anchor!r} found {len(at)} times on the page"
    return "\n".join([*lines[:at[0] + 1], line, *lines[at[0] + 1:]]) + "\n"


def _drop(text: str, anchor: str) -> str:
    """``text`` without the one line starting with ``anchor``."""
    lines = text.splitlines()
    assert sum(x.lstrip().startswith(anchor) for x in lines) == 1
    return "\n".join(x for x in lines if not x.lstrip().startswith(anchor)) + "\n"


@pytest.mark.parametrize("name", list(STALE_ROWS))
def test_checker_names_a_planted_stale_row(name: str) -> None:
    anchor, stale, named = STALE_ROWS[name]
    problems = CHECKERS[name](_plant(PAGE.read_text(), anchor, stale))
    assert any(repr(named) in p and "on the page but" in p for p in problems), problems


@pytest.mark.parametrize("name", list(STALE_ROWS))
def test_checker_names_a_dropped_row(name: str) -> None:
    anchor, _, _ = STALE_ROWS[name]
    assert CHECKERS[name](_drop(PAGE.read_text(), anchor)) != []


def test_layers_checker_names_a_stale_and_a_missing_folder() -> None:
    text = PAGE.read_text()
    stale = _plant(text, "msd_bench/core/safety/", "msd_bench/core/loops/        gone")
    assert any("'msd_bench/core/loops'" in p for p in check_layers(stale))
    assert any("'msd_bench/io/rigs'" in p and "not on the page" in p
               for p in check_layers(_drop(text, "msd_bench/io/rigs/")))


def test_facts_checkers_name_a_wrong_cell() -> None:
    """A row whose name is right but whose facts are stale is caught too."""
    text = PAGE.read_text()
    wrong_kernel = text.replace("| `greybox` | Grey-box | `plant` |", "| `greybox` | Grey-box | `linear` |")
    assert any("'greybox'" in p for p in check_model_kinds(wrong_kernel))
    with_reset = text.replace("| `Float64MultiArray` |", "|").replace(
        "`std_msgs/msg/Float64MultiArray` | no | no |", "`std_msgs/msg/Float64MultiArray` | no | yes |")
    assert any("'ros2_control'" in p for p in check_faces(with_reset))
    moved = text.replace("| `echo` | `commands/topics.py` |", "| `echo` | `commands/echo.py` |")
    assert any("'echo'" in p for p in check_commands(moved))


def test_run_tasks_checker_names_a_task_the_page_lacks() -> None:
    """A task the code writes and no row covers (the code moved on, the page did not)."""
    actual = code_tasks()
    actual["paper"] = [*actual["paper"], "checkpoints"]
    assert any("'checkpoints'" in p for p in check_run_tasks(PAGE.read_text(), actual))
