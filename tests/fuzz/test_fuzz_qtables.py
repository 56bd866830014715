"""Fuzz: Q-table ``.npz`` artifacts and their metadata.

Property: whatever the bytes, ``load_qtables`` (and the report's
``read_qtables`` on top of it) returns tables of finite float64, or raises one
ArtifactError/RunFileError line naming the file; it never leaks a zipfile,
zlib or numpy exception, and never allocates more than :data:`PEAK` (every
input here is under 1 MiB, so a reader that honours its bounds stays far
below; numpy reports its buffers to tracemalloc).

Inputs: a valid artifact truncated, bit-flipped or overwritten; members
replaced by ``.npy`` headers declaring random (huge, negative, mis-typed)
shapes and dtypes over short bodies; the central directory lying about a
member's sizes; and the metadata replaced by random, wrong-typed or deeply
nested JSON.
"""

from __future__ import annotations

import io
import json
import struct
import tempfile
import tracemalloc
import zipfile
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from msd_bench.core.errors import MsdBenchError
from msd_bench.core.learning.qconfig import QConfig
from msd_bench.graph.run_files import read_qtables
from msd_bench.io.storage.artifacts import load_qtables
from tests.fuzz.json_values import JSON, nested

PEAK = 16 << 20
"""Most memory one read may allocate (inputs are under 1 MiB; the archive bound is 64 MiB)."""

META = {"schema": "msd-bench/qtable", "schema_version": 1, "seeds": [0, 1], "learner": asdict(QConfig())}


def _npy(array: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, array)
    return buf.getvalue()


def _zip(members: dict[str, bytes], method: int = zipfile.ZIP_DEFLATED) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", method) as zf:
        for name, body in members.items():
            zf.writestr(name, body)
    return buf.getvalue()


def _members(meta: Any = META, q: np.ndarray | None = None) -> dict[str, bytes]:
    table = np.random.default_rng(0).normal(size=(2, 100, 5)) if q is None else q
    text = meta if isinstance(meta, str) else json.dumps(meta)
    return {"meta.npy": _npy(np.array(text)), "q.npy": _npy(table), "first.npy": _npy(table),
            "last.npy": _npy(table)}


VALID = _zip(_members())


