"""Bytes-level tests of the bag layer (docs/design.md §Tests): round trip, truncation, corruption, topics."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.stream_reader import CRCValidationError
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin, Writer

from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.reader import (
    BagRecorder,
    bag_info,
    read_experiment,
    read_topic,
    typestore,
    write_experiment,
)

N = 400
T0 = 1_700_000_000_123_456_789
PARAMS = {"seed": 7, "bias_n": 5.0, "kind": "prbs"}
STORE = typestore()


def _arrays(n: int = N) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(3)
    t = T0 + np.arange(n, dtype=np.int64) * 10_000_000
    u = rng.choice([-10.0, -5.0, 0.0, 5.0, 10.0], n)
    x = rng.normal(0.0, 1.0, n)
    v = rng.normal(0.0, 2.0, n)
    return t, u, x, v


def _float64(value: float) -> bytes:
    msg = STORE.types["std_msgs/msg/Float64"](data=value)
    return bytes(STORE.serialize_cdr(msg, "std_msgs/msg/Float64"))


@pytest.fixture()
def bag(tmp_path: Path) -> Path:
    t, u, x, v = _arrays()
    return write_experiment(tmp_path / "exp", t, u, x, v, params=PARAMS)


def _mcap(bag: Path) -> Path:
    return bag / f"{bag.name}.mcap"


def _assert_one_line(err: BagError, *needles: str) -> None:
    text = str(err)
    assert "\n" not in text
    for needle in needles:
        assert needle in text


def test_round_trip_is_exact_in_our_reader(bag: Path) -> None:
    _, u, x, _ = _arrays()
    exp, params = read_experiment(bag)
    np.testing.assert_array_equal(exp.u, u)
    np.testing.assert_array_equal(exp.y, x)
    assert params == PARAMS


def test_anyreader_sees_the_same_samples(bag: Path) -> None:
    t, u, x, v = _arrays()
    with AnyReader([bag], default_typestore=STORE) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        conns = [c for c in reader.connections if c.topic == "/msd/joint_states"]
        msgs = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(conns)]
    assert counts == {"/msd/joint_states": N, "/msd/position": N, "/msd/force": N}
    np.testing.assert_array_equal([m.effort[0] for m in msgs], u)
    np.testing.assert_array_equal([m.position[0] for m in msgs], x)
    np.testing.assert_array_equal([m.velocity[0] for m in msgs], v)
    np.testing.assert_array_equal([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in msgs], t)


def test_mcap_library_reads_messages_and_params(bag: Path) -> None:
    t, _, x, _ = _arrays()
    with _mcap(bag).open("rb") as fh:
        reader = make_reader(fh, validate_crcs=True)
        stats = reader.get_summary().statistics
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
        pos = [
            (m.log_time, STORE.deserialize_cdr(m.data, "std_msgs/msg/Float64").data)
            for _, ch, m in reader.iter_messages(topics=["/msd/position"])
        ]
    assert stats.message_count == 3 * N
    assert json.loads(meta["msd_bench"]["params"]) == PARAMS
    assert [p[0] for p in pos] == t.tolist()
    np.testing.assert_array_equal([p[1] for p in pos], x)


def test_read_topic_returns_log_times_and_messages(bag: Path) -> None:
    t, u, _, _ = _arrays()
    stamps, msgs = read_topic(bag, "/msd/force")
    np.testing.assert_array_equal(stamps, t)
    np.testing.assert_array_equal([m.data for m in msgs], u)


def test_samples_are_sorted_by_stamp(tmp_path: Path) -> None:
    t, u, x, v = _arrays()
    perm = np.random.default_rng(0).permutation(N)
    bag = write_experiment(tmp_path / "shuffled", t[perm], u[perm], x[perm], v[perm], params={})
    exp, params = read_experiment(bag)
    np.testing.assert_array_equal(exp.u, u)
    np.testing.assert_array_equal(exp.y, x)
    assert params == {}


@pytest.mark.parametrize("where", [0, 7, 30, 0.25, 0.5, 0.9, -1])
def test_truncated_bag_raises_one_line(bag: Path, where: float) -> None:
    size = _mcap(bag).stat().st_size
    cut = int(size * where) if isinstance(where, float) else (size - 1 if where == -1 else where)
    with _mcap(bag).open("r+b") as fh:
        fh.truncate(cut)
    with pytest.raises(BagError) as err:
        read_experiment(bag)
    _assert_one_line(err.value, str(bag), "truncated or corrupt")


def test_corrupt_chunk_byte_fails_crc(bag: Path) -> None:
    data = bytearray(_mcap(bag).read_bytes())
    data[len(data) // 3] ^= 0x40  # inside the one chunk's message data
    _mcap(bag).write_bytes(bytes(data))
    with _mcap(bag).open("rb") as fh, pytest.raises(CRCValidationError):
        list(make_reader(fh, validate_crcs=True).iter_messages())
    with pytest.raises(BagError) as err:
        read_experiment(bag)
    _assert_one_line(err.value, str(bag), "checksum")


def test_missing_joint_states_names_the_topic(tmp_path: Path) -> None:
    with BagRecorder(tmp_path / "nojs") as rec:
        for k in range(5):
            rec.write("/msd/position", "std_msgs/msg/Float64", k, _float64(k))
    with pytest.raises(BagError) as err:
        read_experiment(tmp_path / "nojs")
    _assert_one_line(err.value, "/msd/joint_states", "/msd/position", str(tmp_path / "nojs"))


def test_wrong_type_on_joint_states(tmp_path: Path) -> None:
    with BagRecorder(tmp_path / "wrong") as rec:
        for k in range(5):
            rec.write("/msd/joint_states", "std_msgs/msg/Float64", k, _float64(k))
    with pytest.raises(BagError) as err:
        read_experiment(tmp_path / "wrong")
    _assert_one_line(err.value, "/msd/joint_states", "std_msgs/msg/Float64", "sensor_msgs/msg/JointState")


def test_empty_bag_and_too_short_bag(tmp_path: Path) -> None:
    BagRecorder(tmp_path / "empty").open().close()
    with pytest.raises(BagError, match="has no topic /msd/joint_states"):
        read_experiment(tmp_path / "empty")
    t, u, x, v = _arrays(2)
    write_experiment(tmp_path / "short", t, u, x, v, params={})
    with pytest.raises(BagError, match="at least 3 samples"):
        read_experiment(tmp_path / "short")


def test_refuses_overwrite_unless_asked(bag: Path, tmp_path: Path) -> None:
    t, u, x, v = _arrays()
    with pytest.raises(BagError, match="exists already"):
        write_experiment(bag, t, u, x, v, params={})
    assert read_experiment(bag)[1] == PARAMS  # untouched
    write_experiment(bag, t, -u, x, v, params={"second": True}, overwrite=True)
    exp, params = read_experiment(bag)
    np.testing.assert_array_equal(exp.u, -u)
    assert params == {"second": True}
    not_a_bag = tmp_path / "notes"
    not_a_bag.mkdir()
    (not_a_bag / "keep.txt").write_text("mine")
    with pytest.raises(BagError, match="not a bag"):
        write_experiment(not_a_bag, t, u, x, v, params={}, overwrite=True)
    assert (not_a_bag / "keep.txt").read_text() == "mine"


def test_bag_without_metadata_yaml_points_to_recover(bag: Path) -> None:
    (bag / "metadata.yaml").unlink()
    with pytest.raises(BagError) as err:
        read_experiment(bag)
    _assert_one_line(err.value, "metadata.yaml", "bag recover")


def test_missing_bag(tmp_path: Path) -> None:
    with pytest.raises(BagError, match="does not exist"):
        read_experiment(tmp_path / "nope")


def test_foreign_rosbag2_bag_without_params(tmp_path: Path) -> None:
    """A bag as a rig would record it: plain rosbags writer, two joints, no params record."""
    t, u, x, v = _arrays(50)
    types = STORE.types
    path = tmp_path / "rig"
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection("/msd/joint_states", "sensor_msgs/msg/JointState", typestore=STORE)
        for k in range(50):
            stamp = types["builtin_interfaces/msg/Time"](sec=int(t[k] // 10**9), nanosec=int(t[k] % 10**9))
            msg = types["sensor_msgs/msg/JointState"](
                header=types["std_msgs/msg/Header"](stamp=stamp, frame_id="rig"),
                name=["other", "msd_slider"],
                position=np.array([99.0, x[k]]),
                velocity=np.array([0.0, v[k]]),
                effort=np.array([-1.0, u[k]]),
            )
            writer.write(conn, int(t[k]) + 5, STORE.serialize_cdr(msg, "sensor_msgs/msg/JointState"))
    exp, params = read_experiment(path)
    np.testing.assert_array_equal(exp.u, u)
    np.testing.assert_array_equal(exp.y, x)
    assert params == {}


def test_bag_info(bag: Path) -> None:
    info = bag_info(bag)
    assert info.topics["/msd/joint_states"] == ("sensor_msgs/msg/JointState", N)
    assert info.topics["/msd/force"] == ("std_msgs/msg/Float64", N)
    assert info.duration_s == pytest.approx((N - 1) * 0.01)
    assert info.params == PARAMS


def test_renamed_bag_stays_readable(bag: Path, tmp_path: Path) -> None:
    """metadata.yaml names the MCAP file relative to the bag, so a moved bag still reads."""
    moved = bag.rename(tmp_path / "renamed")
    exp, _ = read_experiment(moved)
    assert len(exp) == N
