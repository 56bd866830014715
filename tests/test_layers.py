"""The layer rules of docs/design.md §Layers, checked over the real import graph.

Every module of ``msd_bench/``, ``msd_msgs_py/`` and ``launch_scripts/`` is parsed
with :mod:`ast` (nothing is imported, so the check needs no rclpy, no network and
takes well under a second). Each ``import`` and ``from ... import`` is resolved —
relative ones against the importer's package, ``from pkg import sub`` to the
submodule when ``sub`` is one — into an edge between two project modules.

Which imports count: all of them, at module level, inside a function or under
``if TYPE_CHECKING``. A function-level import is the same dependency deferred: the
function cannot run without the imported module, so a lazy import (done here to keep
numba, torch or rclpy off a light path) is a load-time choice, never a licence to
reach up a layer; and a circle closed through a lazy import still means neither
module can be read or tested without the other. A type-only import is part of the
importer's interface in the same way.

The rules, in one table (:data:`MAY_IMPORT`): each layer names the layers it may
import; a module may always import modules of its own layer. The checker fails on

- an import of a layer that is not in the importer's row (an import from a lower
  layer to a higher one, or across, like graph → nodes), naming importer and
  imported module;
- any circle of modules (a strongly connected component of the module graph), named
  by its members, within one layer or across layers.

``python tests/test_layers.py`` prints the layer → layer edges with their counts.
"""

from __future__ import annotations

import ast
import functools
import re
import sys
from collections import Counter
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.syntax import parse_source

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("msd_bench", "msd_msgs_py", "launch_scripts")
"""The top-level trees checked (benchmarks/, scripts/ and tests/ stand above every layer)."""

LAYERS: dict[str, tuple[str, ...]] = {
    "launch_scripts": ("launch_scripts.*",),
    "cli": ("msd_bench.__main__", "msd_bench.cli"),
    "root": ("msd_bench",),
    "graph": ("msd_bench.graph.*",),
    "commands": ("msd_bench.commands.*",),
    "nodes": ("msd_bench.nodes.*",),
    "app": ("msd_bench.app.*",),
    "designs": ("msd_bench.designs.*",),
    "gym": ("msd_bench.gym.*",),
    "io": ("msd_bench.io.*",),
    "msgs.ros": ("msd_msgs_py.ros",),
    "msgs": ("msd_msgs_py.*",),
    "core": ("msd_bench.core.*",),
    "errors": ("msd_bench.core.errors",),
    "support": ("msd_bench.dds", "msd_bench.progress", "msd_bench._bootstrap", "msd_bench._version"),
}
"""Layer name -> its modules: ``pkg.*`` is a package and everything below it, a bare name that
module alone; a module belongs to the longest pattern it matches.

``root`` is the package's public face (``msd_bench.load_model``, ``__version__``), which
reaches into io: so no layer below may import it, and the version lives in the leaf
``_version``. ``errors`` is ``core/errors.py`` alone (it imports nothing), so the
contract's ``interface.py`` can raise the project's one-line errors without sitting
above the science. ``support`` holds leaf modules that import nothing of the project.
"""

_BASE = ("errors", "support")
MAY_IMPORT: dict[str, frozenset[str]] = {
    "launch_scripts": frozenset({"graph", "nodes", *_BASE}),
    "cli": frozenset({"commands", "core", *_BASE}),
    "root": frozenset({"io", "core", *_BASE}),
    "graph": frozenset({"app", "designs", "io", "msgs", "core", *_BASE}),
    "commands": frozenset({"nodes", "app", "designs", "io", "msgs", "msgs.ros", "core", *_BASE}),
    "nodes": frozenset({"app", "designs", "io", "msgs", "msgs.ros", "core", *_BASE}),
    "app": frozenset({"designs", "io", "msgs", "core", *_BASE}),
    "designs": frozenset({"gym", "io", "core", *_BASE}),
    "gym": frozenset({"io", "msgs", "msgs.ros", "core", *_BASE}),
    "io": frozenset({"msgs", "core", *_BASE}),
    "msgs.ros": frozenset({"msgs", *_BASE}),
    "msgs": frozenset({"errors"}),
    "core": frozenset({*_BASE}),
    "errors": frozenset(),
    "support": frozenset(),
}
"""Layer -> the other layers it may import (docs/design.md §Layers says why for each).

Read down the rows: graph starts node processes and never imports a node or a command;
only nodes, the ``echo``/``hz`` commands and the gym's ROS backend may import
``msd_msgs_py.ros`` (rclpy); io never imports the application; core imports no other
layer of the project.
"""

