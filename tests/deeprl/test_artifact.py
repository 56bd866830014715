"""The deep-RL policy artifact: a round trip without SB3, and every defect one ArtifactError line."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest

from msd_bench.core.deeprl import mlp
from msd_bench.io.storage.artifacts import ArtifactError
from msd_bench.io.storage.deeprl_artifact import load_policy, paths, save_policy
from tests.deeprl.conftest import random_net

META = {"kind": "plant+dqn", "algo": "dqn", "seeds": [0, 1], "steps": 900_000,
        "hyper": {"learning_rate": 1e-4}, "stable_baselines3": "2.9.0", "torch": "2.13.0"}


def _saved(tmp_path: Path) -> Path:
    stem = tmp_path / "plant_dqn"
    save_policy(stem, random_net(3, n=2), META)
    return stem


def test_round_trip_keeps_every_weight_and_the_provenance(tmp_path: Path) -> None:
    net = random_net(3, n=2, activation=mlp.TANH)
    stem = tmp_path / "p"
    save_policy(stem, net, META)
    back, meta = load_policy(stem)
    assert all(np.array_equal(a, b) for a, b in zip(net[:6], back[:6], strict=True))
    assert back.activation == mlp.TANH
    assert meta["stable_baselines3"] == "2.9.0" and meta["seeds"] == [0, 1] and meta["n_policies"] == 2


def test_an_existing_artifact_is_never_overwritten(tmp_path: Path) -> None:
    stem = _saved(tmp_path)
    before = paths(stem)[1].read_bytes()
    with pytest.raises(ArtifactError, match="already exists"):
        save_policy(stem, random_net(4, n=2), META)
    assert paths(stem)[1].read_bytes() == before


def _rewrite_meta(stem: Path, **change: object) -> None:
    meta_path = paths(stem)[0]
    doc = json.loads(meta_path.read_text())
    doc.update(change)
    meta_path.write_text(json.dumps(doc))


@pytest.mark.parametrize(("change", "message"), [
    ({"schema": "msd-bench/qtable"}, "not a msd-bench/deeprl-policy artifact"),
    ({"schema_version": 2}, "schema version 2 is not 1"),
    ({"activation": "gelu"}, "activation must be one of"),
    ({"features": {"pos_scale": 1.0}}, "feature scaling"),
    ({"n_policies": True}, "n_policies must be a positive integer"),
    ({"n_policies": 3}, "need 3 policies"),
    ({"weights_sha256": "00"}, "weights_sha256 must be a 64-digit"),
    ({"weights_sha256": "0" * 64}, "do not match the SHA-256"),
    ({"weights": "../other.npz"}, "weights must name"),
])
def test_a_bad_meta_file_is_one_line(tmp_path: Path, change: dict[str, object], message: str) -> None:
    stem = _saved(tmp_path)
    _rewrite_meta(stem, **change)
    with pytest.raises(ArtifactError, match=message) as info:
        load_policy(stem)
    assert "\n" not in str(info.value)


def _replace_weights(stem: Path, arrays: dict[str, np.ndarray]) -> None:
    buf = io.BytesIO()
    np.savez(buf, **arrays)  # type: ignore[arg-type]
    data = buf.getvalue()
    paths(stem)[1].write_bytes(data)
    import hashlib

    _rewrite_meta(stem, weights_sha256=hashlib.sha256(data).hexdigest())


def test_weights_that_do_not_chain_or_are_not_finite_are_one_line(tmp_path: Path) -> None:
    stem = _saved(tmp_path)
    good = dict(zip(("w1", "b1", "w2", "b2", "w3", "b3"), random_net(3, n=2)[:6], strict=True))
    _replace_weights(stem, {**good, "w2": good["w2"][:, :, :3]})
    with pytest.raises(ArtifactError, match="do not chain"):
        load_policy(stem)
    bad = good["b3"].copy()
    bad[0, 0] = np.inf
    _replace_weights(stem, {**good, "b3": bad})
    with pytest.raises(ArtifactError, match="must be finite"):
        load_policy(stem)
    _replace_weights(stem, {k: v for k, v in good.items() if k != "b1"})
    with pytest.raises(ArtifactError, match="members must be"):
        load_policy(stem)


def test_missing_files_and_garbage_are_one_line(tmp_path: Path) -> None:
    with pytest.raises(ArtifactError, match="no such deep-RL policy artifact"):
        load_policy(tmp_path / "none")
    stem = _saved(tmp_path)
    paths(stem)[1].unlink()
    with pytest.raises(ArtifactError, match=r"weights archive of plant_dqn\.json is missing"):
        load_policy(stem)
    paths(stem)[0].write_text("{not json")
    with pytest.raises(ArtifactError, match="not valid JSON"):
        load_policy(stem)
