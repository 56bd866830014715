"""Bags trusted for nothing: stored parameters, metadata.yaml, custom_data, lying MCAP lengths, odd paths.

Each case is one a hostile or damaged bag caused (issue 20): a traceback, an
allocation of terabytes, or a ``bag check`` that said ``ok``. Each must now be
one BagError line naming the bag (and the field), or a fault ``bag check`` lists.
"""

from __future__ import annotations

import json
import os
import struct
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as RosbagsWriter

from msd_bench.commands.bag import main as bag_main
from msd_bench.core.errors import ConfigError
from msd_bench.core.identification import excitation as exc
from msd_bench.io.bags.bag_check import check_bag
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_records import roles_from_dir
from msd_bench.io.bags.bag_recover import recover
from msd_bench.io.bags.mcap_guard import MAX_CHUNK_BYTES
from msd_bench.io.bags.reader import bag_info, read_experiment, read_topic, typestore, write_experiment

N = 120
T = np.arange(N, dtype=np.int64) * 10_000_000
STEPS = {"signal": "steps", "seed": 0, "role": "train", "steps": {"levels": [0.0, 1.0], "dwell": 10}}


def _bag(path: Path, params: dict[str, Any] | None = None) -> Path:
    return write_experiment(path, T, np.ones(N), np.zeros(N), np.zeros(N), params=params or {})


def _meta(bag: Path) -> dict[str, Any]:
    doc: dict[str, Any] = yaml.safe_load((bag / "metadata.yaml").read_text())
    return doc


def _put_meta(bag: Path, doc: object) -> None:
    (bag / "metadata.yaml").write_text(yaml.safe_dump(doc))


def _one_line(err: pytest.ExceptionInfo[BagError], *needles: str) -> None:
    text = str(err.value)
    assert "\n" not in text and len(text) < 600, text
    for needle in needles:
        assert needle in text, text


# --- stored parameters -------------------------------------------------------------------------

@pytest.mark.parametrize(("change", "needles"), [
    ({"steps": {"levels": [0.0], "dwell": 10**13}}, ("steps", "dwell must be <= 10000000")),
    ({"steps": {"levels": [0.0] * 2000, "dwell": 10_000}}, ("len(levels) * dwell = 20000000",)),
    ({"steps": {"levels": [0.0], "dwell": 1e13}}, ("dwell must be an integer",)),
    ({"bias": "abc"}, ("parameter bias must be a finite number",)),
    ({"signal": "prbs", "prbs": 7}, ("parameter prbs must be an object",)),
    ({"signal": "prbs", "prbs": {"n_samples": 10, "settle": -1}}, ("prbs: settle must be >= 0",)),
    ({"signal": "prbs", "prbs": {"amplitude": "1"}}, ("amplitude must be a finite number",)),
    ({"signal": "multilevel", "multilevel": {"levels": [1.0, "x"]}}, ("levels[1] must be a finite number",)),
    ({"signal": "chirp"}, ("signal must be one of prbs, multilevel, steps",)),
    ({"seed": -1}, ("seed must be an integer",)),
    ({"seed": 2.5}, ("seed must be an integer",)),
    ({"role": ["train"]}, ("parameter role must be a string",)),
    ({"steps": {"levels": [0.0], "dwell": 10, "colour": 1}}, ("steps has no field colour",)),
])
def test_bad_parameters_name_the_bag_and_field(tmp_path: Path, change: dict[str, Any],
                                               needles: tuple[str, ...]) -> None:
    bag = _bag(tmp_path / "bags" / "b", {**STEPS, **change})
    with pytest.raises(BagError) as err:
        roles_from_dir(tmp_path / "bags")
    _one_line(err, f"bag {bag}", *needles)


def test_good_parameters_still_give_the_role(tmp_path: Path) -> None:
    prbs = exc.PrbsConfig(bias=5.0, n_samples=100, settle=20)
    params = {"signal": "prbs", "seed": 3, "role": "train", "bias": 5, "prbs": prbs.__dict__}
    _bag(tmp_path / "bags" / "b", params)
    (role,) = roles_from_dir(tmp_path / "bags")
    assert (role.role, role.bias, role.settle) == ("train", 5.0, 20)