KNOWN: frozenset[tuple[str, str]] = frozenset({
    # graph/live.py's watch subscribes to the plant in bench.py's own process, where the issue puts
    # the live view's server; graph otherwise never runs ROS. To remove: the watch in a node process
    # of its own, forwarding rows to the server over a pipe.
    ("msd_bench.graph.live", "msd_msgs_py.ros"),
})
"""Imports that break a rule today and are tracked, each with why; one that no longer
exists fails the suite, so the list can only shrink."""


@dataclass(frozen=True)
class Edge:
    """One import of a project module by a project module, where it is written."""

    importer: str
    imported: str
    path: Path
    line: int


@functools.cache
def _parse(path: Path) -> ast.Module:
    """The syntax tree of ``path`` (parsed once per run: several tests walk the same files)."""
    return parse_source(path.read_text(encoding="utf-8"), filename=str(path))


def modules(root: Path, packages: Iterable[str] = PACKAGES) -> dict[str, Path]:
    """Every module under ``root``'s ``packages`` by dotted name (a package by its ``__init__``)."""
    found: dict[str, Path] = {}
    for pkg in packages:
        for path in sorted((root / pkg).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            found[".".join(parts)] = path
    return found


def _package_of(name: str, path: Path) -> str:
    """The package a relative import in module ``name`` is resolved against."""
    return name if path.name == "__init__.py" else name.rpartition(".")[0]


def _from_base(node: ast.ImportFrom, package: str) -> str:
    """The absolute module a ``from X import ...`` names, resolving dots against ``package``."""
    if node.level == 0:
        return node.module or ""
    parts = package.split(".")
    base = parts[: len(parts) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _targets(node: ast.AST, package: str, known: Mapping[str, Path]) -> Iterator[str]:
    """The project modules an import statement loads (a ``from pkg import sub`` loads ``pkg.sub``)."""
    if isinstance(node, ast.Import):
        for alias in node.names:
            yield alias.name
    elif isinstance(node, ast.ImportFrom):
        base = _from_base(node, package)
        subs = [f"{base}.{a.name}" for a in node.names if f"{base}.{a.name}" in known]
        yield from subs
        if len(subs) < len(node.names):
            yield base


def _owner(name: str, known: Mapping[str, Path]) -> str | None:
    """The project module an imported name lives in (``a.b.c`` -> ``a.b`` if ``c`` is a symbol)."""
    while name:
        if name in known:
            return name
        name = name.rpartition(".")[0]
    return None


def edges(root: Path, packages: Iterable[str] = PACKAGES) -> list[Edge]:
    """Every import between project modules under ``root``, at any depth of the syntax tree."""
    known = modules(root, packages)
    found: list[Edge] = []
    for name, path in known.items():
        package = _package_of(name, path)
        for node in ast.walk(_parse(path)):
            for target in _targets(node, package, known):
                owner = _owner(target, known)
                if owner is not None and owner != name:
                    found.append(Edge(name, owner, path, getattr(node, "lineno", 0)))
    return found


def _matches(module: str, pattern: str) -> int:
    """How specific ``pattern``'s match of ``module`` is (its length), or -1 for no match."""
    if pattern.endswith(".*"):
        base = pattern[:-2]
        return len(base) if module == base or module.startswith(base + ".") else -1
    return len(pattern) if module == pattern else -1


def layer_of(module: str, layers: Mapping[str, tuple[str, ...]] = LAYERS) -> str:
    """The layer of the most specific pattern matching ``module``; a module of no layer fails."""
    scored = [(_matches(module, p), layer) for layer, patterns in layers.items() for p in patterns]
    score, best = max(scored)
    if score < 0:
        raise AssertionError(f"{module}: in no layer of the table (tests/test_layers.py LAYERS)")
    return best


def violations(found: Iterable[Edge], may_import: Mapping[str, frozenset[str]] = MAY_IMPORT,
               layers: Mapping[str, tuple[str, ...]] = LAYERS,
               known: frozenset[tuple[str, str]] = frozenset()) -> list[str]:
    """One line per import a layer may not make, naming the importer, the imported and both layers."""
    lines = []
    for e in found:
        src, dst = layer_of(e.importer, layers), layer_of(e.imported, layers)
        if src != dst and dst not in may_import[src] and (e.importer, e.imported) not in known:
            lines.append(f"{e.importer} ({src}) imports {e.imported} ({dst}) at "
                         f"{e.path.name}:{e.line}: {src} may import only {sorted(may_import[src])}")
    return sorted(set(lines))


def circles(found: Iterable[Edge], known: frozenset[tuple[str, str]] = frozenset()) -> list[list[str]]:
    """Every circle of modules: the strongly connected components of more than one module
    (or a module importing itself), each sorted, by Tarjan's algorithm."""
    graph: dict[str, set[str]] = {}
    for e in found:
        graph.setdefault(e.importer, set())
        graph.setdefault(e.imported, set())
        if (e.importer, e.imported) not in known:
            graph[e.importer].add(e.imported)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1 or v in graph[v]:
                out.append(sorted(comp))

    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 10 * len(graph) + 100))
    try:
        for v in sorted(graph):
            if v not in index:
                visit(v)
    finally:
        sys.setrecursionlimit(limit)
    return sorted(out)


