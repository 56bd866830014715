"""Fuzz: job files and result events, the two documents between bench.py and its node processes.

Property: whatever the bytes, :func:`msd_bench.nodes.params.config_from_job` gives a node config
or one :class:`~msd_bench.app.job.JobError` line naming the file, and
:func:`msd_bench.app.serve_protocol.parse_event` gives an event, None, or one EventError line
naming the node; never another exception. Documents are drawn near the valid job (one field of
the real params replaced by any JSON value, or an extra one) and far from it (any JSON, any text).
The excitation's job is fuzzed too: its fields come in sections (``prbs.bias``), each taken by one
of the node's declarations (:func:`msd_bench.nodes.params.sections_from_job`).
"""

from __future__ import annotations

import json
import tempfile
from dataclasses import asdict
from pathlib import Path

from hypothesis import given
from hypothesis import strategies as st

from msd_bench.app.config import RunConfig
from msd_bench.app.job import JobError, job_document
from msd_bench.app.serve_protocol import EVENT_PREFIX, EventError, parse_event
from msd_bench.graph.bench import BenchConfig, agent_job, record_plan
from msd_bench.graph.jobs import JobFiles
from msd_bench.graph.record import Placement, excitation_placement
from msd_bench.nodes.agent_node import AgentNodeConfig
from msd_bench.nodes.excitation_node import SECTIONS
from msd_bench.nodes.params import config_from_job, sections_from_job
from msd_msgs_py.interface import MSD_INTERFACE
from tests.fuzz.json_values import JSON

BENCH = BenchConfig(run_dir=Path("/nonexistent/run"), run=RunConfig(agents=("glm", "plm")))
GOOD = agent_job(BENCH, "glm")
FIELDS = [*sorted(GOOD["params"]), "unknown_field"]
_WHERE = Placement("/msd", True, False, False, MSD_INTERFACE, 128, JobFiles(BENCH.run_dir), BENCH.run)
EXCITATIONS = [job_document("excitation", BENCH.run, excitation_placement(spec, Path("/x/bag"), _WHERE))
               for spec in record_plan(BENCH)[::5]]  # a PRBS and a multilevel experiment
"""The record stage's excitation jobs, as bench.py writes them."""


def _near(good: dict, fields: list[str]) -> st.SearchStrategy[object]:
    def mutate(name: str, value: object) -> object:
        return {**good, "params": {**good["params"], name: value}}
    keys = st.sampled_from(["schema", "version", "role", "params"])
    envelope = st.builds(lambda k, v: {**good, k: v}, keys, JSON)
    return st.one_of(st.builds(mutate, st.sampled_from(fields), JSON), envelope)


def _read(text: str, read=lambda path: config_from_job(path, AgentNodeConfig, "agent")) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "job.json"
        path.write_text(text)
        try:
            read(str(path))
        except JobError as exc:
            assert "\n" not in str(exc) and str(path) in str(exc), str(exc)


def _read_excitation(text: str) -> None:
    _read(text, lambda path: sections_from_job(path, "excitation", SECTIONS))


@given(st.one_of(_near(GOOD, FIELDS), JSON))
def test_any_json_job_is_a_config_or_one_job_error(doc):
    _read(json.dumps(doc))


@given(st.one_of(*(_near(g, [*sorted(g["params"]), "prbs.nope", "steps.levels"]) for g in EXCITATIONS), JSON))
def test_any_json_excitation_job_is_its_configs_or_one_job_error(doc):
    _read_excitation(json.dumps(doc))


def test_the_excitation_jobs_bench_writes_are_read_back_whole():
    for good in EXCITATIONS:
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "job.json"
            path.write_text(json.dumps(good))
            config, *signals = sections_from_job(str(path), "excitation", SECTIONS)
        assert config.signal == good["params"]["signal"] and config.dt == BENCH.run.plant.dt
        chosen = signals[[prefix for prefix, _, _ in SECTIONS[1:]].index(config.signal + ".")]
        assert {f"{config.signal}.{k}": list(v) if isinstance(v, tuple) else v
                for k, v in asdict(chosen).items()}.items() <= good["params"].items()


@given(st.text(max_size=64))
def test_any_text_job_is_a_config_or_one_job_error(text):
    _read(text)


@given(st.one_of(st.text(max_size=64), JSON.map(json.dumps)))
def test_any_event_line_is_an_event_none_or_one_event_error(body):
    for line in (EVENT_PREFIX + body, body):
        try:
            parse_event(line, "identifier")
        except EventError as exc:
            assert str(exc).startswith("identifier: ") and "\n" not in str(exc)
