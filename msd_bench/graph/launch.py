"""Start node processes from launch scripts and guarantee none is left behind.

Why not ``ros2 launch``: the PyPI wheels ship no launch system, and tests,
benchmarks and ``bench.py`` need exact control: each child is started with
``sys.executable`` in its own process group, inherits the environment plus
``ROS_DOMAIN_ID`` / ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, and is
stopped by SIGINT, then SIGTERM, then SIGKILL. A child gets SIGTERM when the
thread that started it dies (``PR_SET_PDEATHSIG``), so a killed bench.py leaves
no node running, and starts with SIGINT/SIGTERM blocked until its launch
script has installed handlers for them (a stop during start-up exits 0). A SIGKILLed Fast DDS process
cannot unlink its shared-memory segments, so :func:`stop` removes the
``/dev/shm`` files it had open that no other process still uses.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from msd_bench.core.errors import MsdBenchError
from msd_bench.dds import confine_to_loopback

REPO_ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = REPO_ROOT / "launch_scripts"
OUTPUT_DRAIN_S = 20.0
"""Longest wait for a process's last output lines once it has ended (its reader thread drains the pipe)."""
SHM = Path("/dev/shm")
SHM_PREFIXES = ("/dev/shm/fastdds", "/dev/shm/fastrtps")
"""Fast DDS 3 (Kilted) names its segments fastdds_*, Fast DDS 2 (Jazzy) fastrtps_*."""


class LaunchError(MsdBenchError):
    """A node process did not start, did not become ready, or would not stop."""


@dataclass
class NodeProcess:
    """A running launch script with its merged stdout/stderr collected line by line."""

    name: str
    popen: subprocess.Popen[str]
    lines: list[str] = field(default_factory=list)
    shm_files: set[str] = field(default_factory=set)
    reader: threading.Thread | None = None

    @property
    def pid(self) -> int:
        """Process id (also the process group id)."""
        return self.popen.pid

    def output(self) -> str:
        """Everything the process printed so far."""
        return "\n".join(self.lines)

    def wait_for_line(self, pattern: str, timeout: float, since: int = 0) -> str:
        """The first output line from line ``since`` on matching ``pattern`` (regex); LaunchError on
        timeout or exit."""
        rx = re.compile(pattern)
        deadline = time.monotonic() + timeout
        seen = since
        while time.monotonic() < deadline:
            for line in self.lines[seen:]:
                if rx.search(line):
                    return line
            seen = len(self.lines)
            if self.popen.poll() is not None and seen == len(self.lines):
                raise LaunchError(f"{self.name} exited ({self.popen.returncode}) before {pattern!r}")
            time.sleep(0.02)
        raise LaunchError(f"{self.name}: no line matching {pattern!r} within {timeout} s")

    def send(self, line: str) -> None:
        """Write one line to the process's stdin (started with ``stdin=True``); LaunchError if it is gone."""
        if self.popen.stdin is None:
            raise LaunchError(f"{self.name} was not started with a stdin pipe")
        try:
            self.popen.stdin.write(line + "\n")
            self.popen.stdin.flush()
        except (BrokenPipeError, ValueError):
            raise LaunchError(f"{self.name} exited ({self.popen.poll()}); it takes no more input") from None

    def end_input(self) -> None:
        """Close the process's stdin (a served process then ends after its running node)."""
        if self.popen.stdin is not None and not self.popen.stdin.closed:
            with contextlib.suppress(BrokenPipeError):  # it has ended: nothing left to tell it
                self.popen.stdin.close()

    def wait(self, timeout: float) -> int:
        """Exit status once the process ends; LaunchError if it is still running."""
        try:
            status = self.popen.wait(timeout)
        except subprocess.TimeoutExpired:
            raise LaunchError(f"{self.name} still running after {timeout} s") from None
        self.close_output()
        return status

    def close_output(self) -> None:
        """Collect the last lines and close the pipes (the process has ended)."""
        self.end_input()
        if self.reader is not None:
            # A deadline, not an expectation: the reader ends at once on the pipe's end, but on a
            # loaded machine it drained a stopped plant's last lines (its shutdown line) after 2 s.
            self.reader.join(timeout=OUTPUT_DRAIN_S)
        if self.popen.stdout is not None and not self.popen.stdout.closed:
            self.popen.stdout.close()


def ros_env(domain_id: int | None = None, extra: dict[str, str] | None = None) -> dict[str, str]:
    """The inherited environment, confined to loopback, in ``domain_id`` if given."""
    env = dict(os.environ)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    if domain_id is not None:
        env["ROS_DOMAIN_ID"] = str(domain_id)
    env.setdefault("PYTHONUNBUFFERED", "1")
    env.setdefault("RCUTILS_LOGGING_BUFFERED_STREAM", "0")
    env.update(extra or {})
    confine_to_loopback(env)  # sockets on 127.0.0.1 only (msd_bench.dds)
    return env


def _confined(env: dict[str, str]) -> dict[str, str]:
    env = dict(env)
    confine_to_loopback(env)
    return env


_LIBC = ctypes.CDLL(None, use_errno=True)
_PR_SET_PDEATHSIG = 1
_STOP_SIGNALS = {signal.SIGINT, signal.SIGTERM}


