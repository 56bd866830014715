"""One design for runs on disk: tasks written atomically, a manifest, a ``complete`` marker last.

A command's ``--out`` becomes a run directory (docs/design.md §Runs on disk)::

    <out>/manifest.json       command, configuration (and its hash), the task ids
    <out>/tasks/<task>.json   one record per finished task: the files it wrote, their sizes and hashes
    <out>/complete            written last, once every task is recorded
    <out>/...                 the tasks' own files (table1.json, models/, figures/ ...)

Why: a run that dies half-way must neither be mistaken for a finished one nor
block its own rerun, and a later cluster executor must be able to hand tasks to
workers and collect them. Every file goes through :mod:`msd_bench.io.storage.atomic`
(no torn file, no symlink followed below the root, which is resolved once);
a task counts as done only when its record exists, lists at least one file, and
every file it lists is still there with the recorded size and SHA-256 (a file
changed behind the run's back is never reused: its task is redone, and one line
on stderr says which task and why); the marker is written only when every task is done.

:meth:`RunDir.open` is also the probe of ``--out``: it is run before any work
and accepts only a missing or empty directory (a new run) or an unfinished run
of the same command and configuration (resumed: its done tasks are skipped).
Anything else is refused with one line naming what is there.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
import os
import re
import stat
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from msd_bench._version import __version__
from msd_bench.io.storage.atomic import Writer, remove_stale_temps, write_text_atomic, write_with
from msd_bench.io.storage.paths import OutputError
from msd_bench.io.storage.safe_read import read_json_bounded

RUN_SCHEMA = "msd-bench/run"
RUN_VERSION = 1
MANIFEST = "manifest.json"
TASKS = "tasks"
COMPLETE = "complete"
_TASK_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,99}")


class RunDirError(OutputError):
    """An output directory is not empty and not an unfinished run of this command and configuration."""


def config_hash(config: Mapping[str, Any]) -> str:
    """SHA-256 of the configuration's canonical JSON: what "the same configuration" means."""
    text = json.dumps(config, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


class RunDir:
    """An opened run directory; create it with :meth:`open`."""

    def __init__(self, root: Path, command: str, tasks: Sequence[str], resumed: bool) -> None:
        self.root = root
        """The resolved root: every write stays below it."""
        self.command = command
        self.tasks = tuple(tasks)
        self.resumed = resumed
        """True when an unfinished run was found and is continued."""
        self.written: list[str] = []
        """Tasks this process wrote (the ones skipped were done by an earlier attempt)."""
        self.say: Callable[[str], None] = _stderr
        """Where the one line about a record that cannot be trusted goes (stderr unless replaced)."""
        self._told: set[str] = set()

    @classmethod
    def open(cls, path: str | Path, command: str, tasks: Sequence[str], config: Mapping[str, Any],
             label: str = "--out") -> RunDir:
        """Probe and create ``path`` as a run of ``command``, or resume an unfinished one of it."""
        for t in tasks:
            if not _TASK_ID.fullmatch(t):
                raise ValueError(f"bad task id {t!r}")  # a programming error, not a user's
        path = Path(path)
        root = _probe_root(path, label)
        doc = {"schema": RUN_SCHEMA, "schema_version": RUN_VERSION, "command": command,
               "config_sha256": config_hash(config), "tasks": list(tasks),
               "config": json.loads(json.dumps(config, default=str)),
               "msd_bench_version": __version__}
        entries = sorted(os.listdir(root))
        if not entries:
            doc["created_utc"] = _now()
            _probe_write(root, {**doc}, path, label, exclusive=True)
            return cls(root, command, tasks, resumed=False)
        if MANIFEST not in entries:
            raise RunDirError(f"{label} {path} is not empty (holds {_names(entries)}) and is not a run of "
                              f"msd-bench {command}; choose a new or empty directory")
        old = _read_manifest(root, path, label)
        _check_same(old, doc, path, label, entries)
        # the probe of a resumed run: the manifest rewritten in place proves the directory writable
        _probe_write(root, {**old, "resumed_utc": _now()}, path, label, exclusive=False)
        remove_stale_temps(root)
        return cls(root, command, tasks, resumed=True)

    def path(self, rel: str) -> Path:
        """A path inside the run (for the task functions that write their own files)."""
        return self.root / rel

    def _record_path(self, task: str) -> Path:
        if task not in self.tasks:
            raise ValueError(f"task {task!r} is not in the manifest")  # a programming error
        return self.root / TASKS / f"{task}.json"

    def is_done(self, task: str) -> bool:
        """True when ``task`` was recorded and every file it wrote is still there, unchanged.

        A record that exists but cannot be trusted (unreadable, listing no files, naming
        a missing file or one whose size or SHA-256 differs) makes the task pending, and
        the first time it is seen a line names the record and the reason.
        """
        rec = self._record_path(task)
        if not _regular(rec):
            return False
        why = _record_problem(self.root, rec, task)
        if why is not None:
            if task not in self._told and task not in self.written:
                self._told.add(task)
                self.say(f"{TASKS}/{task}.json: {why}; task {task} is run again")
            return False
        return True

    def run_task(self, task: str, produce: Callable[[], Sequence[Path]]) -> bool:
        """Run ``produce`` (which writes files under the root, atomically) unless ``task`` is done.

        Returns True if it ran. The task's record, written after its files, lists them.
        """
        if self.is_done(task):
            return False
        self._record(task, produce())
        return True

    def write_task(self, task: str, files: Mapping[str, Writer]) -> bool:
        """Write each ``relative path -> writer`` atomically, then the task's record; skip a done task."""
        return self.run_task(task, lambda: [write_with(self.root / rel, w, root=self.root)
                                            for rel, w in files.items()])

    def _record(self, task: str, paths: Sequence[Path]) -> None:
        files = []
        for p in paths:
            p = Path(p)
            rel = Path(os.path.abspath(p)).relative_to(self.root).as_posix()
            data = p.read_bytes()
            files.append({"path": rel, "bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()})
        doc = {"task": task, "files": files, "finished_utc": _now()}
        write_text_atomic(self._record_path(task), json.dumps(doc, indent=1) + "\n", root=self.root)
        self.written.append(task)

    def pending(self) -> list[str]:
        """Tasks not done yet, in manifest order."""
        return [t for t in self.tasks if not self.is_done(t)]

    def mark_complete(self) -> Path:
        """Write the ``complete`` marker; refused while a task is not done."""
        missing = self.pending()
        if missing:
            raise RunDirError(f"{self.root}: tasks not done ({', '.join(missing)}); the run is not complete")
        doc = {"command": self.command, "tasks": list(self.tasks), "completed_utc": _now()}
        return write_text_atomic(self.root / COMPLETE, json.dumps(doc, indent=1) + "\n", root=self.root)


def is_complete(path: str | Path) -> bool:
    """Whether ``path`` holds a complete run: a readable manifest, the marker, and every task recorded."""
    root = Path(path)
    if not (_regular(root / MANIFEST) and _regular(root / COMPLETE)):
        return False
    try:
        doc = read_json_bounded(root / MANIFEST, RunDirError)
    except RunDirError:
        return False
    if not isinstance(doc, dict) or not isinstance(doc.get("tasks"), list):
        return False
    run = RunDir(Path(os.path.realpath(root)), str(doc.get("command")), [str(t) for t in doc["tasks"]], True)
    run.say = _silent  # a question, not a resume: nothing is run again
    return not run.pending()


def _probe_root(path: Path, label: str) -> Path:
    """Create ``path`` if needed; refuse a file; return it resolved (the only resolution of the root)."""
    if path.exists() and not path.is_dir():
        raise RunDirError(f"{label} {path} is a file, not a directory")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{label} {path}: cannot create it ({exc.strerror or exc})") from None
    return Path(os.path.realpath(path))


def _probe_write(root: Path, doc: Mapping[str, Any], shown: Path, label: str, exclusive: bool) -> None:
    """Write the manifest: the first write of a run, so it is the write probe of ``--out`` too."""
    try:
        write_text_atomic(root / MANIFEST, json.dumps(doc, indent=1) + "\n", root=root, exclusive=exclusive,
                          error=RunDirError)
    except RunDirError:
        raise
    except OutputError as exc:
        why = str(exc).rsplit("(", 1)[-1].rstrip(")") if "(" in str(exc) else str(exc)
        raise OutputError(f"{label} {shown}: cannot write there ({why})") from None


def _read_manifest(root: Path, shown: Path, label: str) -> dict[str, Any]:
    if not _regular(root / MANIFEST):
        raise RunDirError(f"{label} {shown}: {MANIFEST} is not a regular file; not a run of ours")
    doc = read_json_bounded(root / MANIFEST, RunDirError)
    if not isinstance(doc, dict) or doc.get("schema") != RUN_SCHEMA:
        raise RunDirError(f"{label} {shown}: {MANIFEST} is not an msd-bench run manifest; "
                          f"choose another {label}")
    return doc


def _check_same(old: Mapping[str, Any], new: Mapping[str, Any], shown: Path, label: str,
                entries: list[str]) -> None:
    """Resume only the same command, configuration and tasks, and never a complete run."""
    if old.get("command") != new["command"]:
        raise RunDirError(f"{label} {shown} holds a run of msd-bench {old.get('command')}, not "
                          f"{new['command']}; choose another {label}")
    if COMPLETE in entries:
        raise RunDirError(f"{label} {shown} already holds a complete {new['command']} run; choose another "
                          f"{label}")
    if old.get("config_sha256") != new["config_sha256"] or old.get("tasks") != new["tasks"]:
        raise RunDirError(f"{label} {shown} holds an unfinished {new['command']} run of another "
                          f"configuration (resume it with the same options, or choose another {label})")


def _regular(path: Path) -> bool:
    try:
        return stat.S_ISREG(os.lstat(path).st_mode)
    except (OSError, ValueError):  # ValueError: a NUL byte in a name read from a received record
        return False


def _record_problem(root: Path, rec: Path, task: str) -> str | None:
    """Why the task record ``rec`` does not vouch for its task's files, or None when it does."""
    try:
        doc = read_json_bounded(rec, RunDirError)
    except RunDirError:
        return "the record is not readable JSON"
    if not isinstance(doc, dict) or doc.get("task") != task or not isinstance(doc.get("files"), list):
        return "the record is not a task record of this task"
    if not doc["files"]:
        return "the record lists no files"
    for entry in doc["files"]:
        why = _entry_problem(root, entry)
        if why is not None:
            return why
    return None


def _entry_problem(root: Path, entry: Any) -> str | None:
    """Why a record's file entry does not match a regular file below ``root``, or None when it does."""
    if not isinstance(entry, dict) or not isinstance(entry.get("path"), str):
        return "the record has a file entry without a path"
    rel = Path(entry["path"])
    if rel.is_absolute() or ".." in rel.parts or not rel.parts:
        return f"the record names {entry['path']!r}, a path outside the run"
    try:
        info = os.lstat(root / rel)
    except (OSError, ValueError):
        return f"{rel.as_posix()} is missing"
    if not stat.S_ISREG(info.st_mode):
        return f"{rel.as_posix()} is not a regular file"
    if info.st_size != entry.get("bytes"):
        return f"{rel.as_posix()} has {info.st_size} bytes, the record says {entry.get('bytes')}"
    if _sha256(root / rel) != entry.get("sha256"):
        return f"{rel.as_posix()} does not match the SHA-256 in the record (changed since it was written)"
    return None


def _sha256(path: Path) -> str | None:
    h = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
    except OSError:
        return None
    return h.hexdigest()


def _silent(line: str) -> None:
    del line


def _stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def _names(entries: list[str], most: int = 3) -> str:
    shown = ", ".join(repr(e) for e in entries[:most])
    return shown + (f" and {len(entries) - most} more" if len(entries) > most else "")


__all__ = ["COMPLETE", "MANIFEST", "RUN_SCHEMA", "RunDir", "RunDirError", "config_hash", "is_complete"]