def layer_edges(found: Iterable[Edge],
                layers: Mapping[str, tuple[str, ...]] = LAYERS) -> Counter[tuple[str, str]]:
    """Import statements between two different layers, counted per (importer layer, imported layer)."""
    return Counter((layer_of(e.importer, layers), layer_of(e.imported, layers)) for e in found
                   if layer_of(e.importer, layers) != layer_of(e.imported, layers))


def _picture(text: str) -> list[str]:
    """The module patterns of docs/design.md's §Layers picture, top to bottom (its first code block):
    ``msd_bench/graph/`` is ``msd_bench.graph.*``, ``msd_bench/cli.py`` is ``msd_bench.cli``."""
    section = text.split("## Layers", 1)[1].split("\n## ", 1)[0]
    block = section.split("```", 2)[1]
    drawn = []
    for line in block.splitlines():
        if line and not line[0].isspace():
            path = line.split()[0]
            dotted = path.rstrip("/").removesuffix(".py").removesuffix("/__init__").replace("/", ".")
            drawn.append(dotted + ".*" if path.endswith("/") else dotted)
    return drawn


# --- the project --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def project() -> list[Edge]:
    return edges(ROOT)


def test_every_module_is_in_a_layer(project: list[Edge]) -> None:
    """A new package must be placed in the table, not slip past the check."""
    for name in modules(ROOT):
        layer_of(name)


def test_no_import_breaks_a_layer_rule(project: list[Edge]) -> None:
    bad = violations(project, known=KNOWN)
    assert not bad, "imports that break docs/design.md §Layers:\n" + "\n".join(bad)


def test_no_circle_of_modules(project: list[Edge]) -> None:
    found = circles(project, known=KNOWN)
    assert not found, "import circles:\n" + "\n".join(" <-> ".join(c) for c in found)


def test_known_exceptions_still_exist(project: list[Edge]) -> None:
    """A tracked exception that was fixed must leave the list, so it cannot hide a new one."""
    present = {(e.importer, e.imported) for e in project}
    assert KNOWN.issubset(present), f"fixed, remove from KNOWN: {sorted(KNOWN - present)}"


def test_the_table_is_a_dag_drawn_in_design_md() -> None:
    """Every allowed import points down the picture in docs/design.md §Layers, so the rules allow no
    circle of layers and the doc and this table cannot disagree."""
    assert set(MAY_IMPORT) == set(LAYERS)
    order = _picture((ROOT / "docs" / "design.md").read_text(encoding="utf-8"))
    where = {}
    for layer, patterns in LAYERS.items():
        drawn = [i for i, pattern in enumerate(order) if pattern in patterns]
        assert drawn, f"layer {layer} ({patterns}) is not drawn in docs/design.md §Layers: {order}"
        where[layer] = drawn[0]
    for src, allowed in MAY_IMPORT.items():
        for dst in allowed:
            assert where[dst] > where[src], f"{src} may import {dst}, drawn above it in docs/design.md"


ROS_LAYERS = frozenset({"nodes", "commands", "gym", "msgs.ros"})
"""The only layers that may import rclpy or a ROS message package (docs/design.md §Layers)."""


def _is_ros(top: str) -> bool:
    return top in ("rclpy", "builtin_interfaces") or top.endswith("_msgs") or top.startswith("rosidl")


ROS_TRACKED = frozenset({"msd_bench.graph.live"})
"""Modules outside the ROS layers that import rclpy today, each tracked in :data:`KNOWN` with why."""


