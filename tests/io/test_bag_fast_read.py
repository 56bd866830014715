"""The whole-topic JointState reader gives what the per-message reader gives, and a bag is read once.

Every bag here is written by the project's own writer. The oracle is the
per-message path (:func:`msd_bench.io.bags.cdr.joint_state` row by row, rosbags for
what it declines), forced by making the whole-topic reader decline: the two
reads must agree bit for bit, or fail with the same line.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.rosbag2 import Reader

from msd_bench.io.bags import bag_open, cdr
from msd_bench.io.bags import reader as bags
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_interface import read_interface_experiment
from msd_bench.io.bags.bag_records import load_records, roles_from_dir
from msd_bench.io.bags.bag_writer import BagRecorder, typestore, write_experiment, write_interface_experiment
from msd_msgs_py.interface import MSD_INTERFACE

STORE = typestore()
JS = "sensor_msgs/msg/JointState"
TOPIC = "/msd/joint_states"
DT_NS = 10_000_000
T0 = 1_700_000_000 * 10**9 + 123_456_789  # a wall-clock start: sec and nanosec both non-trivial
N = 300


def _values(n: int = N, seed: int = 0) -> tuple[np.ndarray, ...]:
    """Stamps and values with awkward bits: -0.0, a subnormal, huge and tiny magnitudes."""
    rng = np.random.default_rng(seed)
    t = T0 + np.arange(n, dtype=np.int64) * DT_NS
    u = rng.normal(0.0, 5.0, n)
    x = rng.normal(0.0, 1.0, n)
    v = rng.normal(0.0, 2.0, n)
    u[:4] = [-0.0, 5e-324, 1e300, -1e-300]
    x[:3] = [-0.0, np.nextafter(0.0, 1.0), -1e308]
    return t, u, x, v


def _js(ns: int, names: Sequence[str], pos: Sequence[float], vel: Sequence[float], eff: Sequence[float],
        frame: str = "", little_endian: bool = True) -> bytes:
    t = STORE.types
    msg = t[JS](header=t["std_msgs/msg/Header"](
        stamp=t["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9), frame_id=frame),
        name=list(names), position=np.array(pos, dtype=np.float64), velocity=np.array(vel, dtype=np.float64),
        effort=np.array(eff, dtype=np.float64))
    return bytes(STORE.serialize_cdr(msg, JS, little_endian=little_endian))


def _bag(path: Path, raws: Sequence[bytes], params: dict[str, Any] | None = None) -> Path:
    """A bag of the given JointState bytes on /msd/joint_states, logged every 10 ms."""
    with BagRecorder(path, params=params or {}) as rec:
        for k, raw in enumerate(raws):
            rec.write(TOPIC, JS, T0 + k * DT_NS, raw)
    return path


def _raws(path: Path) -> list[bytes]:
    with Reader(path) as reader:
        conns = [c for c in reader.connections if c.topic == TOPIC]
        return [bytes(raw) for _, _, raw in reader.messages(connections=conns)]


def _outcome(path: Path) -> tuple[Any, ...]:
    """What read_experiment gives, as bytes (bit for bit), or its error's type and text."""
    try:
        exp, params = bags.read_experiment(path, timing=bags.UNCHECKED)
    except Exception as exc:  # whatever it raises, both paths must raise the same
        return ("error", type(exc).__name__, str(exc))
    truth = None if exp.truth is None else exp.truth.tobytes()
    return ("ok", exp.u.tobytes(), exp.y.tobytes(), truth, exp.u.dtype, exp.y.dtype, params)