def outcome(data: bytes) -> str:
    """Read ``data`` as a Q-table artifact both ways; ``"ok"``, ``"refused"`` or what went wrong."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "qtables.npz"
        path.write_bytes(data)
        tracemalloc.start()
        try:
            arrays, _ = load_qtables(path)
            assert all(a.dtype == np.float64 and np.all(np.isfinite(a)) for a in arrays.values())
            tables = read_qtables(path)
            assert tables.arrays["q"].shape[0] == len(tables.seeds)
            verdict = "ok"
        except MsdBenchError as exc:
            assert "\n" not in str(exc) and str(path) in str(exc), str(exc)
            verdict = "refused"
        finally:
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
    assert peak < PEAK, f"a read of {len(data)} bytes allocated {peak} bytes"
    return verdict


def test_the_valid_artifact_is_read() -> None:
    assert outcome(VALID) == "ok"


@given(cut=st.integers(0, len(VALID) - 1))
def test_a_truncated_archive(cut: int) -> None:
    assert outcome(VALID[:cut]) == "refused"


@given(flips=st.lists(st.tuples(st.integers(0, len(VALID) - 1), st.integers(1, 255)), min_size=1, max_size=8))
def test_a_bit_flipped_archive(flips: list[tuple[int, int]]) -> None:
    data = bytearray(VALID)
    for at, mask in flips:
        data[at] ^= mask
    outcome(bytes(data))


@given(at=st.integers(0, len(VALID)), junk=st.binary(min_size=1, max_size=64))
def test_an_overwritten_archive(at: int, junk: bytes) -> None:
    outcome(VALID[:at] + junk + VALID[at + len(junk):])


DESCRS = st.sampled_from(["<f8", ">f8", "<f4", "<f2", "<i8", "|u1", "|b1", "<c16", "|O", "<U10",
                          "<U1000000000",
                          "|V8", "<M8[s]", "S5", [("a", "<f8")], [("a", "<f8", (2,))], ("<f8", (3,)), "bogus",
                          7, None])
SHAPES = st.one_of(st.lists(st.integers(-3, 400), max_size=4).map(tuple),
                   st.lists(st.sampled_from([0, 1, 5, 10**6, 10**12, 2**62, 2**63 - 1, 2**64, -(2**63)]),
                            max_size=4).map(tuple),
                   st.sampled_from([(), (1, 100, 5), (2, 100, 5), [2, 100, 5], "2,100,5", None]))


def _header(descr: Any, shape: Any, fortran: Any, version: int) -> bytes:
    text = repr({"descr": descr, "fortran_order": fortran, "shape": shape}).encode("latin1", "replace")
    text += b" " * (63 - (len(text) + 10) % 64) + b"\n"
    size = struct.pack("<H", len(text)) if version == 1 else struct.pack("<I", len(text))
    return b"\x93NUMPY" + bytes([version, 0]) + size + text


@given(descr=DESCRS, shape=SHAPES, fortran=st.sampled_from([False, True, 0, "no"]),
       version=st.sampled_from([1, 2, 3, 9]), body=st.binary(max_size=4096),
       member=st.sampled_from(["q.npy", "first.npy", "meta.npy", "extra.npy"]),
       stored=st.booleans())
def test_a_member_with_a_crafted_npy_header(descr: Any, shape: Any, fortran: Any, version: int, body: bytes,
                                            member: str, stored: bool) -> None:
    members = _members()
    members[member] = _header(descr, shape, fortran, version) + body
    outcome(_zip(members, zipfile.ZIP_STORED if stored else zipfile.ZIP_DEFLATED))


def _central_entries(data: bytes) -> list[int]:
    at, out = 0, []
    while (at := data.find(b"PK\x01\x02", at)) >= 0:
        out.append(at)
        at += 4
    return out


@given(which=st.integers(0, 3), field=st.sampled_from([20, 24]),
       size=st.one_of(st.integers(0, 2**32 - 1), st.sampled_from([0, 1, 100, 4000, 64 << 20, 2**32 - 1])))
def test_the_central_directory_lies_about_a_member_size(which: int, field: int, size: int) -> None:
    """Offset 20 is the compressed size, 24 the uncompressed size of a central directory entry."""
    data = bytearray(VALID)
    at = _central_entries(VALID)[which] + field
    data[at: at + 4] = struct.pack("<I", size)
    outcome(bytes(data))


LEARNER_FIELDS = st.sampled_from(sorted(asdict(QConfig())))


@st.composite
def metadata(draw: st.DrawFn) -> Any:
    """The metadata string: random JSON or text, deep nesting, or the valid meta with fields replaced."""
    how = draw(st.sampled_from(["json", "text", "deep", "field", "learner", "learner"]))
    if how == "json":
        return json.dumps(draw(JSON))
    if how == "text":
        return draw(st.text(max_size=100))
    if how == "deep":
        depth = draw(st.integers(1, 20000))
        return nested('{"schema": "msd-bench/qtable", "schema_version": 1, "seeds": ', depth)
    meta = json.loads(json.dumps(META))
    if how == "field":
        meta[draw(st.sampled_from(["schema", "schema_version", "seeds", "learner", "extra"]))] = draw(JSON)
    else:
        for _ in range(draw(st.integers(1, 3))):
            value = draw(st.one_of(JSON, st.sampled_from([0, -1, 2**63, 10**400, 1e308, 3, 99, 101, 1e-9])))
            meta["learner"][draw(LEARNER_FIELDS)] = value
    return json.dumps(meta)


@given(meta=metadata())
def test_random_or_wrong_typed_metadata(meta: str) -> None:
    outcome(_zip(_members(meta)))


@given(shape=st.lists(st.integers(0, 6), min_size=0, max_size=4).map(tuple),
       dtype=st.sampled_from([np.float64, np.float32, np.int64, np.bool_, np.complex128]))
def test_tables_of_another_shape_or_dtype(shape: tuple[int, ...], dtype: Any) -> None:
    assert outcome(_zip(_members(q=np.zeros(shape, dtype=dtype)))) == "refused"
