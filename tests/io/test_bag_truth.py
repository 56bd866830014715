"""An emulator's ``truth/joint_states`` in a bag: attached to the experiment by stamp, for scoring only."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from msd_bench.core.physics.sensor import SensorModel, sensor_rng
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_records import BagRole, load_records
from msd_bench.io.bags.reader import BagRecorder, read_experiment, typestore
from msd_msgs_py.contract import JOINT_NAME, JOINT_STATES, TRUTH_JOINT_STATES

N = 300
DT_NS = 10_000_000
STORE = typestore()


def _row(k: int, x: float, u: float) -> bytes:
    t = STORE.types
    ns = k * DT_NS
    msg = t[JOINT_STATES.ros_type](
        header=t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=ns // 10**9,
                                                                               nanosec=ns % 10**9),
                                        frame_id=""),
        name=[JOINT_NAME], position=np.array([x]), velocity=np.array([0.0]), effort=np.array([u]))
    return bytes(STORE.serialize_cdr(msg, JOINT_STATES.ros_type))


def _signals(n: int = N) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    u = np.repeat([5.0, -5.0, 8.0], n // 3 + 1)[:n]
    x = 0.1 * np.sin(np.arange(n) / 30.0)
    y = SensorModel(0.002).measure(x, sensor_rng(1))
    return u, x, y


def _bag(path: Path, truth_samples: range | list[int] | None, truth_u_offset: float = 0.0,
         params: dict[str, object] | None = None) -> Path:
    """Measured rows 0..N-1; truth rows for ``truth_samples`` (each after its measured row, as the plant)."""
    u, x, y = _signals()
    with BagRecorder(path, params=params or {}) as rec:
        for k in range(N):
            rec.write(JOINT_STATES.resolve("/msd"), JOINT_STATES.ros_type, k * DT_NS, _row(k, y[k], u[k]))
            if truth_samples is not None and k in truth_samples:
                rec.write(TRUTH_JOINT_STATES.resolve("/msd"), TRUTH_JOINT_STATES.ros_type, k * DT_NS,
                          _row(k, x[k], u[k] + truth_u_offset))
    return path


def test_truth_is_attached_row_by_row(tmp_path: Path) -> None:
    u, x, y = _signals()
    exp, _ = read_experiment(_bag(tmp_path / "b", range(N)))
    assert exp.truth is not None
    assert np.array_equal(exp.truth, x) and np.array_equal(exp.y, y) and np.array_equal(exp.u, u)


def test_a_bag_without_truth_has_none(tmp_path: Path) -> None:
    exp, _ = read_experiment(_bag(tmp_path / "b", None))
    assert exp.truth is None and len(exp) == N


def test_samples_without_truth_at_the_ends_are_cut(tmp_path: Path) -> None:
    _, x, y = _signals()
    exp, _ = read_experiment(_bag(tmp_path / "b", range(1, N - 2)))
    assert len(exp) == N - 3 and exp.truth is not None
    assert np.array_equal(exp.truth, x[1:N - 2]) and np.array_equal(exp.y, y[1:N - 2])


def test_a_hole_in_the_truth_or_another_force_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(BagError, match="truth/joint_states lacks sample 150 inside the record") as err:
        read_experiment(_bag(tmp_path / "hole", [k for k in range(N) if k != 150]))
    assert "\n" not in str(err.value)
    with pytest.raises(BagError, match="another force"):
        read_experiment(_bag(tmp_path / "force", range(N), truth_u_offset=1.0))


def test_records_keep_the_truth_after_the_settle_segment(tmp_path: Path) -> None:
    _, x, _ = _signals()
    train = _bag(tmp_path / "train", range(N))
    val = _bag(tmp_path / "val", range(N))
    records = load_records([BagRole(train, "train", None, 20), BagRole(val, "validation", None, 0)], False)
    assert records.broad_val.has_truth and records.broad_train.has_truth
    assert np.array_equal(records.broad_train.experiments[0].y_true, x[20:])
