"""A rig's task result read back: a good one pools into the report; a damaged one is one line."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import pytest

from msd_bench.app.rigs import document
from msd_bench.io.rigs.rig_parts import read_part
from msd_bench.io.rigs.rigs_report import render
from msd_bench.io.storage.run_dir import RunDirError
from tests.io.rig_part_sample import CFG, KINDS, SCENARIOS, part


def _write(tmp_path: Path, doc: Any) -> Path:
    path = tmp_path / "rig-1000.json"
    path.write_text(json.dumps(doc))
    return path


def test_a_good_part_is_read_and_reported(tmp_path: Path) -> None:
    got = read_part(_write(tmp_path, part()), 1000, KINDS, SCENARIOS)
    doc = document(CFG, [got])
    assert [k["successes"] for k in doc["kinds"]] == [1, 0]
    assert "| 1000 |" in render(doc)


def _damage(where: list[Any], value: Any) -> dict[str, Any]:
    doc = part()
    node: Any = doc
    for key in where[:-1]:
        node = node[key]
    if value is KeyError:
        del node[where[-1]]
    else:
        node[where[-1]] = value
    return doc


@pytest.mark.parametrize(("where", "value", "message"), [
    (["rig"], 1001, "rig must be 1000"),
    (["parameters", "friction"], "high", "parameters.friction must be a finite number, got str"),
    (["parameters"], KeyError, "parameters must be an object, got NoneType"),
    (["outcomes"], [], "outcomes must be a non-empty list"),
    (["outcomes", 0, "kind"], "plm", "outcomes[0].kind must be one of the run's kinds"),
    (["outcomes", 0, "success"], 1, "outcomes[0].success must be true or false, got int"),
    (["outcomes", 0, "scenarios"], {}, "outcomes[0].scenarios must hold exactly the run's rig scenarios"),
    (["outcomes", 1], copy.deepcopy(part()["outcomes"][0]), "outcomes hold no run of glm+robust"),
    (["seconds", "total"], None, "seconds.total must be a finite number, got NoneType"),
    (["identification_failed", "nope"], 3, "identification_failed must map model kinds to reasons"),
])
def test_a_damaged_part_is_one_line_naming_the_field(tmp_path: Path, where: list[Any], value: Any,
                                                      message: str) -> None:
    path = _write(tmp_path, _damage(where, value))
    with pytest.raises(RunDirError) as err:
        read_part(path, 1000, KINDS, SCENARIOS)
    assert str(err.value) == f"{path}: {message}" or str(err.value).startswith(f"{path}: {message}")
    assert "\n" not in str(err.value)


def test_not_json_is_one_line(tmp_path: Path) -> None:
    path = tmp_path / "rig-1000.json"
    path.write_text('{"rig": 10')
    with pytest.raises(RunDirError, match="not valid JSON"):
        read_part(path, 1000, KINDS, SCENARIOS)
