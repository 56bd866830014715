"""Model and Q-table artifacts and a run's report files are read trusting nothing.

Each crafted, damaged or oversized file is one ArtifactError/RunFileError line
naming the file; the issue's reproductions run as real processes (a surrogate
node on a crafted model, ``bench.py --stages report`` on a corrupt run), where
a crash or a traceback would show.
"""

from __future__ import annotations

import io
import json
import subprocess
import sys
import tracemalloc
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from msd_bench.core.errors import MsdBenchError
from msd_bench.graph import run_files
from msd_bench.gym.backends import model_backend
from msd_bench.io.storage import artifacts

REPO = Path(__file__).resolve().parents[2]
PINNED = REPO / "tests" / "data" / "pinned"
HEAD = {"schema": "msd-bench/model", "schema_version": 1, "name": "m", "info": {}}
META = {"schema": "msd-bench/qtable", "schema_version": 1, "seeds": [0]}


def _model(tmp: Path, **fields: Any) -> Path:
    path = tmp / "m.json"
    path.write_text(json.dumps({**HEAD, "kind": "linear", "params": [5.0, 0.01, 0, -1.9, 0.91, 0, 0],
                                **fields}))
    return path


@pytest.mark.parametrize(("fields", "match"), [
    ({"kind": "nlarx", "params": [1, 5e7, 1, 1, 0, 0, 0, 0, 0]}, r"\(S\) = 50000000.0 must be an integer"),
    ({"params": [0.5]}, r"got 1 parameter value\(s\)"),
    ({"kind": ["linear"]}, "unknown model kind"),
    ({"params": [True] * 7}, r"params\[0\] must be a number"),
    ({"params": [10**400] * 7}, "beyond the float range"),
    ({"params": "5, 1, 2"}, "params must be a list"),
    ({"params": [0.0] * 100_000}, "got 100000 values"),
    ({"name": 7}, "name must be a string"),
    ({"info": [1]}, "info an object"),
    ({"dt": "0.01"}, "dt must be a number"),
    ({"dt": -1}, "dt must be in"),
    ({"info": json.loads("[" * 40 + "]" * 40)}, "nested too deeply"),
    ({"schema_version": True}, "schema version True"),
])
def test_a_crafted_model_is_one_line(tmp_path: Path, fields: dict[str, Any], match: str) -> None:
    path = _model(tmp_path, **fields)
    with pytest.raises(artifacts.ArtifactError, match=match) as info:
        artifacts.load_model(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_the_gym_backend_refuses_a_crafted_model(tmp_path: Path) -> None:
    with pytest.raises(artifacts.ArtifactError, match="parameter value"):
        model_backend(str(_model(tmp_path, params=[0.5])), "default")
    with pytest.raises(MsdBenchError, match="artifact path or a StepModel"):
        model_backend(42, "default")  # type: ignore[arg-type]


def _npz(path: Path, meta: Any = META, **arrays: Any) -> Path:
    text = meta if isinstance(meta, str) else json.dumps(meta)
    with path.open("wb") as fh:
        np.savez_compressed(fh, meta=np.array(text), **arrays)
    return path


def _q(n_states: int = 100) -> np.ndarray:
    return np.zeros((1, n_states, 5))


def test_a_small_archive_that_expands_beyond_the_bound_is_refused_unread(tmp_path: Path) -> None:
    bomb = _npz(tmp_path / "bomb.npz", q=_q(2_000_000))  # 80 MB of zeros (the was 400 MB)
    assert bomb.stat().st_size < 1 << 20
    tracemalloc.start()
    try:
        with pytest.raises(artifacts.ArtifactError, match="expand to 80000516 bytes, more than"):
            artifacts.load_qtables(bomb)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 4 << 20  # numpy reports its allocations to tracemalloc: nothing near 80 MB


def _rewrite(path: Path, member: str, data: bytes, declared: int | None = None) -> None:
    """Replace ``member`` of the archive at ``path`` by ``data``, optionally lying about its size."""
    with zipfile.ZipFile(path) as zf:
        members = {i.filename: zf.read(i) for i in zf.infolist()}
    members[member] = data
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, body in members.items():
            zf.writestr(name, body)
    raw = bytearray(buf.getvalue())
    if declared is not None:  # the central directory's uncompressed size of the member
        at = raw.rfind(b"PK\x01\x02")
        while raw[at + 46: at + 46 + len(member)] != member.encode():
            at = raw.rfind(b"PK\x01\x02", 0, at)
        raw[at + 24: at + 28] = declared.to_bytes(4, "little")
    path.write_bytes(bytes(raw))


def _npy(shape: tuple[int, ...], dtype: str = "<f8", body: bytes | None = None) -> bytes:
    header = repr({"descr": dtype, "fortran_order": False, "shape": shape}).encode()
    header += b" " * (63 - len(header) % 64) + b"\n"
    data = body if body is not None else np.zeros(shape, dtype=dtype).tobytes()
    return b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header + data


@pytest.mark.parametrize(("damage", "match"), [
    ("truncate", "unreadable .npz archive"),
    ("flip", "unreadable .npz archive"),
    ("huge shape", "declares shape"),
    ("int q", "has dtype <i8; only float and string arrays"),
    ("2-D q", "must be a 3-D array"),
    ("nan q", "finite float64"),
    ("object q", "dtype |O"),
    ("short data", "holds 7 data bytes"),
    ("member lies small", "unreadable .npz archive"),
    ("nested meta", "nested too deeply"),
    ("meta not a string", "no metadata string"),
    ("meta not an object", "not a msd-bench/qtable artifact"),
    ("not npy", "uniquely named .npy"),
])
def test_a_damaged_qtable_archive_is_one_line(tmp_path: Path, damage: str, match: str) -> None:
    path = _npz(tmp_path / "q.npz", q=_q())
    raw = path.read_bytes()
    if damage == "truncate":
        path.write_bytes(raw[: len(raw) // 2])
    elif damage == "flip":
        path.write_bytes(raw[:60] + bytes([raw[60] ^ 0xFF]) + raw[61:])
    elif damage == "huge shape":
        _rewrite(path, "q.npy", _npy((1, 10**12, 5), body=b""))
    elif damage == "int q":
        path.unlink()
        _npz(path, q=np.zeros((1, 100, 5), dtype=np.int64))
    elif damage == "2-D q":
        _rewrite(path, "q.npy", _npy((100, 5)))
    elif damage == "nan q":
        _rewrite(path, "q.npy", _npy((1, 2, 5), body=np.full(10, np.nan).tobytes()))
    elif damage == "object q":
        _rewrite(path, "q.npy", _npy((1,), "|O", body=b"\x80\x04N."))
    elif damage == "short data":
        _rewrite(path, "q.npy", _npy((1, 2, 5), body=b"\x00" * 7))
    elif damage == "member lies small":
        _rewrite(path, "q.npy", _npy((1, 100, 5)), declared=200)
    elif damage == "nested meta":
        _rewrite(path, "meta.npy", np_bytes(np.array("[" * 50 + "]" * 50)))
    elif damage == "meta not a string":
        _rewrite(path, "meta.npy", _npy((1, 1, 1)))
    elif damage == "meta not an object":
        _rewrite(path, "meta.npy", np_bytes(np.array("[1]")))
    elif damage == "not npy":
        _rewrite(path, "evil.txt", b"hello")
    with pytest.raises(artifacts.ArtifactError, match=match) as info:
        artifacts.load_qtables(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def np_bytes(array: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, array)
    return buf.getvalue()


def test_a_big_endian_table_is_read_as_native_float64(tmp_path: Path) -> None:
    q = np.arange(10.0).reshape(1, 2, 5)
    arrays, _ = artifacts.load_qtables(_npz(tmp_path / "q.npz", q=q.astype(">f8")))
    assert arrays["q"].dtype == np.float64 and arrays["q"].dtype.isnative
    np.testing.assert_array_equal(arrays["q"], q)


def _learner_meta(**learner: Any) -> dict[str, Any]:
    from dataclasses import asdict

    from msd_bench.core.learning.qconfig import QConfig

    return {**META, "learner": {**asdict(QConfig()), **learner}}


@pytest.mark.parametrize(("meta", "q", "match"), [
    (_learner_meta(), _q(99), r"q has shape \(1, 99, 5\)"),
    (_learner_meta(n_states="100"), _q(), "learner field 'n_states' has the wrong type"),
    (_learner_meta(n_states=10**30), _q(), "need"),
    (_learner_meta(alpha=None), _q(), "learner field 'alpha'"),
    (_learner_meta(unknown=1), _q(), "does not fit this msd-bench"),
    ({**_learner_meta(), "seeds": [True]}, _q(), "seeds must be a non-empty list of integers"),
    ({**_learner_meta(), "seeds": [0, 1]}, _q(), "2 seed"),
    (META, _q(), "carries no learner config"),
])
def test_qtables_must_fit_their_learner(tmp_path: Path, meta: dict[str, Any], q: np.ndarray,
                                        match: str) -> None:
    path = _npz(tmp_path / "q.npz", meta, q=q, first=q, last=q)
    with pytest.raises(MsdBenchError, match=match) as info:
        run_files.read_qtables(path)
    assert str(path) in str(info.value)


def test_a_qtable_that_fits_its_learner_is_read(tmp_path: Path) -> None:
    path = _npz(tmp_path / "q.npz", _learner_meta(), q=_q(), first=_q(), last=_q())
    tables = run_files.read_qtables(path)
    assert tables.seeds == [0] and tables.learner.n_states == 100


GOOD_ROW = {"seed": 0, "id_seed": 0, "mae": 0.1, "std": 0.1, "po": None, "ts": None, "ts5": 1.0,
            "sse": 0.5, "success": True}
GOOD_RESULT = {"training": "in-process", "per_seed": [GOOD_ROW], "real_interactions": 0}


@pytest.mark.parametrize(("doc", "match"), [
    ("{", "not valid JSON"),
    ("[]", "expected a JSON object"),
    (json.dumps({**GOOD_RESULT, "per_seed": 7}), "per_seed must be a list"),
    (json.dumps({**GOOD_RESULT, "per_seed": []}), "per_seed is empty"),
    (json.dumps({**GOOD_RESULT, "per_seed": [{**GOOD_ROW, "seed": "0"}]}), r"per_seed\[0\].seed"),
    (json.dumps({**GOOD_RESULT, "per_seed": [{**GOOD_ROW, "sse": None}]}), "sse and mae must be numbers"),
    (json.dumps({**GOOD_RESULT, "per_seed": [{**GOOD_ROW, "success": 1}]}), "success must be"),
    (json.dumps({**GOOD_RESULT, "real_interactions": -1}), "real_interactions must be a non-negative"),
    (json.dumps({**GOOD_RESULT, "on_node_scenarios": {"a": {"n": 1, "n_success": 2}}}), "exceeds n"),
    ("[" * 100 + "]" * 100, "nested too deeply"),
    (" " * (17 << 20), "exceeds the"),
])
def test_a_corrupt_result_json_is_one_line(tmp_path: Path, doc: str, match: str) -> None:
    path = tmp_path / "result.json"
    path.write_text(doc)
    with pytest.raises(run_files.RunFileError, match=match) as info:
        run_files.read_result(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


FIT = {"model": "glm", "sim_fit": 90.0, "one_step_fit": 99.0, "n_identification": 10, "n_validation": 5,
       "fit_seconds": None}


@pytest.mark.parametrize(("doc", "match"), [
    ({"glm": {**FIT, "sim_fit": "90"}}, "field sim_fit has the wrong type"),
    ({"glm": {**FIT, "extra": 1}}, "unknown field"),
    ({"glm": {k: v for k, v in FIT.items() if k != "sim_fit"}}, "lacks field"),
    ({"glm": [1]}, "must be an object"),
    ({"glm": {"\n": None}}, r"unknown field\(s\) '\\n'"),  # found by the fuzz tier: a key is quoted
])
def test_a_corrupt_fits_json_is_one_line(tmp_path: Path, doc: Any, match: str) -> None:
    path = tmp_path / "fits.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(run_files.RunFileError, match=match) as info:
        run_files.read_fits(path)
    assert "\n" not in str(info.value)


def test_good_run_files_are_read(tmp_path: Path) -> None:
    (tmp_path / "fits.json").write_text(json.dumps({"glm": FIT}))
    assert np.isnan(run_files.read_fits(tmp_path / "fits.json")["glm"].fit_seconds)
    (tmp_path / "result.json").write_text(json.dumps(GOOD_RESULT))
    assert run_files.read_result(tmp_path / "result.json").per_seed == [GOOD_ROW]
    (tmp_path / "run.json").write_text('{"timings": {"record": 1.5}}')
    assert run_files.read_run_facts(tmp_path / "run.json")["timings"] == {"record": 1.5}
    (tmp_path / "run.json").write_text('{"timings": [1, 2]}')
    with pytest.raises(run_files.RunFileError, match="timings must be an object"):
        run_files.read_run_facts(tmp_path / "run.json")


def test_a_surrogate_process_on_a_crafted_model_exits_2_with_one_line(tmp_path: Path) -> None:
    path = _model(tmp_path, kind="nlarx", params=[1, 5e7, 1, 1, 0, 0, 0, 0, 0])  # was exit 139
    proc = subprocess.run([sys.executable, "launch_scripts/surrogate.py", "--ros-args", "-p",
                           f"model_path:={path}", "-p", "lockstep:=true"],
                          cwd=REPO, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().count("\n") == 0 and "must be an integer in [1, 1024]" in proc.stderr
    assert "Traceback" not in proc.stdout + proc.stderr


def test_the_report_stage_on_a_corrupt_result_json_exits_2_with_one_line(tmp_path: Path) -> None:
    run = tmp_path / "run"
    (run / "agents" / "glm").mkdir(parents=True)
    (run / "agents" / "glm" / "result.json").write_text('{"training": "in-process", "per_seed": 7}')
    proc = subprocess.run([sys.executable, "launch_scripts/bench.py", "--stages", "report", "--out",
                           str(run), "--agents", "glm"], cwd=REPO, capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 2, proc.stderr
    errors = [line for line in proc.stderr.splitlines() if "error" in line]
    assert errors == [f"bench: error: {run}/agents/glm/result.json: per_seed must be a list, got int"]
    assert "Traceback" not in proc.stdout + proc.stderr
    assert (run / "agents" / "glm" / "result.json").read_text().endswith("7}")  # left as it was
