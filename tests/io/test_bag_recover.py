"""Recovery of killed/truncated recordings, SIGKILL/SIGTERM of a recording process, the bag CLI."""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from msd_bench.commands.bag import main as bag_main
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_recover import recover
from msd_bench.io.bags.reader import BagRecorder, read_experiment, read_topic, typestore

REPO = Path(__file__).resolve().parents[2]
STORE = typestore()
PER_CHUNK = 25
CHUNKS = 8
PARAMS = {"seed": 11}


def _joint_state(k: int) -> bytes:
    types = STORE.types
    ns = 10_000_000 * k
    msg = types["sensor_msgs/msg/JointState"](
        header=types["std_msgs/msg/Header"](
            stamp=types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
            frame_id="",
        ),
        name=["msd_slider"],
        position=np.array([0.001 * k]),
        velocity=np.array([0.0]),
        effort=np.array([float(k % 7)]),
    )
    return bytes(STORE.serialize_cdr(msg, "sensor_msgs/msg/JointState"))


@pytest.fixture()
def chunked(tmp_path: Path) -> Path:
    """A bag of CHUNKS chunks of PER_CHUNK joint states each (a chunk boundary every flush)."""
    path = tmp_path / "rec"
    with BagRecorder(path, params=PARAMS) as rec:
        for k in range(PER_CHUNK * CHUNKS):
            rec.write("/msd/joint_states", "sensor_msgs/msg/JointState", 10_000_000 * k, _joint_state(k))
            if (k + 1) % PER_CHUNK == 0:
                rec.flush()
    return path


def _chunk_spans(bag: Path) -> list[tuple[int, int]]:
    with (bag / f"{bag.name}.mcap").open("rb") as fh:
        idx = make_reader(fh).get_summary().chunk_indexes
    return [(c.chunk_start_offset, c.chunk_length) for c in idx]


def _kill_like(bag: Path, size: int) -> None:
    """What a SIGKILL leaves: the file cut at ``size``, no metadata.yaml."""
    with (bag / f"{bag.name}.mcap").open("r+b") as fh:
        fh.truncate(size)
    (bag / "metadata.yaml").unlink()


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _assert_prefix(bag: Path, n: int) -> None:
    exp, params = read_experiment(bag)
    k = np.arange(n)
    np.testing.assert_array_equal(exp.y, 0.001 * k)
    np.testing.assert_array_equal(exp.u, (k % 7).astype(float))
    assert params == PARAMS


def test_fixture_has_the_chunks_we_assume(chunked: Path) -> None:
    assert len(_chunk_spans(chunked)) == CHUNKS


@pytest.mark.parametrize("chunk", [1, 4, 7])
@pytest.mark.parametrize("where", ["mid", "end"])
def test_truncation_recovers_every_complete_chunk(chunked: Path, chunk: int, where: str) -> None:
    start, length = _chunk_spans(chunked)[chunk]
    cut = start + length // 2 if where == "mid" else start + length
    _kill_like(chunked, cut)
    mcap_file = chunked / "rec.mcap"
    before = _sha(mcap_file)
    with pytest.raises(BagError, match=r"metadata\.yaml"):
        read_experiment(chunked)
    report = recover(chunked)
    complete = chunk if where == "mid" else chunk + 1
    assert report.chunks == complete
    assert report.messages == complete * PER_CHUNK
    assert report.output == chunked.with_name("rec.recovered")
    assert _sha(mcap_file) == before  # the original is never modified
    _assert_prefix(report.output, complete * PER_CHUNK)


def test_corrupt_chunk_stops_recovery_before_it(chunked: Path) -> None:
    start, length = _chunk_spans(chunked)[3]
    data = bytearray((chunked / "rec.mcap").read_bytes())
    data[start + length - 20] ^= 0xFF  # in the last message of chunk 3
    (chunked / "rec.mcap").write_bytes(bytes(data))
    (chunked / "metadata.yaml").unlink()
    report = recover(chunked)
    assert report.chunks == 3
    assert "crc" in report.stopped.lower()
    _assert_prefix(report.output, 3 * PER_CHUNK)


def test_recover_refuses_to_overwrite_and_needs_data(chunked: Path) -> None:
    _kill_like(chunked, _chunk_spans(chunked)[2][0])
    recover(chunked)
    with pytest.raises(BagError, match="exists already"):
        recover(chunked)
    assert recover(chunked, overwrite=True).messages == 2 * PER_CHUNK
    empty = chunked.with_name("tiny")
    BagRecorder(empty).open().close()
    _kill_like(empty, 80)  # a recording killed before its first chunk
    with pytest.raises(BagError, match="no complete chunk"):
        recover(empty)


