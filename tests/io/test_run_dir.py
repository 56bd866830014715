"""Run directories: probe, manifest, task records, resume, and ``complete`` written last."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from msd_bench.io.storage import atomic
from msd_bench.io.storage.run_dir import COMPLETE, MANIFEST, RunDir, RunDirError, is_complete

TASKS = ["a", "b", "c"]
CONFIG = {"seeds": 3, "preset": "default"}


def _text(data: str) -> atomic.Writer:
    def write(fh: object) -> None:
        fh.write(data.encode())  # type: ignore[attr-defined]

    return write


def test_a_new_run_is_not_complete_until_every_task_and_the_marker(tmp_path: Path) -> None:
    rd = RunDir.open(tmp_path / "run", "paper", TASKS, CONFIG)
    manifest = json.loads((tmp_path / "run" / MANIFEST).read_text())
    assert manifest["command"] == "paper" and manifest["tasks"] == TASKS and manifest["config"] == CONFIG
    for t in TASKS:
        assert not is_complete(tmp_path / "run")
        rd.write_task(t, {f"{t}/out.txt": _text(t)})
    assert not is_complete(tmp_path / "run")  # every task done, but no marker yet
    rd.mark_complete()
    assert is_complete(tmp_path / "run")
    assert (tmp_path / "run" / "b" / "out.txt").read_text() == "b"


def test_the_marker_is_refused_while_a_task_is_missing(tmp_path: Path) -> None:
    rd = RunDir.open(tmp_path, "paper", TASKS, CONFIG)
    rd.write_task("a", {"a.txt": _text("a")})
    with pytest.raises(RunDirError, match="tasks not done \\(b, c\\)"):
        rd.mark_complete()
    assert not (tmp_path / COMPLETE).exists() and not is_complete(tmp_path)


def test_a_marker_without_its_tasks_is_not_complete(tmp_path: Path) -> None:
    rd = RunDir.open(tmp_path, "paper", TASKS, CONFIG)
    rd.write_task("a", {"a.txt": _text("a")})
    (tmp_path / COMPLETE).write_text("{}")  # planted by hand, or a copy that lost files
    assert not is_complete(tmp_path)


def test_resume_skips_done_tasks_and_redoes_a_changed_one(tmp_path: Path) -> None:
    calls: list[str] = []

    def produce(rd: RunDir, task: str) -> list[Path]:
        calls.append(task)
        return [atomic.write_text_atomic(rd.root / f"{task}.txt", task * 3, root=rd.root)]

    first = RunDir.open(tmp_path, "paper", TASKS, CONFIG)
    first.run_task("a", lambda: produce(first, "a"))
    first.run_task("b", lambda: produce(first, "b"))
    # the first attempt dies here: "c" never ran, no marker
    (tmp_path / "b.txt").write_text("b")  # and b's file lost bytes since
    (tmp_path / f"{atomic.TEMP_PREFIX}c.txt.dead").write_text("half")  # what a killed writer leaves
    again = RunDir.open(tmp_path, "paper", TASKS, CONFIG)
    assert again.resumed
    for t in TASKS:
        again.run_task(t, lambda t=t: produce(again, t))  # type: ignore[misc]
    again.mark_complete()
    assert calls == ["a", "b", "b", "c"]  # a was not recomputed; b was, its file having changed
    assert again.written == ["b", "c"]
    assert not list(tmp_path.glob(f"{atomic.TEMP_PREFIX}*"))
    assert is_complete(tmp_path)


def _sentinel(path: Path) -> tuple[str, int]:
    path.write_text("my thesis")
    return path.read_text(), path.stat().st_mtime_ns


@pytest.mark.parametrize("mismatch", ["command", "config", "tasks"])
def test_another_run_is_refused(tmp_path: Path, mismatch: str) -> None:
    RunDir.open(tmp_path, "paper", TASKS, CONFIG)
    before = (tmp_path / MANIFEST).read_bytes()
    args = {"command": ("efficiency", TASKS, CONFIG), "config": ("paper", TASKS, {**CONFIG, "seeds": 4}),
            "tasks": ("paper", [*TASKS, "d"], CONFIG)}[mismatch]
    with pytest.raises(RunDirError) as err:
        RunDir.open(tmp_path, *args)
    assert "\n" not in str(err.value) and "choose another --out" in str(err.value)
    assert (tmp_path / MANIFEST).read_bytes() == before


def test_a_complete_run_is_refused(tmp_path: Path) -> None:
    rd = RunDir.open(tmp_path, "paper", ["a"], CONFIG)
    rd.write_task("a", {"a.txt": _text("a")})
    rd.mark_complete()
    with pytest.raises(RunDirError, match="already holds a complete paper run"):
        RunDir.open(tmp_path, "paper", ["a"], CONFIG)


def test_a_directory_of_someone_else_is_refused_and_untouched(tmp_path: Path) -> None:
    before = _sentinel(tmp_path / "thesis.tex")
    with pytest.raises(RunDirError, match=r"holds 'thesis\.tex'.*not a run of msd-bench paper"):
        RunDir.open(tmp_path, "paper", TASKS, CONFIG)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["thesis.tex"]
    assert ((tmp_path / "thesis.tex").read_text(), (tmp_path / "thesis.tex").stat().st_mtime_ns) == before


def test_a_file_as_out_is_refused(tmp_path: Path) -> None:
    (tmp_path / "f").write_text("keep")
    with pytest.raises(RunDirError, match=r"--out .* is a file"):
        RunDir.open(tmp_path / "f", "paper", TASKS, CONFIG)
    assert (tmp_path / "f").read_text() == "keep"


def test_a_task_writing_through_a_symlink_is_refused(tmp_path: Path) -> None:
    outside = tmp_path / "outside.txt"
    before = _sentinel(outside)
    rd = RunDir.open(tmp_path / "run", "paper", TASKS, CONFIG)
    (tmp_path / "run" / "a.txt").symlink_to(outside)
    with pytest.raises(atomic.OutputError, match="is a symlink"):
        rd.write_task("a", {"a.txt": _text("injected")})
    assert (outside.read_text(), outside.stat().st_mtime_ns) == before
    assert not rd.is_done("a")


def _two_done(tmp_path: Path) -> list[str]:
    first = RunDir.open(tmp_path, "paper", TASKS, CONFIG)
    first.write_task("a", {"parts/a.json": _text('{"mae": 2.536}')})
    first.write_task("b", {"parts/b.json": _text('{"mae": 1.000}')})
    return []  # the first attempt dies here


def _resume(tmp_path: Path) -> tuple[RunDir, list[str]]:
    lines: list[str] = []
    again = RunDir.open(tmp_path, "paper", TASKS, CONFIG)
    again.say = lines.append
    return again, lines


def test_a_reused_file_tampered_at_the_same_length_is_recomputed_with_one_line(tmp_path: Path) -> None:
    _two_done(tmp_path)
    (tmp_path / "parts" / "a.json").write_text('{"mae": 0.036}')  # same byte length, forged value
    again, lines = _resume(tmp_path)
    assert again.pending() == ["a", "c"] and again.pending() == ["a", "c"]
    assert lines == ["tasks/a.json: parts/a.json does not match the SHA-256 in the record "
                     "(changed since it was written); task a is run again"]
    for t in TASKS:
        again.write_task(t, {f"parts/{t}.json": _text('{"mae": 2.536}')})
    assert again.written == ["a", "c"]
    assert (tmp_path / "parts" / "a.json").read_text() == '{"mae": 2.536}'
    again.mark_complete()
    assert is_complete(tmp_path)


@pytest.mark.parametrize(("damage", "said"), [
    ("empty", "tasks/a.json: the record lists no files; task a is run again"),
    ("missing", "tasks/a.json: parts/a.json is missing; task a is run again"),
])
def test_a_record_listing_no_files_or_a_missing_one_is_redone_and_named(
        tmp_path: Path, damage: str, said: str) -> None:
    _two_done(tmp_path)
    rec = tmp_path / "tasks" / "a.json"
    if damage == "empty":
        doc = json.loads(rec.read_text())
        rec.write_text(json.dumps({**doc, "files": []}))
    else:
        (tmp_path / "parts" / "a.json").unlink()
    again, lines = _resume(tmp_path)
    assert again.run_task("a", lambda: [atomic.write_text_atomic(tmp_path / "parts" / "a.json", "{}",
                                                                 root=again.root)])
    assert lines == [said]
    assert not again.run_task("b", lambda: [])  # b's record still vouches for its file
    assert again.is_done("a") and lines == [said]