def _both_ways(path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
    """read_experiment's outcome as it is, then with the whole-topic reader declining every topic."""
    fast = _outcome(path)
    with monkeypatch.context() as m:
        m.setattr(cdr, "joint_state_columns", lambda raws: None)
        slow = _outcome(path)
    return fast, slow


def _assert_columns_match_rows(raws: Sequence[bytes]) -> None:
    cols = cdr.joint_state_columns(raws)
    assert cols is not None, "the plant's one-joint rows must take the whole-topic path"
    rows = [cdr.joint_state(raw) for raw in raws]
    assert all(r is not None for r in rows)
    assert cols.stamp_ns.dtype == np.int64
    assert cols.stamp_ns.tolist() == [r.stamp_ns for r in rows if r is not None]
    for field in ("position", "velocity", "effort"):
        got = getattr(cols, field)
        want = np.array([getattr(r, field) for r in rows if r is not None], dtype=np.float64)
        assert got.dtype == np.float64 and got.shape == want.shape
        assert got.tobytes() == want.tobytes(), field
    assert all(cols.name == r.name for r in rows if r is not None)


def test_the_plants_bag_is_read_whole_and_bit_for_bit(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    t, u, x, v = _values()
    bag = write_experiment(tmp_path / "plant", t, u, x, v, params={"role": "train", "seed": 3})
    _assert_columns_match_rows(_raws(bag))
    fast, slow = _both_ways(bag, monkeypatch)
    assert fast == slow
    assert fast[1] == u.tobytes() and fast[2] == x.tobytes()  # and both are what was written


def test_rows_without_velocity_still_take_the_whole_topic_path(tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    t, u, x, _ = _values()
    bag = _bag(tmp_path / "novel", [_js(int(t[k]), ["msd_slider"], [x[k]], [], [u[k]], frame="map")
                                    for k in range(N)])
    raws = _raws(bag)
    _assert_columns_match_rows(raws)
    cols = cdr.joint_state_columns(raws)
    assert cols is not None and cols.velocity.shape == (N, 0)
    fast, slow = _both_ways(bag, monkeypatch)
    assert fast == slow and fast[1] == u.tobytes()


def test_what_rclpy_serializes_is_read_whole() -> None:
    """The bytes a recorder stores are rmw's serialization (its padding), not rosbags'."""
    pytest.importorskip("rclpy")
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    t, u, x, v = _values(20)
    raws = []
    for k in range(20):
        msg = JointState(name=["msd_slider"], position=[x[k]], velocity=[v[k]], effort=[u[k]])
        msg.header.stamp.sec, msg.header.stamp.nanosec = int(t[k]) // 10**9, int(t[k]) % 10**9
        raws.append(bytes(serialize_message(msg)))
    _assert_columns_match_rows(raws)


def test_padding_may_differ_between_rows(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """rmw leaves padding uninitialised: rows that differ only there still share one layout."""
    t, u, x, v = _values()
    raws = [_js(int(t[k]), ["msd_slider"], [x[k]], [v[k]], [u[k]]) for k in range(N)]
    ref = cdr.joint_state(raws[0])
    ignored = [i for i in range(len(raws[0]))  # bytes the per-message reader does not look at
               if cdr.joint_state(raws[0][:i] + b"\xa5" + raws[0][i + 1:]) == ref]
    assert len(ignored) >= 4, "the plant's row has padding (after the frame id and the name)"
    rng = np.random.default_rng(1)
    scribbled = []
    for raw in raws:
        row = bytearray(raw)
        for i in ignored:
            row[i] = int(rng.integers(0, 256))
        scribbled.append(bytes(row))
    assert len({r[ignored[0]] for r in scribbled}) > 1
    bag = _bag(tmp_path / "scribbled", scribbled)
    _assert_columns_match_rows(_raws(bag))
    fast, slow = _both_ways(bag, monkeypatch)
    assert fast == slow and fast[1] == u.tobytes() and fast[2] == x.tobytes()


def test_a_multi_joint_bag_falls_back_and_picks_our_joint(tmp_path: Path,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    t, u, x, v = _values()
    bag = write_interface_experiment(tmp_path / "rig", t, x, v, u, iface=MSD_INTERFACE, command_ns=t,
                                     command_u=u, params={}, other_joints=["pole"])
    assert cdr.joint_state_columns(_raws(bag)) is None
    fast, slow = _both_ways(bag, monkeypatch)
    assert fast == slow
    assert fast[2] == x.tobytes()  # msd_slider, listed second, not the pole


@pytest.mark.parametrize("change", ["frame_id", "name", "joint_count"])
def test_a_topic_whose_layout_changes_falls_back(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                 change: str) -> None:
    """Half the rows in one layout, half in another: read row by row, each at its own offsets."""
    t, u, x, v = _values()
    late = {"frame_id": {"frame": "base_link"},
            "name": {"names": ["msd_slidex"]},  # same length: only the bytes differ
            "joint_count": {"names": ["pole", "msd_slider"]}}[change]
    raws = []
    for k in range(N):
        kw: dict[str, Any] = {"names": ["msd_slider"], "frame": ""} if k < N // 2 else {
            "names": ["msd_slider"], "frame": "", **late}
        pad = [7.0] * (len(kw["names"]) - 1)
        raws.append(_js(int(t[k]), kw["names"], [*pad, x[k]], [*pad, v[k]], [*pad, u[k]], frame=kw["frame"]))
    bag = _bag(tmp_path / change, raws)
    assert cdr.joint_state_columns(_raws(bag)) is None
    assert cdr.joint_state_columns(_raws(bag)[: N // 2]) is not None  # the first half alone is uniform
    fast, slow = _both_ways(bag, monkeypatch)
    assert fast == slow
    assert fast[1] == u.tobytes() and fast[2] == x.tobytes()


def test_big_endian_rows_fall_back_to_rosbags(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    t, u, x, v = _values()
    raws = [_js(int(t[k]), ["msd_slider"], [x[k]], [v[k]], [u[k]], little_endian=False) for k in range(N)]
    bag = _bag(tmp_path / "be", raws)
    assert cdr.joint_state_columns(_raws(bag)) is None
    fast, slow = _both_ways(bag, monkeypatch)
    assert fast == slow and fast[2] == x.tobytes()


def test_rows_without_effort_fail_as_before(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    t, _, x, v = _values()
    bag = _bag(tmp_path / "noeff", [_js(int(t[k]), ["msd_slider"], [x[k]], [v[k]], []) for k in range(N)])
    assert cdr.joint_state_columns(_raws(bag)) is not None  # uniform, but no effort to read
    fast, slow = _both_ways(bag, monkeypatch)
    assert fast == slow
    assert fast[:2] == ("error", "BagError") and "a message lacks position or effort" in fast[2]


def test_one_truncated_row_among_uniform_ones_fails_as_before(tmp_path: Path,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    t, u, x, v = _values()
    raws = [_js(int(t[k]), ["msd_slider"], [x[k]], [v[k]], [u[k]]) for k in range(N)]
    raws[N // 2] = raws[N // 2][:-9]  # cut inside the effort array
    bag = _bag(tmp_path / "cut", raws)
    assert cdr.joint_state_columns(_raws(bag)) is None
    fast, slow = _both_ways(bag, monkeypatch)
    assert fast == slow
    assert fast[:2] == ("error", "BagError") and "truncated or corrupt" in fast[2]
    assert "offset" in fast[2]  # rosbags names where the message breaks


def test_an_empty_list_is_declined() -> None:
    assert cdr.joint_state_columns([]) is None


def _experiment_bags(root: Path) -> Path:
    t, u, x, v = _values()
    write_experiment(root / "broad", t, u, x, v, params={"role": "train", "seed": 1})
    write_experiment(root / "val_broad", t, -u, x[::-1].copy(), v, params={"role": "validation", "seed": 2})
    write_experiment(root / "foreign", t, u, x, v, params={"seed": 3})  # no role: read, not used
    return root


def _count_opens(monkeypatch: pytest.MonkeyPatch) -> Counter[str]:
    opened: Counter[str] = Counter()
    real = bag_open._Reader

    def counting(path: Any, *args: Any, **kwargs: Any) -> Reader:
        opened[Path(path).name] += 1
        return real(path, *args, **kwargs)

    monkeypatch.setattr(bag_open, "_Reader", counting)
    return opened


def _arrays(records: Any) -> list[bytes]:
    return [a.tobytes() for io in (records.broad_train, records.broad_val)
            for e in io.experiments for a in (e.u, e.y)]


def test_the_identifier_reads_each_bag_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    root = _experiment_bags(tmp_path / "bags")
    opened = _count_opens(monkeypatch)
    roles = roles_from_dir(root)
    records = load_records(roles, need_plm=False)
    assert opened == {"broad": 1, "val_broad": 1, "foreign": 1}
    opened.clear()
    reread = load_records([replace(r, samples=None) for r in roles], need_plm=False)
    assert opened == {"broad": 1, "val_broad": 1}  # without what roles_from_dir kept, read again
    assert _arrays(records) == _arrays(reread)
    assert records.broad_train.meta == reread.broad_train.meta


def test_kept_samples_are_checked_with_the_identifiers_timing(tmp_path: Path) -> None:
    """roles_from_dir accepts a short bag (any read); identifying from its kept samples still refuses it."""
    t, u, x, v = _values(50)
    root = tmp_path / "bags"
    write_experiment(root / "broad", t, u, x, v, params={"role": "train"})
    write_experiment(root / "val_broad", t, u, x, v, params={"role": "validation"})
    roles = roles_from_dir(root)
    assert all(r.samples is not None for r in roles)
    with pytest.raises(BagError, match="only 50 samples, need at least 100"):
        load_records(roles, need_plm=False)


def test_samples_of_another_namespace_are_not_used(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    root = _experiment_bags(tmp_path / "bags")
    roles = roles_from_dir(root)
    samples = roles[0].samples
    assert samples is not None
    opened = _count_opens(monkeypatch)
    with pytest.raises(BagError, match="has no topic /other/joint_states"):
        read_interface_experiment(roles[0].path, namespace="/other", samples=samples)
    assert opened == {roles[0].path.name: 1}


def test_a_bad_row_before_a_corrupt_chunk_is_the_error(tmp_path: Path) -> None:
    """Rows used to be decoded while the bag was read: the first bad one is reported, not the chunk after."""
    mark = 1234.5678
    with BagRecorder(tmp_path / "bad") as rec:
        for k in range(40):
            if k == 20:
                rec.flush()  # a second chunk
            pos, eff = [0.1 if k < 20 else mark], [] if k == 5 else [1.0]
            rec.write(TOPIC, JS, T0 + k * DT_NS, _js(T0 + k * DT_NS, ["msd_slider"], pos, [0.0], eff))
    mcap = tmp_path / "bad" / "bad.mcap"
    data = bytearray(mcap.read_bytes())
    data[data.find(np.float64(mark).tobytes())] ^= 0x40  # inside the second chunk only
    mcap.write_bytes(bytes(data))
    with pytest.raises(BagError, match="a message lacks position or effort"):
        bags.read_experiment(tmp_path / "bad", timing=bags.UNCHECKED)
    with pytest.raises(BagError, match="truncated or corrupt: Chunk checksum mismatch"):
        bags.read_topic(tmp_path / "bad", TOPIC)  # the chunk is corrupt indeed
