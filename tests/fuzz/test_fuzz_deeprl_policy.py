"""Fuzz: deep-RL policy artifacts (``<stem>.json`` meta + ``<stem>.npz`` weights).

Property: whatever the bytes of either file, ``load_policy`` returns a network
that chains and is finite, or raises one ArtifactError line; it never leaks a
zipfile, zlib, numpy, JSON or key/type exception. Inputs: the meta replaced by
random JSON or with one field set to a random value; the archive truncated,
bit-flipped or replaced by random bytes, its SHA-256 in the meta updated so
the archive reader itself is reached.
"""

from __future__ import annotations

import hashlib
import json
import tempfile
from pathlib import Path
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from msd_bench.core.deeprl import mlp
from msd_bench.io.storage.artifacts import ArtifactError
from msd_bench.io.storage.deeprl_artifact import load_policy, paths, save_policy
from tests.deeprl.conftest import random_net
from tests.fuzz.json_values import JSON

FIELDS = ("schema", "schema_version", "activation", "features", "n_policies", "weights", "weights_sha256")


def _fresh(tmp: Path) -> Path:
    stem = tmp / "p"
    save_policy(stem, random_net(2, n=2, hidden=(4, 4)), {"kind": "plant+ppo"})
    return stem


def _load_is_clean(stem: Path) -> None:
    try:
        net, _ = load_policy(stem)
    except ArtifactError as exc:
        assert "\n" not in str(exc)
        return
    mlp.check_net(net)


@given(field=st.sampled_from(FIELDS), value=JSON)
def test_any_meta_field_value_is_a_clean_load_or_one_line(field: str, value: Any) -> None:
    with tempfile.TemporaryDirectory() as d:
        stem = _fresh(Path(d))
        meta = paths(stem)[0]
        doc = json.loads(meta.read_text())
        doc[field] = value
        meta.write_text(json.dumps(doc))
        _load_is_clean(stem)


@given(doc=JSON)
def test_any_json_document_as_meta_is_one_line(doc: Any) -> None:
    with tempfile.TemporaryDirectory() as d:
        stem = _fresh(Path(d))
        paths(stem)[0].write_text(json.dumps(doc))
        _load_is_clean(stem)


@given(cut=st.integers(0, 4000), flips=st.lists(st.tuples(st.integers(0, 4000), st.integers(1, 255)),
                                                max_size=4), noise=st.none() | st.binary(max_size=600))
def test_damaged_weights_are_a_clean_load_or_one_line(cut: int, flips: list[tuple[int, int]],
                                                      noise: bytes | None) -> None:
    with tempfile.TemporaryDirectory() as d:
        stem = _fresh(Path(d))
        meta, npz = paths(stem)
        data = bytearray(npz.read_bytes() if noise is None else noise)
        for at, bits in flips:
            if data:
                data[at % len(data)] ^= bits
        data = data[:cut] if cut < len(data) else data
        npz.write_bytes(bytes(data))
        doc = json.loads(meta.read_text())
        doc["weights_sha256"] = hashlib.sha256(bytes(data)).hexdigest()
        meta.write_text(json.dumps(doc))
        _load_is_clean(stem)