def test_core_configs_refuse_before_allocating() -> None:
    with pytest.raises(ConfigError, match="dwell must be <= 10000000"):
        exc.StepsConfig(levels=(0.0,), dwell=10**13)
    with pytest.raises(ConfigError, match=r"settle \+ n_samples = 10000001"):
        exc.PrbsConfig(n_samples=10_000_000, settle=1)
    with pytest.raises(ConfigError, match="bias must be a finite number"):
        exc.PrbsConfig(bias=float("nan"))
    with pytest.raises(ConfigError, match="n_samples must be an integer"):
        exc.MultilevelConfig(n_samples=True)
    with pytest.raises(ConfigError, match="must be a finite number"):
        exc.StepsConfig(levels=(10**400,))
    assert exc.StepsConfig(levels=[1, 2]).levels == (1.0, 2.0)  # type: ignore[arg-type]


@pytest.mark.parametrize("bits", [7, 9])
def test_prbs_bits_repeat_the_register_exactly(bits: int) -> None:
    """One period repeated is the register run bit by bit (the loop prbs_bits used to run)."""
    a, b = {7: (7, 6), 9: (9, 5)}[bits]
    period = (1 << bits) - 1
    state, expected = 1 + (5 % period), []
    for _ in range(3 * period + 17):
        bit = ((state >> (a - 1)) ^ (state >> (b - 1))) & 1
        state = ((state << 1) | bit) & period
        expected.append(1 if bit else -1)
    assert exc.prbs_bits(3 * period + 17, bits, 5).tolist() == expected


# --- metadata.yaml and custom_data -------------------------------------------------------------

def _info(doc: dict[str, Any]) -> dict[str, Any]:
    info: dict[str, Any] = doc["rosbag2_bagfile_information"]
    return info


@pytest.mark.parametrize(("edit", "needle"), [
    (lambda d: d.update(rosbag2_bagfile_information=[1]), "rosbag2_bagfile_information must be a mapping"),
    (lambda d: _info(d).update(topics_with_message_count={"a": 1}),
     "topics_with_message_count must be a list"),
    (lambda d: _info(d)["topics_with_message_count"][0].update(message_count="9"), "message_count must be"),
    (lambda d: _info(d).update(message_count=-3), "message_count must be a count >= 0"),
    (lambda d: _info(d).update(custom_data=["x"]), "custom_data must map strings to strings"),
    (lambda d: _info(d).update(relative_file_paths=[7]), "relative_file_paths must list file names"),
    (lambda d: _info(d).update(compression_mode="message", compression_format="zstd"),
     "is compressed by message"),
    (lambda d: _info(d)["custom_data"].update({"msd_bench.params": "[" * 5000 + "]" * 5000}),
     "nested too deeply"),
    (lambda d: _info(d)["custom_data"].update({"msd_bench.params": "1" * 5000}), "not valid JSON"),
    (lambda d: _info(d)["custom_data"].update({"msd_bench.params": "[1, 2]"}), "must be a JSON object"),
])
def test_bad_metadata_is_one_line_everywhere(tmp_path: Path, edit: Any, needle: str) -> None:
    bag = _bag(tmp_path / "b", {"a": 1})
    doc = _meta(bag)
    edit(doc)
    _put_meta(bag, doc)
    for read in (bag_info, read_experiment):
        with pytest.raises(BagError) as err:
            read(bag)
        _one_line(err, f"bag {bag}", needle)


@pytest.mark.parametrize(("text", "needle"), [
    (b"{{{{", "not valid YAML"),
    (b"[" * 20_000 + b"]" * 20_000, "metadata.yaml is n"),  # libyaml's own depth limit, or ours
    (b"a: " + b"x" * (5 << 20), "over the 4194304-byte limit"),
])
def test_unparsable_metadata(tmp_path: Path, text: bytes, needle: str) -> None:
    bag = _bag(tmp_path / "b")
    (bag / "metadata.yaml").write_bytes(text)
    with pytest.raises(BagError) as err:
        bag_info(bag)
    _one_line(err, needle)
    report = check_bag(bag)  # bag check lists it as a fault
    assert any(needle in p for p in report.problems), report.problems


def test_bag_check_compares_every_topic_and_the_times(tmp_path: Path) -> None:
    bag = _bag(tmp_path / "b")
    assert check_bag(bag).ok
    doc = _meta(bag)
    topics = _info(doc)["topics_with_message_count"]
    topics[0]["message_count"] += 10**15  # the total still agrees: only per-topic counts show it
    topics[1]["message_count"] -= 10
    topics[2]["message_count"] -= 10**15 - 10
    topics[2]["message_count"] = max(topics[2]["message_count"], 0)
    _info(doc)["message_count"] = sum(t["message_count"] for t in topics)
    _info(doc)["duration"]["nanoseconds"] += 1
    _info(doc)["starting_time"]["nanoseconds_since_epoch"] = 7
    _put_meta(bag, doc)
    report = check_bag(bag)
    names = [t["topic_metadata"]["name"] for t in topics]
    for name in names:
        assert any(f"on {name}, the data holds {N}" in p for p in report.problems), report.problems
    warned = report.warnings  # the times: reported, but the data is usable
    assert any("duration is" in w for w in warned) and any("starting_time is 7 ns" in w for w in warned)
    assert bag_main(["bag", "check", str(bag)]) == 1


