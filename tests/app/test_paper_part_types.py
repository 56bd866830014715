"""A paper part read back by the report stage: every field type-checked, one line naming file and field."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import pytest

from msd_bench.app.paper_tasks import _part_kinds
from msd_bench.io.storage.run_dir import RunDirError

ROW = {"seed": 0, "id_seed": 0, "mae": 2.5, "std": 1.0, "po": 3.0, "ts": 4.0, "ts5": None, "sse": 0.5,
       "success": True}
PART = {"kinds": {"glm": {"seeds": [0], "per_seed": [ROW], "cells": {}}}}


def _with(path: tuple[Any, ...], value: Any) -> dict[str, Any]:
    doc = copy.deepcopy(PART)
    node: Any = doc
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return doc


def test_a_well_formed_part_is_read() -> None:
    assert _part_kinds(copy.deepcopy(PART), Path("parts/id0.json")) == PART["kinds"]


def test_a_deterministic_kind_has_one_row_for_all_its_seeds() -> None:
    """A baseline is one nominal run per identified model whatever the seeds (its copies are not n)."""
    doc = copy.deepcopy(PART)
    entry = doc["kinds"]["glm"]
    entry["seeds"] = [*entry["seeds"], max(entry["seeds"]) + 1]
    assert len(entry["per_seed"]) < len(entry["seeds"])
    assert _part_kinds(doc, Path("parts/id0.json"))["glm"]["per_seed"] == entry["per_seed"]


@pytest.mark.parametrize(("path", "value", "said"), [
    (("kinds", "glm", "per_seed", 0, "ts"), "4.0", "kinds['glm'].per_seed[0].ts must be a number or null"),
    (("kinds", "glm", "per_seed", 0, "seed"), 0.5, "kinds['glm'].per_seed[0].seed must be an integer"),
    (("kinds", "glm", "per_seed", 0, "success"), "yes", "kinds['glm'].per_seed[0].success must be true or"),
    (("kinds", "glm", "seeds"), ["0"], "kinds['glm'].seeds must be a list of integers"),
    (("kinds", "glm", "per_seed"), [], "kinds['glm'].per_seed must be a list of one row per member"),
    (("kinds", "glm", "cells"), [], "kinds['glm'].cells must be an object"),
    (("kinds", "glm"), "x", "kinds['glm'] must be an object"),
    (("kinds",), [], "kinds must be an object"),
])
def test_a_wrong_typed_field_is_one_line_naming_file_and_field(path: tuple[Any, ...], value: Any,
                                                               said: str) -> None:
    with pytest.raises(RunDirError) as err:
        _part_kinds(_with(path, value), Path("R/parts/id0.json"))
    assert str(err.value).startswith(f"R/parts/id0.json: {said}")
    assert "\n" not in str(err.value)
