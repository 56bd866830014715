"""What a rosbag2 user reads in our bags: QoS profiles, type hashes, the distribution, stamps."""

from __future__ import annotations

import importlib.metadata
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from rosbags.rosbag2 import Reader

from msd_bench.io.bags.bag_recover import recover
from msd_bench.io.bags.bag_writer import contract_qos, leading_stamp, ros_distro, typestore, write_experiment
from msd_msgs_py.contract import FORCE, JOINT_STATES, POSITION, RECORDER_READY

STORE = typestore()
N = 50


@pytest.fixture()
def bag(tmp_path: Path) -> Path:
    t = np.arange(N, dtype=np.int64) * 10_000_000
    return write_experiment(tmp_path / "exp", t, np.ones(N), np.zeros(N), np.zeros(N), params={"a": 1})


def _meta(bag: Path) -> dict[str, Any]:
    doc: dict[str, Any] = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    return doc


def _channels(bag: Path) -> dict[str, dict[str, str]]:
    with (bag / f"{bag.name}.mcap").open("rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    return {c.topic: dict(c.metadata) for c in summary.channels.values()}


def test_offline_bag_carries_the_contract_qos_and_type_hashes(bag: Path) -> None:
    rows = _meta(bag)["topics_with_message_count"]
    topics = {t["topic_metadata"]["name"]: t["topic_metadata"] for t in rows}
    js = topics["/msd/joint_states"]
    assert js["offered_qos_profiles"] == [{
        "history": "keep_last", "depth": JOINT_STATES.depth, "reliability": "reliable",
        "durability": "volatile", "deadline": {"sec": 9223372036, "nsec": 854775807},
        "lifespan": {"sec": 9223372036, "nsec": 854775807}, "liveliness": "automatic",
        "liveliness_lease_duration": {"sec": 9223372036, "nsec": 854775807},
        "avoid_ros_namespace_conventions": False}]
    assert topics["/msd/force"]["offered_qos_profiles"][0]["depth"] == FORCE.depth == 1
    channels = _channels(bag)
    for name, ros_type in (("/msd/joint_states", JOINT_STATES.ros_type),
                           ("/msd/position", POSITION.ros_type)):
        expected = STORE.hash_rihs01(ros_type)
        assert expected.startswith("RIHS01_") and len(expected) == 7 + 64
        assert channels[name]["topic_type_hash"] == expected == topics[name]["type_description_hash"]
        assert yaml.safe_load(channels[name]["offered_qos_profiles"]) == topics[name]["offered_qos_profiles"]


def test_ros_distro_is_the_running_one(bag: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # The pinned wheels: rclpy 9 is Kilted's, rclpy 7 Jazzy's (the suite runs on both).
    wheels = {"9": "kilted", "7": "jazzy"}[importlib.metadata.version("ros-rclpy").split(".")[0]]
    running = os.environ.get("ROS_DISTRO") or wheels
    assert _meta(bag)["ros_distro"] == ros_distro() == running
    with (bag / "exp.mcap").open("rb") as fh:
        record = next(m for m in make_reader(fh).iter_metadata() if m.name == "rosbag2")
    assert yaml.safe_load(record.metadata["serialized_metadata"])["ros_distro"] == running
    monkeypatch.setenv("ROS_DISTRO", "jazzy")
    assert ros_distro() == "jazzy"  # a sourced ROS install says which it is
    other = write_experiment(bag.parent / "other", np.arange(3), np.ones(3), np.zeros(3), np.zeros(3),
                             params={})
    assert _meta(other)["ros_distro"] == "jazzy"
    with Reader(other) as reader:  # rosbags still reads it
        assert reader.message_count == 9


def test_ros_distro_without_rclpy_or_env(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("ROS_DISTRO", raising=False)

    def missing(_name: str) -> str:
        raise importlib.metadata.PackageNotFoundError

    monkeypatch.setattr(importlib.metadata, "version", missing)
    assert ros_distro() == "unknown"


def test_latched_topic_qos_is_transient_local() -> None:
    assert contract_qos(RECORDER_READY).durability.name == "TRANSIENT_LOCAL"
    assert contract_qos(POSITION).durability.name == "VOLATILE"


@pytest.mark.parametrize("little_endian", [True, False])
def test_leading_stamp_reads_header_and_clock_times(little_endian: bool) -> None:
    types = STORE.types
    t = types["builtin_interfaces/msg/Time"](sec=1_700_000_000, nanosec=123_456_789)
    js = types[JOINT_STATES.ros_type](header=types["std_msgs/msg/Header"](stamp=t, frame_id="f"), name=["a"],
                                      position=np.zeros(1), velocity=np.zeros(1), effort=np.zeros(1))
    clock = types["rosgraph_msgs/msg/Clock"](clock=t)
    for msg, ros_type in ((js, JOINT_STATES.ros_type), (clock, "rosgraph_msgs/msg/Clock")):
        raw = STORE.serialize_cdr(msg, ros_type, little_endian=little_endian)
        assert leading_stamp(ros_type, raw) == 1_700_000_000_123_456_789
    raw = STORE.serialize_cdr(types["std_msgs/msg/Float64"](data=1.0), "std_msgs/msg/Float64")
    assert leading_stamp("std_msgs/msg/Float64", raw) is None  # no stamp to read


def test_recovered_bag_keeps_the_qos(bag: Path) -> None:
    (bag / "metadata.yaml").unlink()
    report = recover(bag)
    before = _channels(bag)
    after = _channels(report.output)
    for topic in before:
        assert after[topic]["offered_qos_profiles"] == before[topic]["offered_qos_profiles"]
        assert after[topic]["topic_type_hash"] == before[topic]["topic_type_hash"]
