"""Bag throughput: BagRecorder vs plain rosbags Writer (same run), and read speed.

Prints JSON. Messages are pre-serialized 100 Hz JointState samples, so the
numbers measure the storage path only (what the recorder node does with raw
CDR bytes). Best of ``--repeat`` runs.

    .venv/bin/python benchmarks/bench_bags.py [--n 30000] [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mcap.reader import make_reader
from rosbags.rosbag2 import Reader, StoragePlugin, Writer

from msd_bench.io.bags.reader import BagRecorder, read_experiment, typestore, write_experiment

TOPIC, TYPE = "/msd/joint_states", "sensor_msgs/msg/JointState"


def _messages(n: int) -> list[bytes]:
    store = typestore()
    t = store.types
    out = []
    for k in range(n):
        ns = 10_000_000 * k
        msg = t[TYPE](
            header=t["std_msgs/msg/Header"](
                stamp=t["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9), frame_id=""
            ),
            name=["msd_slider"],
            position=np.array([0.001 * k]),
            velocity=np.array([0.0]),
            effort=np.array([1.0]),
        )
        out.append(bytes(store.serialize_cdr(msg, TYPE)))
    return out


def _best(fn: Callable[[Path], None], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        with tempfile.TemporaryDirectory() as tmp:
            start = time.perf_counter()
            fn(Path(tmp) / "bag")
            times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=30_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    msgs = _messages(args.n)

    def recorder(path: Path, flush_period_s: float = 1.0) -> None:
        with BagRecorder(path, flush_period_s=flush_period_s) as rec:
            for k, data in enumerate(msgs):
                rec.write(TOPIC, TYPE, 10_000_000 * k, data)

    def rosbags_writer(path: Path) -> None:
        with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
            conn = writer.add_connection(TOPIC, TYPE, typestore=typestore())
            for k, data in enumerate(msgs):
                writer.write(conn, 10_000_000 * k, data)

    t_base = _best(rosbags_writer, args.repeat)
    t_rec = _best(recorder, args.repeat)
    t_rec_flushy = _best(lambda p: recorder(p, 0.0), args.repeat)  # a chunk per message: worst case

    n = args.n
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as tmp:
        bag = Path(tmp) / "read"
        t_ns = np.arange(n, dtype=np.int64) * 10_000_000
        start = time.perf_counter()
        write_experiment(bag, t_ns, rng.normal(size=n), rng.normal(size=n), rng.normal(size=n), params={})
        t_write_exp = time.perf_counter() - start
        start = time.perf_counter()
        read_experiment(bag)
        t_read_exp = time.perf_counter() - start
        start = time.perf_counter()
        with Reader(bag) as reader:
            raw_count = sum(1 for _ in reader.messages())
        t_read_raw = time.perf_counter() - start
        start = time.perf_counter()
        with (bag / "read.mcap").open("rb") as fh:
            mcap_count = sum(1 for _ in make_reader(fh).iter_messages())
        t_read_mcap = time.perf_counter() - start

    print(json.dumps({
        "messages": n,
        "write_msgs_per_s": {
            "rosbags_writer_baseline": round(n / t_base),
            "bag_recorder_flush_1s": round(n / t_rec),
            "bag_recorder_flush_every_message": round(n / t_rec_flushy),
        },
        "bag_recorder_vs_baseline": round(t_base / t_rec, 3),
        "write_experiment_samples_per_s": round(n / t_write_exp),
        "read": {
            "read_experiment_samples_per_s": round(n / t_read_exp),
            "rosbags_reader_raw_msgs_per_s": round(raw_count / t_read_raw),
            "mcap_reader_raw_msgs_per_s": round(mcap_count / t_read_mcap),
        },
        "note": "recorder at 100 Hz x 3 topics needs 300 msgs/s; write_experiment writes 3 msgs/sample",
    }, indent=2))


if __name__ == "__main__":
    main()