CHILD = """
import signal, sys, time
import numpy as np
from msd_bench.io.bags.reader import BagRecorder, typestore

def on_term(signum, frame):
    raise KeyboardInterrupt

signal.signal(signal.SIGTERM, on_term)
store = typestore()
T = store.types
rec = BagRecorder(sys.argv[1], params={"child": True}, flush_period_s=1.0).open()
k = 0
try:
    while True:
        ns = 10_000_000 * k
        js = T["sensor_msgs/msg/JointState"](
            header=T["std_msgs/msg/Header"](
                stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
                frame_id=""),
            name=["msd_slider"], position=np.array([float(k)]), velocity=np.array([0.0]),
            effort=np.array([1.0]))
        rec.write("/msd/joint_states", "sensor_msgs/msg/JointState", ns,
                  store.serialize_cdr(js, "sensor_msgs/msg/JointState"))
        rec.write("/msd/position", "std_msgs/msg/Float64", ns,
                  store.serialize_cdr(T["std_msgs/msg/Float64"](data=float(k)), "std_msgs/msg/Float64"))
        k += 1
        print(k, flush=True)
        time.sleep(0.01)  # never faster than 100 Hz, even after a stall
except KeyboardInterrupt:
    pass
finally:
    rec.close()
"""


def _start_child(bag: Path) -> subprocess.Popen[str]:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(bag)], stdout=subprocess.PIPE, text=True, env=env, cwd=REPO
    )
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == "1"  # recording has started
    return proc


def _stop_child(proc: subprocess.Popen[str], sig: int, after_s: float) -> int:
    """Send ``sig`` after ``after_s``; return the number of samples the child reported written."""
    time.sleep(after_s)
    proc.send_signal(sig)
    out, _ = proc.communicate(timeout=20)
    lines = out.split()
    return int(lines[-1]) if lines else 1


def test_sigkilled_recording_loses_at_most_one_flush_period(tmp_path: Path) -> None:
    bag = tmp_path / "killed"
    proc = _start_child(bag)
    written = _stop_child(proc, signal.SIGKILL, 3.0)
    assert proc.returncode == -signal.SIGKILL
    assert written > 150  # the child really streamed for seconds
    assert not (bag / "metadata.yaml").exists()
    report = recover(bag)
    _, msgs = read_topic(report.output, "/msd/joint_states")
    got = len(msgs)
    # at most one flush period (1 s, ≤ 100 samples at ≤ 100 Hz) is lost; +1: killed mid-print
    assert written - 105 <= got <= written + 1
    assert [m.position[0] for m in msgs] == [float(k) for k in range(got)]
    assert report.counts["/msd/position"] >= got - 1
    assert read_experiment(report.output)[1] == {"child": True}


def test_sigterm_closes_a_complete_bag(tmp_path: Path) -> None:
    bag = tmp_path / "termed"
    proc = _start_child(bag)
    written = _stop_child(proc, signal.SIGTERM, 1.5)
    assert proc.returncode == 0
    exp, params = read_experiment(bag)  # readable directly, no recovery needed
    assert written <= len(exp) <= written + 1
    np.testing.assert_array_equal(exp.y, np.arange(len(exp), dtype=float))
    assert params == {"child": True}


def test_cli_info_and_recover(chunked: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert bag_main(["bag", "info", str(chunked)]) == 0
    out = capsys.readouterr().out
    assert "/msd/joint_states  [sensor_msgs/msg/JointState]  200 messages" in out
    assert '{"seed": 11}' in out
    _kill_like(chunked, _chunk_spans(chunked)[5][0] + 10)
    assert bag_main(["bag", "recover", str(chunked)]) == 0
    out = capsys.readouterr().out
    assert "recovered 125 messages (5 chunks)" in out
    assert "original left untouched" in out


def test_cli_errors_are_one_line_with_status_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert bag_main(["bag", "info", str(tmp_path / "missing")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: bag ") and "Traceback" not in err


def test_cli_as_a_process_prints_no_traceback(tmp_path: Path) -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "msd_bench.commands.bag", "bag", "recover", str(tmp_path / "x")],
        capture_output=True, text=True, cwd=REPO, env={**os.environ, "PYTHONPATH": str(REPO)},
        timeout=60, check=False,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().startswith("error: bag ") and "Traceback" not in proc.stderr


def test_recover_keeps_a_message_type_the_typestore_lacks(tmp_path: Path) -> None:
    from rosbags.typesys import get_types_from_msg

    store = typestore()
    store.register(get_types_from_msg("float64 a\nint32 b", "my_pkg/msg/Custom"))
    custom = store.types["my_pkg/msg/Custom"]
    path = tmp_path / "custom"
    with BagRecorder(path, store=store) as rec:
        for k in range(10):
            data = store.serialize_cdr(custom(a=0.5 * k, b=k), "my_pkg/msg/Custom")
            rec.write("/x", "my_pkg/msg/Custom", k, data)
    start, length = _chunk_spans(path)[0]
    _kill_like(path, start + length)
    report = recover(path)  # the schema comes from the bag itself
    assert [m.b for m in read_topic(report.output, "/x")[1]] == list(range(10))
