"""Timing validation when bags are read, ``bag check`` (CRC + index), killed-bag hints."""

from __future__ import annotations

import shutil
import struct
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from msd_bench.commands.bag import main as bag_main
from msd_bench.io.bags.bag_check import check_bag
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_records import BagRole, bag_dirs, load_records, roles_from_dir
from msd_bench.io.bags.bag_timing import IDENTIFY, TimingPolicy, check_timing
from msd_bench.io.bags.reader import read_experiment, write_experiment

DT_NS = 10_000_000
N = 300


def _bag(path: Path, t: np.ndarray, params: dict[str, object] | None = None) -> Path:
    n = t.size
    rng = np.random.default_rng(1)
    return write_experiment(path, t, rng.normal(size=n), rng.normal(size=n), np.zeros(n), params=params or {})


def _regular(n: int = N) -> np.ndarray:
    return np.arange(n, dtype=np.int64) * DT_NS


def _one_line(err: pytest.ExceptionInfo[BagError], *needles: str) -> None:
    text = str(err.value)
    assert "\n" not in text
    for needle in needles:
        assert needle in text, text


def test_regular_bag_passes_every_policy(tmp_path: Path) -> None:
    bag = _bag(tmp_path / "ok", _regular())
    exp, _ = read_experiment(bag, timing=IDENTIFY)
    assert len(exp) == N


def test_stamps_going_backwards_name_the_sample() -> None:
    t = _regular()
    t[57] = t[55] - 1_000_000  # sample 57 stamped before 56 (and 55)
    with pytest.raises(BagError) as err:
        check_timing("b", t)
    _one_line(err, "bag b", "sample 57", "before sample 56")


def test_duplicate_stamp_names_the_sample() -> None:
    t = _regular()
    t[120:] -= DT_NS  # 120 repeats 119, the rest stays regular
    with pytest.raises(BagError) as err:
        check_timing("b", t)
    _one_line(err, "sample 120 repeats the stamp of sample 119")


def test_gap_is_named_with_its_length() -> None:
    t = _regular()
    t[200:] += 2_000_000_000
    with pytest.raises(BagError) as err:
        check_timing("b", t)
    _one_line(err, "gap of 2.010 s between sample 199 and 200", "1 gap in all")


def test_dropped_single_sample_is_a_gap() -> None:
    t = np.delete(_regular(), 150)
    with pytest.raises(BagError, match=r"gap of 0.020 s between sample 149 and 150"):
        check_timing("b", t)


def test_other_rate_names_both_rates(tmp_path: Path) -> None:
    bag = _bag(tmp_path / "khz", np.arange(N, dtype=np.int64) * 1_000_000)
    with pytest.raises(BagError) as err:
        read_experiment(bag)
    _one_line(err, str(bag), "1.000 ms apart", "dt is 10.000 ms", "1000 Hz", "100 Hz")


def test_jitter_within_tolerance_passes() -> None:
    jitter = np.random.default_rng(0).integers(-2_000_000, 2_000_000, N)
    check_timing("b", _regular() + jitter, TimingPolicy(gap_factor=1.5))


def test_short_bag_refused_for_identification_only(tmp_path: Path) -> None:
    bag = _bag(tmp_path / "short", _regular(10))
    assert len(read_experiment(bag)[0]) == 10  # plain reads take it
    with pytest.raises(BagError) as err:
        load_records([BagRole(bag, "train", None, 0), BagRole(bag, "validation", None, 0)], False)
    _one_line(err, str(bag), "only 10 samples", "at least 100")


def test_bag_stored_out_of_log_order_is_refused(tmp_path: Path) -> None:
    """Header stamps out of order relative to log time: the classic rig-clock fault."""
    from msd_bench.io.bags.reader import BagRecorder, typestore

    store = typestore()
    types = store.types
    order = list(range(N))
    order[40], order[41] = order[41], order[40]
    with BagRecorder(tmp_path / "swapped") as rec:
        for log_k, k in enumerate(order):
            ns = k * DT_NS
            msg = types["sensor_msgs/msg/JointState"](
                header=types["std_msgs/msg/Header"](
                    stamp=types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
                    frame_id=""),
                name=["msd_slider"], position=np.array([0.0]), velocity=np.array([0.0]),
                effort=np.array([0.0]))
            rec.write("/msd/joint_states", "sensor_msgs/msg/JointState", log_k * DT_NS,
                      store.serialize_cdr(msg, "sensor_msgs/msg/JointState"))
    with pytest.raises(BagError, match=r"sample 41 is stamped 10.000 ms before sample 40"):
        read_experiment(tmp_path / "swapped")


