"""``PolicyBase``: the fields, ``policy.json`` and no-figures the non-tabular policies share."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import pytest

from msd_bench.designs.baselines import BaselinePolicy
from msd_bench.designs.deeprl import DeepPolicy
from msd_bench.designs.protocol import Facts, PolicyBase
from msd_bench.io.storage.artifacts import ArtifactError


@dataclass(frozen=True)
class _Gain(PolicyBase):
    gain: float = 1.0


def test_a_subclass_writes_policy_json_with_its_files_and_body_and_draws_nothing(tmp_path: Path) -> None:
    p = _Gain("glm+gain", (4,), Facts("gain", True, True, 0), 2.5)
    path = p.write_policy(tmp_path, {"by": "test"}, tmp_path, False, {"weights": "w.json"}, {"gain": p.gain})
    doc = json.loads(path.read_text())
    assert path == tmp_path / "policy.json" and doc["kind"] == "glm+gain" and doc["design"] == "gain"
    assert doc["members"] == [4] and doc["files"] == {"weights": "w.json"} and doc["body"] == {"gain": 2.5}
    assert doc["facts"]["deterministic"] is True and p.figures(tmp_path, tmp_path) == []
    with pytest.raises(ArtifactError):  # never over a file it may not have written
        p.write_policy(tmp_path, {}, tmp_path, False, {}, {})
    assert json.loads(path.read_text())["body"] == {"gain": 2.5}
    p.write_policy(tmp_path, {}, tmp_path, True, {}, {"gain": 3.0})  # a rerun into its own directory
    assert json.loads(path.read_text())["body"] == {"gain": 3.0}


def test_the_baselines_and_the_deep_policies_share_it() -> None:
    assert issubclass(BaselinePolicy, PolicyBase) and issubclass(DeepPolicy, PolicyBase)
