"""The launcher's side of a served node process (:mod:`msd_bench.nodes.serve`).

A :class:`JobServer` is one long-lived launch script started with
``--serve``; each :meth:`JobServer.submit` runs one node in it and returns a
:class:`Job`, which answers the questions a launcher asks of a node process
(its output lines, a line it waits for, its exit status, stop it) for that
node alone. So a stage written against one process per node runs unchanged
against one process for all of them.
"""

from __future__ import annotations

import contextlib
import json
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from msd_bench.app.serve_protocol import READY_LINE, SERVE_FLAG, STOP_LINE, exit_pattern, parse_event
from msd_bench.graph.launch import LaunchError, NodeProcess, ProcessSet, stop
from msd_bench.io.storage.atomic import write_text_atomic


def last_line(lines: Sequence[str], contains: str = "") -> str:
    """The last non-empty output line containing ``contains``, a served process's own lines aside
    (what a stage quotes when a node fails or finishes)."""
    kept = [ln for ln in lines if contains in ln and ln.strip() and not ln.startswith("[serve]")]
    return kept[-1].strip() if kept else ""


JOBS_DIR = "jobs"
"""Where the stages write each node's job file under the run directory."""


@dataclass(frozen=True)
class JobFiles:
    """Where a stage writes the job files of its nodes: ``<root>/jobs/<name>.json``, atomically.

    Why files in the run directory and not ``-p`` strings: they are the record of what each
    node was asked to do (docs/design.md §Jobs), and one loader reads them
    (:func:`msd_bench.nodes.params.use_job`). ``root`` bounds the write: no symlink under it is
    followed (:mod:`msd_bench.io.storage.atomic`).
    """

    root: Path
    """The run directory."""

    def write(self, name: str, doc: dict[str, Any]) -> Path:
        """Write job ``doc`` (from :func:`msd_bench.app.job.job_document`) as ``jobs/<name>.json``."""
        path = self.root / JOBS_DIR / f"{name}.json"
        return write_text_atomic(path, json.dumps(doc, indent=1) + "\n", root=self.root)

    def args(self, name: str, doc: dict[str, Any]) -> list[str]:
        """The ROS arguments handing a node its job: ``-p job:=<path>`` (the file written now)."""
        return ["-p", f"job:={self.write(name, doc)}"]


READY_TIMEOUT = 60.0
"""Seconds a served process gets to import and join the graph."""


@dataclass
class Job:
    """One node run by a :class:`JobServer`: its own lines, exit status and stop."""

    server: JobServer
    index: int
    since: int
    """Index of the first output line that can belong to this job."""
    name: str
    status: int | None = None

    @property
    def lines(self) -> list[str]:
        """The server's output since this job was submitted."""
        return self.server.proc.lines[self.since:]

    def own_lines(self) -> list[str]:
        """This job's lines alone: those up to its exit line (a later job's follow it)."""
        rx = re.compile(self._exit_pattern)
        lines = self.lines
        for i, line in enumerate(lines):
            if rx.search(line):
                return lines[:i]
        return lines

    def events(self, node: str, event: str) -> list[dict[str, Any]]:
        """This job's structured result events named ``event`` from node ``node``
        (:func:`msd_bench.app.serve_protocol.parse_event`: a malformed one is its EventError)."""
        found = (parse_event(line, node) for line in self.own_lines())
        return [e for e in found if e is not None and e["event"] == event]

    def wait_for_line(self, pattern: str, timeout: float) -> str:
        """The first line of this job matching ``pattern``; LaunchError on timeout or if the server died."""
        try:
            return self.server.proc.wait_for_line(pattern, timeout, self.since)
        except LaunchError as err:
            raise LaunchError(str(err).replace(self.server.proc.name, self.name, 1)) from None

    def finished(self) -> bool:
        """Whether this job has ended (or its server has)."""
        if self.status is not None or self.server.proc.popen.poll() is not None:
            return True
        rx = re.compile(self._exit_pattern)
        return any(rx.search(line) for line in self.lines)

    def wait(self, timeout: float) -> int:
        """The job's exit status once it ends; LaunchError if it is still running after ``timeout``."""
        if self.status is None:
            line = self.wait_for_line(self._exit_pattern, timeout)
            self.status = int(line.rsplit(" ", 1)[-1])
        return self.status

    def stop(self, timeout: float = 15.0) -> int:
        """End the job as Ctrl-C ends a node (a recorder completes its bag); its exit status.

        A server that does not answer in ``timeout`` is stopped as a process.
        """
        if self.status is not None:
            return self.status
        if self.server.proc.popen.poll() is None and not self.finished():
            with contextlib.suppress(LaunchError):  # it ended meanwhile: the wait below says how
                self.server.proc.send(STOP_LINE)
        try:
            return self.wait(timeout)
        except LaunchError:
            self.status = stop(self.server.proc)
            return self.status

    @property
    def _exit_pattern(self) -> str:
        return exit_pattern(self.index)


class JobServer:
    """One launch script run with ``--serve``: nodes one after another in a single process."""

    def __init__(self, procs: ProcessSet, script: str, name: str) -> None:
        """Start it (do not wait: start several, then :meth:`ready` each)."""
        self.name = name
        self.proc: NodeProcess = procs.start(script, script_args=[SERVE_FLAG], name=name, stdin=True)
        self.submitted = 0

    def ready(self, timeout: float = READY_TIMEOUT) -> JobServer:
        """Wait until the process can take jobs."""
        self.proc.wait_for_line("^" + re.escape(READY_LINE) + "$", timeout)
        return self

    def submit(self, ros_args: Sequence[str], name: str) -> Job:
        """Run one node with these ROS arguments (what would follow ``--ros-args``)."""
        job = Job(self, self.submitted, len(self.proc.lines), name)
        self.proc.send(json.dumps(list(ros_args)))
        self.submitted += 1
        return job

    def close(self, timeout: float = 15.0) -> int:
        """No more jobs: the process ends after its running node; its exit status."""
        self.proc.end_input()
        try:
            return self.proc.wait(timeout)
        except LaunchError:
            return stop(self.proc)
