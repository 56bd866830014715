"""One job description between the engines: what bench.py hands a node is what the run configures."""

from __future__ import annotations

import ast
import dataclasses
import inspect
import json
import textwrap
from dataclasses import replace
from pathlib import Path

import pytest

from msd_bench.app.agents import agent_kind
from msd_bench.app.bag_identification import IdentifierConfig
from msd_bench.app.config import RunConfig
from msd_bench.app.job import (
    JOB_VERSION,
    SHARED_ALIASES,
    SHARED_DEFAULTS,
    JobError,
    job_document,
    read_job,
    shared,
)
from msd_bench.app.pipeline import settings
from msd_bench.core.errors import ConfigError
from msd_bench.graph.bench import (
    BenchConfig,
    agent_args,
    agent_job,
    identifier_job,
    surrogate_args,
    surrogate_job,
    write_job,
)
from msd_bench.nodes.agent_node import AgentNodeConfig
from msd_bench.nodes.excitation_node import ExcitationNodeConfig
from msd_bench.nodes.params import config_from_job
from msd_bench.nodes.recorder_node import RecorderConfig
from msd_bench.nodes.surrogate_node import SurrogateConfig
from tests.syntax import parse_source

NODE_CONFIGS = (AgentNodeConfig, IdentifierConfig, ExcitationNodeConfig, RecorderConfig, SurrogateConfig)
HOMONYMS = {ExcitationNodeConfig: {"window"}, IdentifierConfig: {"dt"}}
"""Fields that only share a name with a run quantity (the excitation's ``window`` counts commands in
flight, not the SSE's terminal samples; the identifier's ``dt`` defaults to ``FROM_STAMPS``, the
bags' own rate, and its job always carries the run's: issue 32)."""
JOB_FIELDS = frozenset(SHARED_DEFAULTS) | frozenset(SHARED_ALIASES)
"""The names of the run quantities a job carries (and their aliases in node configs)."""
PACKAGE = Path(__file__).resolve().parents[2] / "msd_bench"
SCANNED = (PACKAGE / "nodes", PACKAGE / "graph")
"""The node processes and the stages that start them: no default of a job field of their own."""
RUN = RunConfig(seeds=2, episodes=7, steps=50, dyna_episodes=3, planning_steps=4, validation_steps=400,
                window=100, target=0.5, shaping="away", nlarx_scale=0.5, preset="mild",
                agents=("glm", "plm+improved", "dyna-q", "plant"))


def _literal_defaults(cls: type) -> dict[str, object]:
    """Fields of ``cls`` whose default is written as a literal in its source."""
    body = parse_source(textwrap.dedent(inspect.getsource(cls))).body[0]
    found: dict[str, object] = {}
    for stmt in getattr(body, "body", []):
        if not (isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name) and stmt.value):
            continue
        value = stmt.value
        if isinstance(value, ast.Call):  # field(default=...)
            value = next((k.value for k in value.keywords if k.arg == "default"), None)
        if isinstance(value, ast.Constant):
            found[stmt.target.id] = value.value
    return found


@pytest.mark.parametrize("cls", NODE_CONFIGS, ids=lambda c: c.__name__)
def test_no_node_config_redeclares_a_shared_quantity_with_a_literal(cls):
    shared_names = JOB_FIELDS - HOMONYMS.get(cls, set())
    redeclared = sorted(set(_literal_defaults(cls)) & shared_names)
    assert redeclared == [], f"{cls.__name__} re-declares {redeclared}: use msd_bench.app.job.shared()"
    for f in dataclasses.fields(cls):
        if f.name in shared_names:
            assert f.default == shared(f.name), f.name


def _literal(value: ast.expr | None) -> bool:
    """A default written as a number, string or bool (``-0.01`` too), not read from somewhere."""
    if isinstance(value, ast.UnaryOp):
        value = value.operand
    return isinstance(value, ast.Constant) and value.value is not None


