"""Fault row "unwritable output / disk full": the bag is closed with what reached the disk, one line.

The full disk is a real 400 KiB tmpfs (root can mount one); the same fault is
also injected at the same layer (``os.write`` raising ENOSPC) so the row is
covered where mounting is not allowed.
"""

from __future__ import annotations

import errno
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from msd_bench.graph import launch
from msd_bench.io.bags import bag_writer
from msd_bench.io.bags.bag_check import check_bag
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_writer import BagRecorder, BagWriteError
from msd_bench.io.bags.reader import read_experiment, write_experiment
from msd_bench.io.storage.paths import OutputError, writable_dir

REPO = Path(__file__).resolve().parents[2]


def _mount_tmpfs(where: Path, size: str, *options: str) -> bool:
    where.mkdir(parents=True, exist_ok=True)
    opts = ",".join((f"size={size}", *options))
    return subprocess.run(["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(where)],
                          capture_output=True).returncode == 0


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path]:
    disk = tmp_path / "disk"
    if not _mount_tmpfs(disk, "400k"):
        pytest.skip("cannot mount a tmpfs here; test_injected_enospc_closes_the_bag covers the row")
    try:
        yield disk
    finally:
        subprocess.run(["umount", "-l", str(disk)], check=False)


@pytest.fixture
def read_only_disk(tmp_path: Path) -> Iterator[Path]:
    disk = tmp_path / "ro"
    if not _mount_tmpfs(disk, "64k", "ro"):
        pytest.skip("cannot mount a read-only tmpfs here")
    try:
        yield disk
    finally:
        subprocess.run(["umount", "-l", str(disk)], check=False)


@pytest.mark.e2e
def test_recorder_on_a_full_disk_closes_its_bag_and_exits_1(small_disk: Path) -> None:
    bag = small_disk / "run"
    with launch.process_group() as procs:
        procs.start("plant.py", ["-p", "duplicate_check:=0.0"]).wait_for_line(r"ready \(", 60.0)
        rec = procs.start("recorder.py", ["-p", f"bag_path:={bag}"])
        status = rec.wait(90.0)
    errors = [ln for ln in rec.lines if "ERROR" in ln or "error" in ln]
    assert status == 1, rec.output()
    assert len(errors) == 1 and "No space left on device" in errors[0] and "closed the bag" in errors[0]
    assert "Traceback" not in rec.output()
    kept = int(errors[0].split("with the ")[1].split(" of ")[0])
    report = check_bag(bag)
    assert report.ok, report.problems
    assert report.messages == kept > 1000  # about 10 s of 3 topics at 100 Hz before the disk filled
    assert len(read_experiment(bag)[0]) > 300


def test_injected_enospc_closes_the_bag(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    budget = {"bytes": 60_000}
    real_write = os.write

    def failing_write(fd: int, data: bytes | memoryview) -> int:
        if budget["bytes"] <= 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        n = real_write(fd, bytes(data)[: budget["bytes"]])
        budget["bytes"] -= n
        return n

    monkeypatch.setattr(bag_writer.os, "write", failing_write)
    n = 20_000
    t = np.arange(n, dtype=np.int64) * 10_000_000
    with pytest.raises(BagWriteError) as err, BagRecorder(tmp_path / "b", flush_period_s=0.0) as rec:
        for k in range(n):
            rec.write("/msd/force", "std_msgs/msg/Float64", int(t[k]), b"\x00\x01\x00\x00" + bytes(8))
    assert "\n" not in str(err.value) and "No space left on device" in str(err.value)
    assert check_bag(tmp_path / "b").messages == err.value.kept > 0
    assert err.value.dropped >= 1
    assert not (tmp_path / "b" / bag_writer.RESERVE_NAME).exists()


def test_read_only_storage_is_one_line_everywhere(read_only_disk: Path, tmp_path: Path) -> None:
    with pytest.raises(BagError, match="cannot create \\(Read-only file system\\)"):
        BagRecorder(read_only_disk / "bag").open()
    src = write_experiment(tmp_path / "src", np.arange(200) * 10_000_000, np.zeros(200), np.zeros(200),
                           np.zeros(200), params={})
    cases = [  # real processes for two entry points; the shared check is exercised in-process below
        [sys.executable, "-m", "msd_bench.commands.bag", "bag", "recover", str(src), "--output",
         str(read_only_disk / "rec")],
        [sys.executable, "launch_scripts/identifier.py", "--ros-args", "-p", f"bags_dir:={tmp_path}",
         "-p", f"out_dir:={read_only_disk / 'models'}"],
        [sys.executable, "launch_scripts/bench.py", "--out", str(src / "metadata.yaml" / "run"),
         "--stages", "report"],  # under a file
    ]
    for label, path in (("--out", read_only_disk / "run"), ("out_dir", src / "metadata.yaml" / "m")):
        with pytest.raises(OutputError) as err:
            writable_dir(path, label)
        assert str(err.value).startswith(f"{label} {path}: cannot write there (")
    for argv in cases:
        proc = subprocess.run(argv, cwd=REPO, capture_output=True, text=True, timeout=120)
        err = proc.stderr.strip()
        assert proc.returncode == 2, (argv, proc.stdout, err)
        assert "Traceback" not in err and err.count("\n") == 0, (argv, err)
        assert "Read-only file system" in err or "Not a directory" in err, (argv, err)
