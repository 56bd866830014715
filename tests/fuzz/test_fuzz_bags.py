"""Fuzz tier, bag readers: damaged MCAP bytes, metadata.yaml and custom_data through every public reader.

Property: whatever the bytes, every reader — ``bag info`` (the command), ``bag check``, reading an
experiment and a topic, finding roles and reading records for identification, ``bag recover`` —
ends with a clean result or one :class:`MsdBenchError` line; never another exception, a crash, a
hang, or an allocation over the bound.

Each case runs in a forked child (:func:`in_child`) whose address space may grow by at most
:data:`HEADROOM` beyond what the test process had mapped when it forked (``RLIMIT_AS``; an absolute
512 MiB would sit below this process's own ~350 MiB of numpy, numba and rosbags, leaving too
little for the readers' legitimate bounded buffers), with an alarm for hangs. The child exits
:data:`CLEAN` or :data:`PROJECT_ERROR`; a signal death (the alarm, a segfault), a MemoryError, any
other exception or exit code fails the case, with the child's report.

Starting points are small valid bags written by the project's own writer (a broad ``train`` and
``validation`` pair with parameters, one recorder bag of several flushed chunks, and a zstd
MCAP), mutated by truncation, bit flips and huge values written over record lengths, string
lengths and chunk sizes.
"""

from __future__ import annotations

import json
import os
import resource
import shutil
import signal
import struct
import tempfile
import traceback
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

from msd_bench.commands.bag import main as bag_main
from msd_bench.core.errors import MsdBenchError
from msd_bench.io.bags.bag_check import check_bag
from msd_bench.io.bags.bag_records import load_records, roles_from_dir
from msd_bench.io.bags.bag_recover import recover
from msd_bench.io.bags.reader import (
    UNCHECKED,
    BagRecorder,
    bag_info,
    read_experiment,
    read_topic,
    write_experiment,
)

CLEAN = 0
"""Child exit status: every reader returned."""
PROJECT_ERROR = 3
"""Child exit status: at least one reader raised a one-line MsdBenchError, none anything else."""
HEADROOM = 512 << 20
"""Address space a case may add to what the test process maps (RLIMIT_AS of the child)."""
HANG_S = 60
"""Seconds after which a case counts as hung (SIGALRM kills the child); cases take milliseconds."""

N = 120
"""Samples per bag: over the 100 identification needs, so valid bags are read all the way."""


def _vm_bytes() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmSize:"):
            return int(line.split()[1]) * 1024
    raise AssertionError("no VmSize in /proc/self/status")


def in_child(case: Callable[[], bool], timeout_s: int = HANG_S) -> tuple[int, str]:
    """Run ``case`` in a forked child under the memory bound and the alarm: (wait status, report).

    ``case`` returns True when some reader raised a clean project error. The harness itself
    catches everything in the child, on purpose: the parent must learn what went wrong.
    """
    limit = _vm_bytes() + HEADROOM
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        os.close(read_end)
        code, report = 1, b""
        try:
            resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
            signal.alarm(timeout_s)
            code = PROJECT_ERROR if case() else CLEAN
        except BaseException:  # reported to the parent, which fails the case
            report = traceback.format_exc().encode()[-6000:]
        finally:
            os.write(write_end, report)
            os._exit(code)
    os.close(write_end)
    with os.fdopen(read_end, "rb") as fh:
        report_text = fh.read().decode(errors="replace")
    _, status = os.waitpid(pid, 0)
    return status, report_text


def assert_clean(case: Callable[[], bool]) -> None:
    """The case ended cleanly or with project errors only."""
    status, report = in_child(case)
    if os.WIFSIGNALED(status):
        pytest.fail(f"child killed by signal {os.WTERMSIG(status)} (SIGALRM = a hang)\n{report}")
    assert os.WIFEXITED(status) and os.WEXITSTATUS(status) in (CLEAN, PROJECT_ERROR), \
        f"child exit {os.WEXITSTATUS(status)}:\n{report}"


def readers_of(bag: Path) -> list[Callable[[], object]]:
    """The public readers of one bag directory, as the user reaches them: ``bag info`` and
    ``bag check`` (the commands: bag_info, the CRC scan, check_bag), then identification (roles
    from the bag's directory, and the records read from them: read_samples, the experiment, the
    signal rebuilt from the parameters)."""
    return [
        lambda: _status(bag_main(["bag", "info", str(bag)]), (0, 2)),
        lambda: _status(bag_main(["bag", "check", str(bag)]), (0, 1, 2)),
        identification(bag.parent),
    ]