def test_only_the_ros_layers_import_rclpy_or_messages() -> None:
    """core runs in a notebook, io reads bags without ROS, graph starts processes: rclpy and the
    message packages are imported by nodes, the echo/hz/check-rig commands, the gym's ROS backend
    and msd_msgs_py/ros.py only, at any depth of a module."""
    found = []
    for name, path in modules(ROOT).items():
        if layer_of(name) in ROS_LAYERS or name in ROS_TRACKED:
            continue
        for node in ast.walk(_parse(path)):
            tops = ([a.name.split(".")[0] for a in node.names] if isinstance(node, ast.Import) else
                    [(node.module or "").split(".")[0]] if isinstance(node, ast.ImportFrom) and not node.level
                    else [])
            found += [f"{name} ({layer_of(name)}) imports {t} at {path.name}:{node.lineno}"
                      for t in tops if _is_ros(t)]
    assert not found, "ROS imported outside nodes, commands, gym and msd_msgs_py/ros.py:\n" + "\n".join(found)


_ROS_TYPE = re.compile(r"^[A-Za-z_]\w*/(msg|srv|action)/[A-Z]\w*$")
"""A ROS interface name as rosbag2 stores it (``std_msgs/msg/Float64``)."""


def _type_names(path: Path) -> list[str]:
    """String literals of ``path`` that are ROS interface names, docstrings left out."""
    tree = _parse(path)
    docs = {id(n.value) for n in ast.walk(tree)
            if isinstance(n, ast.Expr) and isinstance(n.value, ast.Constant)}
    return [f"{path.relative_to(ROOT)}:{n.lineno}: {n.value}" for n in ast.walk(tree)
            if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in docs
            and _ROS_TYPE.match(n.value)]


def test_only_the_contract_spells_a_message_type() -> None:
    """docs/design.md §Layers: a message type name is written in msd_msgs_py only; everything else
    takes it from a TopicSpec or a contract constant (io/bag_writer.py spelt six)."""
    found = [hit for name, path in modules(ROOT).items() if not name.startswith("msd_msgs_py")
             for hit in _type_names(path)]
    assert not found, "message types spelt outside msd_msgs_py:\n" + "\n".join(found)


def _config_fields(path: Path, cls: str) -> set[str]:
    """The annotated fields of dataclass ``cls`` in ``path`` (by ast: no rclpy import)."""
    tree = parse_source(path.read_text(encoding="utf-8"))
    body = next(n for n in ast.walk(tree) if isinstance(n, ast.ClassDef) and n.name == cls).body
    return {n.target.id for n in body if isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name)}


def test_the_agent_script_documents_parameters_the_node_takes() -> None:
    """launch_scripts/agent.py once documented ``-p agent:=improved``, which the node refuses: every
    ``-p name:=`` it shows is a field of the node's config (or ``job``), every kind it shows a kind."""
    from msd_bench.designs.registry import AGENT_KINDS

    script = parse_source((ROOT / "launch_scripts" / "agent.py").read_text(encoding="utf-8"))
    doc = ast.get_docstring(script) or ""
    fields = _config_fields(ROOT / "msd_bench" / "nodes" / "agent_node.py", "AgentNodeConfig") | {"job"}
    shown = set(re.findall(r"-p \"?(\w+):=", doc))
    assert shown and shown <= fields, f"not parameters of the agent node: {sorted(shown - fields)}"
    kinds = set(re.findall(r"kind:=([\w+@-]+)", doc)) | set(re.findall(r"``([\w-]+[+@][\w-]+)``", doc))
    assert kinds and kinds <= set(AGENT_KINDS), f"not agent kinds: {sorted(kinds - set(AGENT_KINDS))}"


# --- the checker on a deliberately wrong tree -----------------------------------------------


def _tree(root: Path, files: Mapping[str, str]) -> Path:
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    return root


_LAYOUT = {
    "msd_bench/__init__.py": "",
    "msd_bench/core/__init__.py": "",
    "msd_bench/core/errors.py": "",
    "msd_bench/core/plant.py": "from msd_bench.core.errors import x\n",
    "msd_bench/io/__init__.py": "",
    "msd_bench/io/bags.py": "from ..core import plant\n",
    "msd_bench/app/__init__.py": "",
    "msd_bench/app/config.py": "import msd_bench.io.bags\n",
    "msd_msgs_py/__init__.py": "",
}


def test_a_clean_tree_passes(tmp_path: Path) -> None:
    found = edges(_tree(tmp_path, _LAYOUT))
    assert {(e.importer, e.imported) for e in found} == {
        ("msd_bench.core.plant", "msd_bench.core.errors"),
        ("msd_bench.io.bags", "msd_bench.core.plant"),
        ("msd_bench.app.config", "msd_bench.io.bags"),
    }
    assert violations(found) == [] and circles(found) == []