def literal_job_defaults(tree: ast.AST, homonyms: frozenset[str] = frozenset()) -> list[tuple[int, str]]:
    """Every default of a job field written as a literal in ``tree``: a class field (``dt: float = 0.01``,
    ``field(default=10.0)``) or a function's keyword (``def f(force=10.0)``); ``homonyms`` aside."""
    names = JOB_FIELDS - homonyms
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and node.target.id in names:
            value = node.value
            if isinstance(value, ast.Call):
                value = next((k.value for k in value.keywords if k.arg == "default"), None)
            if _literal(value):
                found.append((node.lineno, node.target.id))
        elif isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            args = node.args
            positional = [*args.posonlyargs, *args.args]
            tail = positional[len(positional) - len(args.defaults):]
            keywords = zip(args.kwonlyargs, args.kw_defaults, strict=True)
            pairs = [*zip(tail, args.defaults, strict=True), *((a, d) for a, d in keywords if d is not None)]
            found += [(node.lineno, a.arg) for a, d in pairs if a.arg in names and _literal(d)]
    return sorted(found)


def test_the_module_scan_finds_each_literal_default():
    tree = parse_source("class C:\n    dt: float = 0.01\n    force_limit: float = field(default=10.0)\n"
                     "    episodes: int = shared('episodes')\n    seed: int = 0\n"
                     "def f(steps: int = 3000, *, target=-1.0, window=RECORD_WINDOW): ...\n")
    assert [n for _, n in literal_job_defaults(tree)] == ["dt", "force_limit", "steps", "target"]


def test_no_node_module_declares_a_default_for_a_job_field():
    """Each run quantity has one default, the run configuration's: a node takes it from its job (or,
    run by hand, from :func:`msd_bench.app.job.shared`), and a stage from the run, never from a literal
    of its own (``graph/record.py`` had ``force_limit: float = 10.0, dt: float = 0.01``)."""
    hits = []
    for path in sorted(p for d in SCANNED for p in d.glob("*.py")):
        homonyms = frozenset({"window"}) if path.name == "excitation_node.py" else frozenset()
        hits += [f"{path.relative_to(PACKAGE)}:{line}: {name}"
                 for line, name in literal_job_defaults(parse_source(path.read_text(), str(path)), homonyms)]
    assert hits == [], "literal defaults of job fields in msd_bench/nodes or graph:\n" + "\n".join(hits)


def test_the_surrogate_job_carries_the_runs_plant(tmp_path):
    cfg = _bench(tmp_path, via_ros=True)
    doc = surrogate_job(cfg, "glm")
    assert doc["role"] == "surrogate"
    assert doc["params"] == {"dt": RUN.plant.dt, "force_limit": RUN.plant.F, "lockstep": True,
                             "model_path": str(tmp_path / "models" / "glm.json")}
    args = surrogate_args(cfg, "glm")
    assert json.loads(Path(_job_path(args)).read_text()) == doc
    assert args[-2:] == ["-r", "__ns:=/surrogate/glm"]


def test_the_ast_check_catches_a_literal():
    @dataclasses.dataclass(frozen=True)
    class Drifted:
        dt: float = dataclasses.field(default=0.02, metadata={"range": (1e-4, 1.0)})
        episodes: int = 300

    assert set(_literal_defaults(Drifted)) == {"dt", "episodes"}


def _bench(tmp_path: Path, **kw) -> BenchConfig:
    return BenchConfig(run_dir=tmp_path, run=RUN, **kw)


def _job_path(args: list[str]) -> str:
    assert args[0] == "-p" and args[1].startswith("job:=")
    return args[1].removeprefix("job:=")


@pytest.mark.parametrize("kind", RUN.agents)
def test_an_agent_node_runs_what_the_in_process_engine_runs(tmp_path, kind):
    cfg = _bench(tmp_path)
    node = config_from_job(_job_path(agent_args(cfg, kind)), AgentNodeConfig, "agent")
    mine, theirs = node.settings(), settings(RUN)
    model_free = agent_kind(kind).design.model_free  # its budget is the on-plant one (Dyna-Q)
    budget = (lambda s: s.plant_episodes) if model_free else (lambda s: s.episodes)
    assert budget(mine) == budget(theirs)
    blind = {"episodes": 0, "plant_episodes": 0, "planning_steps": 0}  # each checked where it counts
    assert replace(mine, **blind) == replace(theirs, **blind)
    assert (node.validation_steps, node.window, node.target, node.dt, node.force) == (
        RUN.validation_steps, RUN.window, RUN.target, RUN.plant.dt, RUN.plant.F)
    assert list(node.seeds) == RUN.learning_seeds(0)
    if model_free:
        assert node.planning_steps == RUN.planning_steps