def _status(code: int, allowed: tuple[int, ...]) -> None:
    assert code in allowed, f"exit status {code}"


def run_readers(readers: list[Callable[[], object]]) -> bool:
    """Call each reader; True if any raised a (one-line) project error. Anything else propagates."""
    errored = False
    for read in readers:
        try:
            read()
        except MsdBenchError as exc:
            text = str(exc)
            assert text and "\n" not in text, f"not one line: {text!r}"
            errored = True
    return errored


def identification(bags_dir: Path) -> Callable[[], object]:
    """Roles from a directory of bags, then the records identification reads from them (a directory
    of one train bag ends with "no broad-range validation bag" once that bag was read whole)."""
    return lambda: load_records(roles_from_dir(bags_dir), need_plm=False)


def recovery(bag: Path) -> Callable[[], object]:
    """``bag recover`` of the bag as a killed recording (no metadata.yaml), into a fresh directory."""
    def run() -> object:
        (bag / "metadata.yaml").unlink(missing_ok=True)
        out = bag.with_name(bag.name + ".fuzzed")
        return recover(bag, output=out)
    return run


# --- starting points ---------------------------------------------------------------------------

def _experiment(path: Path, role: str, seed: int) -> Path:
    rng = np.random.default_rng(seed)
    t = np.arange(N, dtype=np.int64) * 10_000_000
    params = {"role": role, "signal": "steps", "seed": seed, "steps": {"levels": [0.0, 1.0], "dwell": 60}}
    return write_experiment(path, t, rng.normal(size=N), rng.normal(size=N), np.zeros(N), params=params)


def _chunked(path: Path) -> Path:
    """A recorder bag of four flushed chunks (what a live recording looks like)."""
    src = _experiment(path.with_name("src"), "train", 9)
    with BagRecorder(path, params={"role": "train"}) as rec:
        from mcap.reader import make_reader
        with (src / "src.mcap").open("rb") as fh:
            reader = make_reader(fh)
            for i, (schema, channel, message) in enumerate(reader.iter_messages()):
                assert schema is not None
                rec.write(channel.topic, schema.name, message.log_time, message.data)
                if i % 90 == 89:
                    rec.flush()
    shutil.rmtree(src)
    return path


def _zstd(path: Path) -> Path:
    from mcap.writer import CompressionType, Writer

    path.mkdir()
    mcap = path / f"{path.name}.mcap"
    with mcap.open("wb") as fh:
        w = Writer(fh, compression=CompressionType.ZSTD, chunk_size=4096)
        w.start(profile="ros2", library="fuzz")
        schema = w.register_schema("std_msgs/msg/Float64", "ros2msg", b"float64 data")
        channel = w.register_channel("/msd/position", "cdr", schema)
        for k in range(600):
            raw = b"\x00\x01\x00\x00" + struct.pack("<d", k)
            w.add_message(channel, log_time=k, data=raw, publish_time=k)
        w.finish()
    return mcap


