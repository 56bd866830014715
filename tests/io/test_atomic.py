"""The atomic writer: old file or new file after any crash, no symlink followed below the root."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pytest

from msd_bench.io.storage import atomic
from msd_bench.io.storage.artifacts import ArtifactError
from msd_bench.io.storage.paths import OutputError

REPO = Path(__file__).resolve().parents[2]


def _sentinel(path: Path, text: str = "outside, not ours") -> tuple[str, int]:
    path.write_text(text)
    os.utime(path, ns=(1_000_000_000, 1_000_000_000))
    return text, path.stat().st_mtime_ns


def _untouched(path: Path, before: tuple[str, int]) -> bool:
    return (path.read_text(), path.stat().st_mtime_ns) == before


def _temps(root: Path) -> list[Path]:
    return [p for p in root.rglob("*") if p.name.startswith(atomic.TEMP_PREFIX)]


def test_replaces_and_leaves_no_temporary_file(tmp_path: Path) -> None:
    target = tmp_path / "out" / "deep" / "r.json"
    atomic.write_text_atomic(target, "old\n", root=tmp_path / "out")
    atomic.write_text_atomic(target, "new\n", root=tmp_path / "out")
    assert target.read_text() == "new\n"
    assert _temps(tmp_path) == []


def test_failed_rename_keeps_the_old_file_and_no_temporary(tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    target = tmp_path / "r.json"
    target.write_text("old")

    def crash(*args: object, **kwargs: object) -> None:
        raise OSError(5, "Input/output error")

    monkeypatch.setattr(atomic.os, "replace", crash)
    with pytest.raises(OutputError) as err:
        atomic.write_text_atomic(target, "new")
    assert "\n" not in str(err.value) and "Input/output error" in str(err.value)
    assert target.read_text() == "old"
    assert _temps(tmp_path) == []


def test_failed_write_keeps_the_old_file(tmp_path: Path) -> None:
    target = tmp_path / "fig.png"
    target.write_bytes(b"old")

    def half_then_fail(fh: object) -> None:
        fh.write(b"half")  # type: ignore[attr-defined]
        raise OSError(28, "No space left on device")

    with pytest.raises(OutputError, match="No space left on device"):
        atomic.write_with(target, half_then_fail)
    assert target.read_bytes() == b"old"
    assert _temps(tmp_path) == []


KILLED = """
import os, sys
from pathlib import Path
from msd_bench.io.storage import atomic
os.replace = lambda *a, **k: os._exit(9)   # the process dies between the write and the rename
atomic.write_text_atomic(Path(sys.argv[1]), "new content\\n")
"""


def test_process_killed_before_the_rename_leaves_the_old_file(tmp_path: Path) -> None:
    target = tmp_path / "result.json"
    target.write_text("old content\n")
    proc = subprocess.run([sys.executable, "-c", textwrap.dedent(KILLED), str(target)], cwd=REPO,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 9, proc.stderr
    assert target.read_text() == "old content\n"
    left = _temps(tmp_path)
    assert len(left) == 1 and left[0].read_text() == "new content\n"  # written whole, never renamed
    atomic.write_text_atomic(target, "rerun\n")  # the leftover blocks nothing
    assert target.read_text() == "rerun\n"
    assert atomic.remove_stale_temps(tmp_path) == 1 and _temps(tmp_path) == []


def test_symlink_at_the_target_is_refused(tmp_path: Path) -> None:
    outside = tmp_path / "victim.txt"
    before = _sentinel(outside)
    root = tmp_path / "run"
    (root / "report").mkdir(parents=True)
    (root / "report" / "table1.md").symlink_to(outside)
    with pytest.raises(OutputError, match=r"table1\.md: is a symlink"):
        atomic.write_text_atomic(root / "report" / "table1.md", "Table 1\n", root=root)
    assert _untouched(outside, before)


def test_symlink_in_a_directory_below_the_root_is_refused(tmp_path: Path) -> None:
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    before = _sentinel(elsewhere / "table1.md")
    root = tmp_path / "run"
    root.mkdir()
    (root / "report").symlink_to(elsewhere)
    with pytest.raises(OutputError, match="report is a symlink inside the output directory"):
        atomic.write_text_atomic(root / "report" / "table1.md", "x", root=root)
    assert _untouched(elsewhere / "table1.md", before)
    assert sorted(p.name for p in elsewhere.iterdir()) == ["table1.md"]


def test_the_root_itself_is_resolved_once(tmp_path: Path) -> None:
    real = tmp_path / "real"
    real.mkdir()
    (tmp_path / "link").symlink_to(real)
    atomic.write_text_atomic(tmp_path / "link" / "a" / "b.txt", "ok", root=tmp_path / "link")
    assert (real / "a" / "b.txt").read_text() == "ok"


def test_a_path_outside_the_root_and_a_directory_target_are_refused(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="outside the output directory"):
        atomic.write_text_atomic(tmp_path / "a" / ".." / "b.txt", "x", root=tmp_path / "a")
    (tmp_path / "d").mkdir()
    with pytest.raises(OutputError, match="not a regular file"):
        atomic.write_text_atomic(tmp_path / "d", "x")


def test_exclusive_refuses_an_existing_file(tmp_path: Path) -> None:
    target = tmp_path / "m.json"
    target.write_text("first")
    with pytest.raises(ArtifactError, match="refusing to overwrite"):
        atomic.write_text_atomic(target, "second", exclusive=True, error=ArtifactError)
    assert target.read_text() == "first" and _temps(tmp_path) == []


def test_figure_and_npz_variants_round_trip(tmp_path: Path) -> None:
    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 0])
    png = atomic.save_figure_atomic(fig, tmp_path / "f.png")
    plt.close(fig)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    npz = atomic.savez_atomic(tmp_path / "q.npz", {"q": np.arange(6.0).reshape(2, 3)})
    with np.load(npz) as data:
        np.testing.assert_array_equal(data["q"], np.arange(6.0).reshape(2, 3))


def test_exclusive_never_clobbers_a_file_that_appeared_meanwhile(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    target = tmp_path / "m.json"
    target.write_text("a concurrent writer's")
    monkeypatch.setattr(atomic, "_check_target", lambda *a: None)  # the file appears after the check
    with pytest.raises(ArtifactError, match="refusing to overwrite"):
        atomic.write_text_atomic(target, "ours", exclusive=True, error=ArtifactError)
    assert target.read_text() == "a concurrent writer's" and _temps(tmp_path) == []
