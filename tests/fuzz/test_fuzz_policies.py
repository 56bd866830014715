"""Fuzz: trained-policy artifacts (``policy.json`` and the design files beside it).

Property: whatever ``policy.json`` holds, :func:`msd_bench.designs.load` gives
a policy back or raises one :class:`ArtifactError` / :class:`ConfigError` line;
it never leaks a KeyError, TypeError or a numba error. Inputs: a valid
artifact of a baseline (``glm+pid``) and of a Q-learner (``glm``) with one
field replaced by random JSON, random JSON as the whole document, and the
bytes truncated.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from msd_bench import designs
from msd_bench.core.errors import ConfigError
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.designs import Settings
from msd_bench.io.storage.artifacts import ArtifactError
from tests.fuzz.json_values import JSON

MODEL: StepModel = plant_model(PlantParams())
TINY = Settings(episodes=1, steps=20)
FIELDS = ("schema", "schema_version", "kind", "design", "facts", "members", "files", "body", "provenance")


def _saved(kind: str) -> dict[str, bytes]:
    with tempfile.TemporaryDirectory() as d:
        designs.save(designs.make(kind, MODEL, TINY, [0, 1]), Path(d), {}, root=Path(d))
        return {p.name: p.read_bytes() for p in Path(d).iterdir()}


SAVED = {kind: _saved(kind) for kind in ("glm+pid", "glm")}


def _load(files: dict[str, bytes]) -> None:
    with tempfile.TemporaryDirectory() as d:
        for name, data in files.items():
            (Path(d) / name).write_bytes(data)
        try:
            designs.load(Path(d), MODEL)
        except (ArtifactError, ConfigError) as exc:
            assert "\n" not in str(exc)


def _with(kind: str, doc: dict[str, Any]) -> dict[str, bytes]:
    return {**SAVED[kind], "policy.json": json.dumps(doc).encode()}


@given(st.sampled_from(sorted(SAVED)), st.sampled_from(FIELDS), JSON)
def test_one_field_replaced_is_loaded_or_refused_in_one_line(kind, key, value):
    doc = json.loads(SAVED[kind]["policy.json"])
    doc[key] = value
    _load(_with(kind, doc))


@given(st.sampled_from(sorted(SAVED)), st.sampled_from(("members", "facts", "body", "files")),
       st.text(max_size=6), JSON)
def test_a_nested_value_replaced_is_loaded_or_refused_in_one_line(kind, key, inner, value):
    doc = json.loads(SAVED[kind]["policy.json"])
    target = doc[key]
    if isinstance(target, list) and target:
        target[0] = value
    elif isinstance(target, dict):
        target[next(iter(target), inner) if inner == "" else inner] = value
    _load(_with(kind, doc))


@given(st.sampled_from(sorted(SAVED)), JSON)
def test_random_json_as_the_document_is_refused_in_one_line(kind, value):
    _load({**SAVED[kind], "policy.json": json.dumps(value).encode()})


@given(st.sampled_from(sorted(SAVED)), st.integers(0, 4000))
def test_a_truncated_document_is_refused_in_one_line(kind, cut):
    _load({**SAVED[kind], "policy.json": SAVED[kind]["policy.json"][:cut]})