def test_times_alone_are_a_warning(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = _bag(tmp_path / "b")
    doc = _meta(bag)
    _info(doc)["duration"]["nanoseconds"] += 10**9
    _put_meta(bag, doc)
    assert bag_main(["bag", "check", str(bag)]) == 0
    out, err = capsys.readouterr()
    assert out.startswith("ok: ") and "warning: " in err and "the data spans 1190000000 ns" in err


def _sqlite_bag(path: Path) -> Path:
    store = typestore()
    f64 = "std_msgs/msg/Float64"
    with RosbagsWriter(path, version=9, storage_plugin=StoragePlugin.SQLITE3) as w:
        conn = w.add_connection("/msd/position", f64, typestore=store)
        for k in range(5):
            w.write(conn, k * 10_000_000, store.serialize_cdr(store.types[f64](data=1.0), f64))
    return path


def test_sqlite3_bag_info_says_so_and_exits_0(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = _sqlite_bag(tmp_path / "sq")
    assert bag_main(["bag", "info", str(bag)]) == 0
    out, err = capsys.readouterr()
    assert "storage:   sqlite3" in out and "5 messages" in out and err == ""
    assert bag_main(["bag", "check", str(bag)]) == 2
    assert capsys.readouterr().err.strip().endswith("bag check reads MCAP bags only")


# --- lying MCAP lengths and sizes --------------------------------------------------------------

def _mcap(bag: Path) -> Path:
    return bag / f"{bag.name}.mcap"


def _first_chunk(path: Path) -> int:
    with path.open("rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    return int(summary.chunk_indexes[0].chunk_start_offset)


def _poke(path: Path, offset: int, value: int) -> None:
    with path.open("r+b") as fh:
        fh.seek(offset)
        fh.write(struct.pack("<Q", value))


def _every_reader_refuses(bag: Path, needle: str = "") -> None:
    for read in (bag_info, read_experiment, lambda b: read_topic(b, "/msd/position")):
        with pytest.raises(BagError) as err:
            read(bag)
        _one_line(err, f"bag {bag}", needle)
    assert not check_bag(bag).ok


@pytest.mark.parametrize("field", ["header", "chunk_record", "chunk_size"])
def test_huge_lengths_are_refused_without_allocating(tmp_path: Path, field: str) -> None:
    bag = _bag(tmp_path / "b")
    chunk = _first_chunk(_mcap(bag))
    where = {"header": 9, "chunk_record": chunk + 1, "chunk_size": chunk + 1 + 8 + 16}[field]
    _poke(_mcap(bag), where, 2**60)
    _every_reader_refuses(bag)
    (bag / "metadata.yaml").unlink()
    if field == "chunk_size":  # the chunk's data is whole (its CRC says so): recover keeps it
        assert recover(bag).messages == 3 * N
        return
    with pytest.raises(BagError) as err:  # the bag's one chunk is behind the lie: nothing to salvage
        recover(bag)
    _one_line(err, "no complete chunk to recover", "exceeds limit")


def _zstd_mcap(path: Path, payload: int) -> Path:
    """A ros2 MCAP whose one chunk is zstd-compressed: one Float64 message of ``payload`` extra bytes."""
    with path.open("wb") as fh:
        w = Writer(fh, compression=CompressionType.ZSTD)
        w.start(profile="ros2", library="test")
        schema = w.register_schema("std_msgs/msg/Float64", "ros2msg", b"float64 data")
        channel = w.register_channel("/msd/position", "cdr", schema)
        raw = b"\x00\x01\x00\x00" + struct.pack("<d", 1.0) + b"\x00" * payload
        w.add_message(channel, log_time=1, data=raw, publish_time=1)
        w.finish()
    return path


def test_chunk_index_pointing_far_past_the_end(tmp_path: Path) -> None:
    """Found by the long fuzz run: a chunk index offset of 2^60 made ``bag check``'s seek raise OSError."""
    bag = _bag(tmp_path / "b")
    mcap = _mcap(bag)
    with mcap.open("rb") as fh:
        summary = make_reader(fh).get_summary()
        assert summary is not None
    data = mcap.read_bytes()
    start = struct.pack("<Q", summary.chunk_indexes[0].chunk_start_offset)
    where = data.rindex(start)  # the chunk index record's chunk_start_offset field
    _poke(mcap, where, 2**60)
    problems = check_bag(bag).problems
    assert any("chunk index 0 points at offset 1152921504606846976" in p for p in problems), problems


def test_compressed_chunk_read_normally(tmp_path: Path) -> None:
    path = _zstd_mcap(tmp_path / "z.mcap", 0)
    assert bag_info(path).topics == {"/msd/position": ("std_msgs/msg/Float64", 1)}
    assert check_bag(path).ok


@pytest.mark.parametrize("claim", [16, MAX_CHUNK_BYTES + 1])
def test_compressed_chunk_that_inflates_beyond_its_claim(tmp_path: Path, claim: int) -> None:
    """1 MiB of zeros compresses to a few bytes; claiming 16 (or over the bound) must not inflate it."""
    path = _zstd_mcap(tmp_path / "z.mcap", 1 << 20)
    _poke(path, _first_chunk(path) + 1 + 8 + 16, claim)
    for read in (bag_info, lambda p: read_topic(p, "/msd/position")):
        with pytest.raises(BagError) as err:
            read(path)
        _one_line(err, str(path), "chunk")
    assert any("chunk" in p for p in check_bag(path).problems)


# --- paths that are not bags -------------------------------------------------------------------

def test_dangling_symlink_and_directory_named_mcap(tmp_path: Path) -> None:
    link = _bag(tmp_path / "link")
    _mcap(link).unlink()
    _mcap(link).symlink_to(tmp_path / "gone")
    folder = _bag(tmp_path / "folder")
    _mcap(folder).unlink()
    _mcap(folder).mkdir()
    alone = tmp_path / "alone.mcap"
    alone.symlink_to(tmp_path / "gone")
    for bag, needle in ((link, "dangling symlink"), (folder, "is a directory"), (alone, "dangling symlink")):
        for read in (bag_info, read_experiment, check_bag, recover):
            with pytest.raises(BagError) as err:
                read(bag)
            _one_line(err, needle)


def test_fifo_named_mcap_is_refused_without_blocking(tmp_path: Path) -> None:
    bag = _bag(tmp_path / "b")
    _mcap(bag).unlink()
    os.mkfifo(_mcap(bag))
    for read in (bag_info, check_bag, recover):
        with pytest.raises(BagError, match="not a regular file"):
            read(bag)


def test_recover_from_inside_the_bag(tmp_path: Path) -> None:
    bag = _bag(tmp_path / "b")
    (bag / "metadata.yaml").unlink()
    proc = subprocess.run([sys.executable, "-m", "msd_bench.commands.bag", "bag", "recover", "b.mcap"],
                          cwd=bag, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    assert (tmp_path / "b.recovered" / "metadata.yaml").exists()


def test_malformed_message_definition_in_recover(tmp_path: Path) -> None:
    path = tmp_path / "bad" / "bad.mcap"
    path.parent.mkdir()
    with path.open("wb") as fh:
        w = Writer(fh)
        w.start(profile="ros2", library="test")
        schema = w.register_schema("my_pkg/msg/Odd", "ros2msg", b"float64 data\nthis is not = a field [[")
        channel = w.register_channel("/odd", "cdr", schema)
        w.add_message(channel, log_time=1, data=b"\x00\x01\x00\x00" + b"\x00" * 8, publish_time=1)
        w.finish()
    with pytest.raises(BagError) as err:
        recover(path.parent)
    _one_line(err, "cannot rewrite salvaged messages")


def test_cli_one_line_for_each(tmp_path: Path) -> None:
    """The same faults through the process: exit 2, one error line, no traceback."""
    bag = _bag(tmp_path / "b", {**STEPS, "steps": {"levels": [0.0], "dwell": 10**13}})
    doc = _meta(bag)
    _info(doc)["custom_data"]["msd_bench.params"] = json.dumps({"x": 1}) + "x"
    _put_meta(bag, doc)
    proc = subprocess.run([sys.executable, "-m", "msd_bench.commands.bag", "bag", "info", str(bag)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and proc.stdout == ""
    lines = [line for line in proc.stderr.splitlines() if not line.startswith("WARNING")]
    assert len(lines) == 1 and lines[0].startswith("error: bag ") and "not valid JSON" in lines[0]