def test_killed_bag_in_a_bags_dir_points_at_recover(tmp_path: Path) -> None:
    _bag(tmp_path / "a_ok", _regular(), {"role": "train"})
    killed = _bag(tmp_path / "b_killed", _regular(), {"role": "train"})
    (killed / "metadata.yaml").unlink()
    with pytest.raises(BagError) as err:
        roles_from_dir(tmp_path)
    _one_line(err, str(killed), "no metadata.yaml", f"msd-bench bag recover {killed}")
    shutil.copytree(tmp_path / "a_ok", tmp_path / "b_killed.recovered")
    assert [p.name for p in bag_dirs(tmp_path)] == ["a_ok", "b_killed.recovered"]


def test_bag_check_passes_a_sound_bag_and_counts(tmp_path: Path) -> None:
    report = check_bag(_bag(tmp_path / "ok", _regular()))
    assert report.ok, report.problems
    assert (report.messages, report.chunks) == (3 * N, 1)


def test_bag_check_finds_a_flipped_data_byte(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = _bag(tmp_path / "flip", _regular())
    mcap = bag / "flip.mcap"
    data = bytearray(mcap.read_bytes())
    data[len(data) // 3] ^= 0x40
    mcap.write_bytes(bytes(data))
    assert bag_main(["bag", "check", str(bag)]) == 1
    assert "CRC mismatch" in capsys.readouterr().out
    assert bag_main(["bag", "info", str(bag)]) == 0  # info still shows, with a warning
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "warning" in err and "bag check" in err


def test_bag_check_finds_a_bad_chunk_index(tmp_path: Path) -> None:
    bag = _bag(tmp_path / "idx", _regular())
    mcap = bag / "idx.mcap"
    with mcap.open("rb") as fh:
        idx = make_reader(fh).get_summary().chunk_indexes[0]  # type: ignore[union-attr]
    data = mcap.read_bytes()
    needle = struct.pack("<Q", idx.chunk_start_offset) + struct.pack("<Q", idx.chunk_length)
    at = data.rindex(needle)
    patched = data[:at] + struct.pack("<Q", idx.chunk_start_offset + 5) + data[at + 8:]
    mcap.write_bytes(patched)
    report = check_bag(bag)
    assert not report.ok
    assert any("chunk index 0 points at offset" in p for p in report.problems), report.problems


def test_bag_check_finds_a_metadata_count_mismatch(tmp_path: Path) -> None:
    bag = _bag(tmp_path / "meta", _regular())
    meta = bag / "metadata.yaml"
    meta.write_text(meta.read_text().replace(f"\n  message_count: {3 * N}\n", "\n  message_count: 7\n"))
    report = check_bag(bag)
    assert report.problems == [f"metadata.yaml says 7 messages, the data holds {3 * N}"]


def test_bag_check_on_a_truncated_file(tmp_path: Path) -> None:
    bag = _bag(tmp_path / "cut", _regular())
    mcap = bag / "cut.mcap"
    with mcap.open("r+b") as fh:
        fh.truncate(mcap.stat().st_size // 2)
    report = check_bag(bag)
    assert any("truncated or corrupt" in p for p in report.problems), report.problems


def test_bag_info_prints_counts_it_verified_and_names_a_claim_that_disagrees(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = _bag(tmp_path / "claim", _regular())
    assert bag_main(["bag", "info", str(bag)]) == 0
    out, err = capsys.readouterr()
    assert f"/msd/joint_states  [sensor_msgs/msg/JointState]  {N} messages\n" in out and not err
    meta = bag / "metadata.yaml"
    text = meta.read_text()
    at = text.index("  - message_count: 300\n")  # the first topic's claim: /msd/joint_states
    meta.write_text(text[:at] + "  - message_count: 1000000000000000\n" + text[at + 23:])
    assert bag_main(["bag", "info", str(bag)]) == 0
    out, err = capsys.readouterr()
    assert f"/msd/joint_states  [sensor_msgs/msg/JointState]  {N} messages (metadata.yaml claims " \
           "1000000000000000)" in out
    assert err.count("\n") == 1 and "disagree with the data on /msd/joint_states" in err


def test_bag_info_marks_counts_of_a_damaged_bag_as_not_verified(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = _bag(tmp_path / "flip", _regular())
    mcap = bag / "flip.mcap"
    data = bytearray(mcap.read_bytes())
    data[len(data) // 3] ^= 0x40
    mcap.write_bytes(bytes(data))
    assert bag_main(["bag", "info", str(bag)]) == 0
    out = capsys.readouterr().out
    assert out.count("(metadata.yaml's count, not verified)") == 3