def _child_setup(parent: int, hold_stops: bool) -> None:
    """Runs in the child between fork and exec: die with the parent, hold stops until ready.

    Only our launch scripts unblock the stop signals (once their handlers are in place).
    """
    if hold_stops:
        signal.pthread_sigmask(signal.SIG_BLOCK, _STOP_SIGNALS)
    _LIBC.prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)
    if os.getppid() != parent:  # the parent died before prctl took effect
        os._exit(1)


def start(
    script: str | Path,
    ros_args: Sequence[str] = (),
    *,
    name: str | None = None,
    script_args: Sequence[str] = (),
    domain_id: int | None = None,
    env: dict[str, str] | None = None,
    stdin: bool = False,
) -> NodeProcess:
    """Start ``launch_scripts/<script>`` (or a path) with ``--ros-args`` in a new process group.

    ``stdin``: give it a pipe to write lines to (:meth:`NodeProcess.send`; a served process)."""
    path = Path(script)
    if not path.is_absolute() and not path.exists():
        path = SCRIPTS / path
    argv = [sys.executable, str(path), *script_args]
    if ros_args:
        argv += ["--ros-args", *ros_args]
    popen = subprocess.Popen(
        argv, cwd=REPO_ROOT, env=_confined(env) if env else ros_env(domain_id), text=True,
        stdin=subprocess.PIPE if stdin else None, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
        start_new_session=True,
        preexec_fn=functools.partial(_child_setup, os.getpid(), path.resolve().parent == SCRIPTS),
    )
    proc = NodeProcess(name or path.stem, popen)
    proc.reader = threading.Thread(target=_pump, args=(proc,), daemon=True)
    proc.reader.start()
    return proc


def _pump(proc: NodeProcess) -> None:
    assert proc.popen.stdout is not None
    try:
        for line in proc.popen.stdout:
            proc.lines.append(line.rstrip("\n"))
    except ValueError:  # the pipe was closed under us
        pass


def stop(proc: NodeProcess, grace: Sequence[float] = (5.0, 3.0, 3.0)) -> int:
    """SIGINT, then SIGTERM, then SIGKILL the process group; return the exit status."""
    for sig, wait in zip((signal.SIGINT, signal.SIGTERM, signal.SIGKILL), grace, strict=True):
        if proc.popen.poll() is not None:
            break
        if sig == signal.SIGKILL:
            proc.shm_files |= shm_files_of(proc.pid)
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            break
        try:
            proc.popen.wait(wait)
        except subprocess.TimeoutExpired:
            continue
    status = proc.wait(1.0)
    if status == -signal.SIGKILL:
        remove_orphan_shm(proc.shm_files)
    return status


def shm_files_of(pid: int) -> set[str]:
    """Fast DDS segment names under /dev/shm that ``pid`` has open or mapped."""
    names: set[str] = set()
    try:
        for fd in Path(f"/proc/{pid}/fd").iterdir():
            names.add(os.readlink(fd))
        names |= {line.split()[-1] for line in Path(f"/proc/{pid}/maps").read_text().splitlines()}
    except OSError:
        pass
    return {Path(n).name.removesuffix("_el") for n in names if n.startswith(SHM_PREFIXES)}


def _in_use() -> set[str]:
    """Segment names some live process still holds (its fd or mapping)."""
    used: set[str] = set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            used |= shm_files_of(int(entry.name))
    return used


def remove_orphan_shm(segments: set[str]) -> list[str]:
    """Unlink the segments (and their lock/mutex files) no live process uses; return them."""
    removed = []
    used = _in_use()
    for seg in sorted(segments - used):
        for path in (SHM / seg, SHM / f"{seg}_el", SHM / f"sem.{seg}_mutex"):
            try:
                path.unlink()
                removed.append(path.name)
            except FileNotFoundError:
                pass
    return removed


def caller_env() -> dict[str, str]:
    """The inherited environment as is: the caller's domain and discovery range (a --plant-ns run
    must see the rig the caller sees, which may be on another host)."""
    env = dict(os.environ)
    env.setdefault("PYTHONUNBUFFERED", "1")
    env.setdefault("RCUTILS_LOGGING_BUFFERED_STREAM", "0")
    return env


@contextmanager
def process_group(domain_id: int | None = None, env: dict[str, str] | None = None) -> Iterator[ProcessSet]:
    """A :class:`ProcessSet` whose processes are all stopped on exit, whatever happens."""
    procs = ProcessSet(domain_id, env)
    try:
        yield procs
    finally:
        procs.stop_all()


class ProcessSet:
    """The processes one experiment started, stopped newest first."""

    def __init__(self, domain_id: int | None = None, env: dict[str, str] | None = None) -> None:
        """Children run in ``domain_id`` (the inherited ROS_DOMAIN_ID if None) on loopback, or with
        exactly ``env`` if given (:func:`caller_env`)."""
        self.domain_id = domain_id
        self.env = env
        self.procs: list[NodeProcess] = []

    def start(self, script: str | Path, ros_args: Sequence[str] = (), **kw: object) -> NodeProcess:
        """Start a launch script in this set (see :func:`start`)."""
        if self.env is not None and "env" not in kw:
            kw["env"] = self.env
        proc = start(script, ros_args, domain_id=self.domain_id, **kw)  # type: ignore[arg-type]
        self.procs.append(proc)
        return proc

    def stop_all(self) -> dict[str, int]:
        """Stop every process still running; return exit statuses by name."""
        return {p.name: stop(p) for p in reversed(self.procs)}