@pytest.fixture(scope="module")
def seeds(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The valid starting points, each read once here so the children fork with warm caches."""
    root = tmp_path_factory.mktemp("fuzz_bags")
    bags = root / "bags"
    bags.mkdir()
    _experiment(bags / "broad", "train", 1)
    found = {"bags": bags, "chunked": _chunked(root / "chunked" / "chunked"), "zstd": _zstd(root / "zstd")}
    assert run_readers(readers_of(bags / "broad"))  # only "no broad-range validation bag"
    assert not run_readers([lambda: read_experiment(found["chunked"], timing=UNCHECKED),
                            lambda: read_topic(found["zstd"], "/msd/position")])
    return found


def _record_offsets(data: bytes) -> list[int]:
    """Offsets of every length field an MCAP reader trusts: top-level records and those inside chunks."""
    out, pos = [], 8
    while pos + 9 <= len(data):
        opcode, length = struct.unpack_from("<BQ", data, pos)
        out.append(pos + 1)
        if opcode == 0x06:  # chunk: its sizes, then the records inside an uncompressed one
            out += [pos + 9 + 16, pos + 9 + 28, pos + 9 + 32]
            name_len = struct.unpack_from("<I", data, pos + 9 + 28)[0]
            start = pos + 9 + 32 + name_len + 8
            inner = start
            while inner + 9 <= min(start + length, len(data)) and name_len == 0:
                out.append(inner + 1)
                inner += 9 + struct.unpack_from("<Q", data, inner + 1)[0]
        if opcode == 0x02:
            break
        pos += 9 + length
    return out


HUGE = st.sampled_from([2**60, 2**63 - 1, 2**64 - 1, 2**32 - 1, 2**31, 10**15, 0, 1, 7])

Mutation = tuple[str, int, int]


@st.composite
def mutations(draw: st.DrawFn, size: int, lengths: list[int]) -> list[Mutation]:
    """1-3 edits of a file of ``size`` bytes: truncate, flip a bit, or a huge value over a length."""
    edits: list[Mutation] = []
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["truncate", "flip", "length", "length32"]))
        if kind in ("length", "length32"):
            where = draw(st.sampled_from(lengths) | st.integers(0, size - 1))
        else:
            where = draw(st.integers(0, size - 1))
        value = draw(HUGE) if kind.startswith("length") else draw(st.integers(0, 7))
        edits.append((kind, where, value))
    return edits


def _apply(data: bytes, edits: list[Mutation]) -> bytes:
    buf = bytearray(data)
    for kind, where, value in edits:
        where = min(where, max(len(buf) - 1, 0))
        if kind == "truncate":
            del buf[where:]
        elif kind == "flip" and buf:
            buf[where] ^= 1 << value
        elif kind == "length":
            buf[where:where + 8] = struct.pack("<Q", value)[: max(0, len(buf) - where)]
        elif kind == "length32":
            buf[where:where + 4] = struct.pack("<I", value & 0xFFFFFFFF)[: max(0, len(buf) - where)]
    return bytes(buf)


@pytest.fixture()
def scratch() -> Iterator[Path]:
    path = Path(tempfile.mkdtemp(prefix="msd_fuzz_bags_"))
    yield path
    shutil.rmtree(path, ignore_errors=True)


def _copy(src: Path, scratch: Path) -> Path:
    """A fresh copy of a starting point's directory; returns the copy of ``src`` in it.

    The previous case's copy is removed first: the examples of one test share ``scratch``, and
    the long profile runs 10,000 of them.
    """
    for old in scratch.iterdir():
        shutil.rmtree(old, ignore_errors=True)
    case = scratch / "case"
    shutil.copytree(src.parent, case)
    return case / src.name


def _mutate(data_file: Path, draw: Any) -> None:
    data = data_file.read_bytes()
    data_file.write_bytes(_apply(data, draw(mutations(len(data), _record_offsets(data)))))


@given(data=st.data())
def test_mutated_experiment_bags(seeds: dict[str, Path], scratch: Path, data: st.DataObject) -> None:
    bag = _copy(seeds["bags"] / "broad", scratch)
    _mutate(bag / "broad.mcap", data.draw)
    assert_clean(lambda: run_readers([*readers_of(bag), recovery(bag)]))


@given(data=st.data())
def test_mutated_chunked_recordings(seeds: dict[str, Path], scratch: Path, data: st.DataObject) -> None:
    bag = _copy(seeds["chunked"], scratch)
    _mutate(bag / "chunked.mcap", data.draw)
    readers = [lambda: _status(bag_main(["bag", "info", str(bag)]), (0, 2)),
               lambda: check_bag(bag), lambda: read_experiment(bag, timing=UNCHECKED), recovery(bag)]
    assert_clean(lambda: run_readers(readers))


@given(data=st.data())
def test_mutated_compressed_mcap(seeds: dict[str, Path], scratch: Path, data: st.DataObject) -> None:
    mcap = _copy(seeds["zstd"], scratch)
    folder = mcap.parent
    raw = mcap.read_bytes()
    mcap.write_bytes(_apply(raw, data.draw(mutations(len(raw), _record_offsets(raw)))))
    readers: list[Callable[[], object]] = [lambda: bag_info(mcap), lambda: check_bag(mcap),
                                           lambda: read_topic(mcap, "/msd/position"),
                                           lambda: recover(mcap, output=folder / "out")]
    assert_clean(lambda: run_readers(readers))


# --- metadata.yaml and custom_data --------------------------------------------------------------

JSONISH = st.recursive(
    st.none() | st.booleans() | st.integers(-(2**70), 2**70) | st.floats() | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=12,
)
FIELD_PATHS = [
    ("rosbag2_bagfile_information",),
    ("rosbag2_bagfile_information", "version"),
    ("rosbag2_bagfile_information", "storage_identifier"),
    ("rosbag2_bagfile_information", "relative_file_paths"),
    ("rosbag2_bagfile_information", "relative_file_paths", 0),
    ("rosbag2_bagfile_information", "message_count"),
    ("rosbag2_bagfile_information", "duration"),
    ("rosbag2_bagfile_information", "duration", "nanoseconds"),
    ("rosbag2_bagfile_information", "starting_time", "nanoseconds_since_epoch"),
    ("rosbag2_bagfile_information", "topics_with_message_count"),
    ("rosbag2_bagfile_information", "topics_with_message_count", 0),
    ("rosbag2_bagfile_information", "topics_with_message_count", 0, "message_count"),
    ("rosbag2_bagfile_information", "topics_with_message_count", 0, "topic_metadata"),
    ("rosbag2_bagfile_information", "topics_with_message_count", 0, "topic_metadata", "name"),
    ("rosbag2_bagfile_information", "topics_with_message_count", 0, "topic_metadata", "type"),
    ("rosbag2_bagfile_information", "topics_with_message_count", 0, "topic_metadata",
     "offered_qos_profiles"),
    ("rosbag2_bagfile_information", "topics_with_message_count", 1, "topic_metadata",
     "serialization_format"),
    ("rosbag2_bagfile_information", "compression_mode"),
    ("rosbag2_bagfile_information", "compression_format"),
    ("rosbag2_bagfile_information", "custom_data"),
    ("rosbag2_bagfile_information", "custom_data", "msd_bench.params"),
    ("rosbag2_bagfile_information", "files"),
]


def _set(doc: Any, path: tuple[Any, ...], value: object, delete: bool) -> None:
    """Replace (or delete) the field at ``path``, if earlier edits left containers all the way there."""
    for key in path[:-1]:
        if not _has(doc, key):
            return
        doc = doc[key]
    if delete and _has(doc, path[-1]):
        del doc[path[-1]]
    elif not delete and (isinstance(doc, dict) or _has(doc, path[-1])):
        doc[path[-1]] = value


def _has(doc: Any, key: Any) -> bool:
    if isinstance(doc, dict):
        return key in doc
    return isinstance(doc, list) and isinstance(key, int) and key < len(doc)


@given(data=st.data())
def test_mutated_metadata_yaml(seeds: dict[str, Path], scratch: Path, data: st.DataObject) -> None:
    bag = _copy(seeds["bags"] / "broad", scratch)
    meta = bag / "metadata.yaml"
    how = data.draw(st.sampled_from(["fields", "text", "deep", "bytes"]))
    if how == "fields":
        doc = yaml.safe_load(meta.read_text())
        for _ in range(data.draw(st.integers(1, 3))):
            path = data.draw(st.sampled_from(FIELD_PATHS))
            _set(doc, path, data.draw(JSONISH), data.draw(st.booleans()))
        meta.write_text(yaml.safe_dump(doc))
    elif how == "text":
        meta.write_text(data.draw(st.text(max_size=300)))
    elif how == "deep":
        depth = data.draw(st.integers(1, 30_000))
        meta.write_text("a: " + "[" * depth + "]" * depth + "\n")
    else:
        meta.write_bytes(data.draw(st.binary(max_size=300)))
    assert_clean(lambda: run_readers(readers_of(bag)))


@given(params=st.one_of(JSONISH.map(json.dumps), st.text(max_size=200),
                        st.integers(1, 50_000).map(lambda d: "[" * d + "]" * d),
                        st.integers(4000, 6000).map(lambda n: "1" * n)))
def test_custom_data_params(seeds: dict[str, Path], scratch: Path, params: str) -> None:
    bag = _copy(seeds["bags"] / "broad", scratch)
    meta = bag / "metadata.yaml"
    doc = yaml.safe_load(meta.read_text())
    doc["rosbag2_bagfile_information"]["custom_data"]["msd_bench.params"] = params
    meta.write_text(yaml.safe_dump(doc))
    assert_clean(lambda: run_readers([lambda: bag_info(bag), identification(bag.parent)]))


def test_the_harness_fails_a_crash_and_a_big_allocation() -> None:
    """The property could fail: a non-project exception, a huge allocation and a hang are each caught."""
    status, report = in_child(lambda: bool(bytearray(HEADROOM + (64 << 20))))
    assert os.WIFEXITED(status) and os.WEXITSTATUS(status) == 1 and "MemoryError" in report
    status, report = in_child(lambda: {}["x"])  # type: ignore[no-any-return]
    assert os.WEXITSTATUS(status) == 1 and "KeyError" in report
    status, _ = in_child(lambda: signal.pause() is None, timeout_s=1)
    assert os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGALRM
    status, _ = in_child(lambda: run_readers([lambda: bag_info("/nonexistent/bag")]))
    assert os.WEXITSTATUS(status) == PROJECT_ERROR