def test_an_upward_function_level_import_fails_naming_both(tmp_path: Path) -> None:
    """core reaching up into app from inside a function, by a relative import: named, with its line."""
    tree = _tree(tmp_path, {**_LAYOUT, "msd_bench/core/plant.py":
                            "def f():\n    from ..app.config import RunConfig\n    return RunConfig\n"})
    bad = violations(edges(tree))
    assert len(bad) == 1
    assert re.match(r"msd_bench\.core\.plant \(core\) imports msd_bench\.app\.config \(app\) at plant\.py:2:",
                    bad[0]), bad[0]


def test_graph_importing_a_node_fails(tmp_path: Path) -> None:
    """Across, not only up: graph starts node processes and may not import one."""
    tree = _tree(tmp_path, {**_LAYOUT, "msd_bench/graph/__init__.py": "",
                            "msd_bench/nodes/__init__.py": "",
                            "msd_bench/nodes/serve_protocol.py": "",
                            "msd_bench/graph/jobs.py": "from msd_bench.nodes import serve_protocol\n"})
    bad = violations(edges(tree))
    assert [b.split(" at ")[0] for b in bad] == [
        "msd_bench.graph.jobs (graph) imports msd_bench.nodes.serve_protocol (nodes)"]


def test_a_circle_fails_naming_its_modules(tmp_path: Path) -> None:
    """Two modules of one layer importing each other (as nodes/serve and nodes/spin did): a circle,
    though no layer rule is broken."""
    tree = _tree(tmp_path, {**_LAYOUT, "msd_bench/io/paths.py": "from msd_bench.io import bags\n",
                            "msd_bench/io/bags.py": "def g():\n    from . import paths\n"})
    found = edges(tree)
    assert violations(found) == []
    assert circles(found) == [["msd_bench.io.bags", "msd_bench.io.paths"]]


def test_importing_the_package_root_from_below_fails(tmp_path: Path) -> None:
    """``import msd_bench`` (for its version) is an import of the root facade, which reaches into io."""
    tree = _tree(tmp_path, {**_LAYOUT, "msd_bench/io/artifacts.py": "import msd_bench\n"})
    bad = violations(edges(tree))
    assert [b.split(" at ")[0] for b in bad] == ["msd_bench.io.artifacts (io) imports msd_bench (root)"]


def test_a_symbol_import_counts_against_its_module(tmp_path: Path) -> None:
    """``from pkg.mod import name`` is an edge to ``pkg.mod``; ``from pkg import sub`` to ``pkg.sub``."""
    tree = _tree(tmp_path, {**_LAYOUT, "msd_bench/core/model.py":
                            "from msd_bench.io.bags import read\nimport msd_bench.core.errors as e\n"})
    pairs = {(e.importer, e.imported) for e in edges(tree) if e.importer == "msd_bench.core.model"}
    assert pairs == {("msd_bench.core.model", "msd_bench.io.bags"),
                     ("msd_bench.core.model", "msd_bench.core.errors")}


def test_a_module_in_no_layer_is_named(tmp_path: Path) -> None:
    tree = _tree(tmp_path, {**_LAYOUT, "msd_bench/newpkg/__init__.py": "",
                            "msd_bench/newpkg/thing.py": "from msd_bench.core import plant\n"})
    with pytest.raises(AssertionError, match=r"msd_bench\.newpkg\.thing: in no layer"):
        violations(edges(tree))


def main() -> None:
    """Print the layer -> layer edges with their counts, then every violation and circle."""
    found = edges(ROOT)
    for (src, dst), n in sorted(layer_edges(found).items()):
        mark = "" if dst in MAY_IMPORT[src] else "   <- not allowed"
        print(f"{src:>14} -> {dst:<14} {n:4d}{mark}")
    tracked = [e for e in found if (e.importer, e.imported) in KNOWN]
    for line in violations(found, known=KNOWN):
        print("violation:", line)
    for line in violations(tracked):
        print("tracked (KNOWN):", line)
    for circle in circles(found, known=KNOWN):
        print("circle:", " <-> ".join(circle))


if __name__ == "__main__":
    main()


def test_the_docs_layer_lists_agree_with_design_md() -> None:
    """docs/nodes.md and docs/testing.md list the layers in design.md's order (the README's two lists,
    which moved there, once disagreed with it and with each other)."""
    def order(page: str) -> list[str]:
        text = (ROOT / "docs" / page).read_text()
        return [m for m in re.findall(r"^(launch_scripts|msd_bench/\w+|msd_msgs_py)/", text, re.M)]

    design = [d for d in order("design.md") if d in set(order("nodes.md"))]
    assert order("nodes.md") == order("testing.md")[: len(order("nodes.md"))]
    assert [d for d in order("nodes.md") if d in set(design)] == list(dict.fromkeys(design))