def test_the_identifier_job_carries_the_run(tmp_path):
    cfg = _bench(tmp_path)
    node = config_from_job(str(write_job(cfg, "identifier", identifier_job(cfg))), IdentifierConfig,
                           "identifier")
    p = RUN.plant
    assert (node.stroke, node.force, node.dt, node.nlarx_scale, node.seed) == (p.L, p.F, p.dt, 0.5, 0)
    assert list(node.models) == RUN.surrogates_needed()
    assert node.out_dir == str(tmp_path / "models")


def test_job_files_are_written_inside_the_run_directory(tmp_path):
    cfg = _bench(tmp_path)
    path = Path(_job_path(agent_args(cfg, "glm")))
    assert path.parent == (tmp_path / "jobs").resolve()
    assert json.loads(path.read_text())["params"]["episodes"] == RUN.episodes


def test_a_placement_cannot_restate_a_run_quantity():
    with pytest.raises(ConfigError, match="episodes comes from the run configuration"):
        job_document("agent", RUN, {"episodes": 1})


def test_node_defaults_equal_the_run_defaults():
    run, node = RunConfig(), AgentNodeConfig(out_dir="x", kind="dyna-q")
    assert (node.episodes, node.plant_episodes, node.steps, node.window, node.shaping) == (
        run.episodes, run.dyna_episodes, run.steps, run.window, run.shaping)


# --- bad job files: one line naming the file and the field -------------------------------------

def _written(tmp_path: Path, doc: object) -> Path:
    path = tmp_path / "job.json"
    path.write_text(doc if isinstance(doc, str) else json.dumps(doc))
    return path


def _good(tmp_path: Path) -> dict:
    return agent_job(_bench(tmp_path), "glm")


def _bad_cases(tmp_path: Path) -> list[tuple[object, str]]:
    good = _good(tmp_path)
    params = good["params"]
    return [
        ("{not json", "not valid JSON"),
        ([1, 2], "expected a JSON object"),
        ({**good, "version": JOB_VERSION + 1}, "field version 2 is not supported"),
        ({**good, "schema": "other"}, "field schema must be"),
        ({**good, "role": "identifier"}, "field role is 'identifier'"),
        ({**good, "extra": 1}, "unknown field 'extra'"),
        ({**good, "params": {**params, "episode": 3}}, "unknown field 'episode' for a agent node"),
        ({**good, "params": {**params, "episodes": 0}}, r"field episodes: 0 is outside \[1, 100000\]"),
        ({**good, "params": {**params, "dt": "0.01"}}, "field dt must be float"),
        ({**good, "params": {**params, "episodes": True}}, "field episodes must be int"),
        ({**good, "params": {**params, "seeds": 3}}, "field seeds must be a list"),
        ({**good, "params": {**params, "kind": "nope"}}, "unknown agent kind|nope"),
    ]


def test_bad_job_files_are_one_line_naming_file_and_field(tmp_path):
    for doc, message in _bad_cases(tmp_path):
        path = _written(tmp_path, doc)
        with pytest.raises(JobError, match=message) as err:
            config_from_job(str(path), AgentNodeConfig, "agent")
        text = str(err.value)
        assert "\n" not in text and str(path) in text, text


def test_a_missing_job_file_names_it(tmp_path):
    with pytest.raises(JobError, match=r"job file .*absent\.json: cannot read"):
        read_job(tmp_path / "absent.json", "agent")


def test_an_oversized_job_file_is_refused_before_parsing(tmp_path):
    path = _written(tmp_path, "[" + "0," * (1 << 20) + "0]")
    with pytest.raises(JobError, match="exceeds"):
        read_job(path, "agent")


def test_a_rig_run_and_a_via_ros_run_hand_their_placement_through_the_job(tmp_path):
    rig = _bench(tmp_path / "rig", realtime=True, plant_ns="/rig", node_scenarios=("setpoint=0.5",),
                 scenario_kinds=("glm",))
    node = config_from_job(_job_path(agent_args(rig, "glm")), AgentNodeConfig, "agent")
    assert (node.plant_ns, node.reset, node.lockstep, node.pooled, node.scenarios) == (
        "/rig", False, False, False, "setpoint=0.5")
    via = _bench(tmp_path / "via", via_ros=True)
    node = config_from_job(_job_path(agent_args(via, "plm+improved")), AgentNodeConfig, "agent")
    assert node.via_ros and node.surrogate_ns.endswith("plm") and node.model_path.endswith("plm.json")
