"""The three real-time ``bench.py --plant-ns`` runs of the e2e tier, run side by side in the background.

Two are the README's short configuration against a separately started
real-time node: our plant under ``/fakerig`` (msd face) and the rig emulator's
ros2_control face under ``/r2crig``. The third is issue 21's PLM route, the
paper's best, at its short configuration (:data:`PLM_LOOK`) against the rig
emulator's msd face under ``/plmrig``: it records all twelve experiments, the
five bias records included, which only the PLM needs. Each spends almost all
its time waiting for real time (rests, recordings, validation runs at 100 Hz;
the PLM run about 6 min of it), so they share one domain and are told apart by
namespace only, as benches on one network would. The first two validate behind
the supervisor (bench.py's default with ``--plant-ns``), the PLM run opts out
(``--no-supervisor``).

The suite starts them with the session (:class:`BackgroundPair`, from the root
conftest) and runs the tests that read them last, so the rest of the selected tests
run meanwhile instead of waiting 200 s. The tests that read them are marked
``realtime``: an opt-in tier, outside the default ``make test`` (docs/testing.md §Tiers).
They run on a domain of their own, claimed like a bench run's: the suite's own nodes never
see them, nor they the suite's.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from msd_bench.app.plant_ns import QUICK_LOOK
from msd_bench.graph import launch
from msd_bench.graph.domains import claim_domain

REPO = Path(__file__).resolve().parents[2]
PLANT_NS = "/fakerig"
R2C_NS = "/r2crig"
PLM_NS = "/plmrig"
PLM_LOOK = ("--samples", "600", "--val-samples", "400", "--seeds", "1", "--validation-steps", "500",
            "--agents", "plm", "--node-scenarios", "setpoint=0.5")
"""Issue 21's short configuration of the PLM route (the command a rig owner tried)."""
R2C_FACE = ["--interface", "ros2_control", "--controller", "effort_controller", "--joint", "slider_to_cart"]
NO_SUPERVISOR = "--no-supervisor"
"""The PLM run opts out of the supervisor (the other two validate behind it, bench.py's default), so
the suite sees both: docs/supervisor.md §bench.py."""
TARGET = os.environ.get("MSD_PLANT_NS_TARGET", "plant")
"""``plant`` (our plant node, real time, under PLANT_NS) or the path of another plant-like launch
script, e.g. ``launch_scripts/rig.py`` (started with ``-r __ns:=PLANT_NS``)."""


@dataclass(frozen=True)
class Run:
    """Where a bench run wrote its output, and how its process ended."""

    out: Path
    proc: subprocess.CompletedProcess[str]
    domain: int
    """The ROS_DOMAIN_ID the run was given (its caller's)."""


def _target() -> tuple[str, list[str]]:
    if TARGET == "plant":
        return "plant.py", ["-p", "lockstep:=false", "-r", f"__ns:={PLANT_NS}"]
    return str(REPO / TARGET), ["-r", f"__ns:={PLANT_NS}"]


def _bench(ns: str, out: Path, face: list[str], domain: int,
           look: tuple[str, ...] = QUICK_LOOK) -> subprocess.Popen[str]:
    argv = [sys.executable, "launch_scripts/bench.py", "--plant-ns", ns, *face, "--out", str(out), *look]
    # the caller's environment and ROS_DOMAIN_ID (the bench claims none with --plant-ns)
    return subprocess.Popen(argv, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=launch.ros_env(domain))


def _finish(popen: subprocess.Popen[str], timeout: float) -> subprocess.CompletedProcess[str]:
    try:
        stdout, stderr = popen.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        popen.kill()
        stdout, stderr = popen.communicate()
    return subprocess.CompletedProcess(popen.args, popen.returncode, stdout, stderr)


def _claim_other_domain() -> tuple[int, IO[str]]:
    """A domain claimed as a bench run claims one, other than the suite's own (which holds no lock:
    its e2e tests hand it to bench.py with ``--domain-id``)."""
    domain, lock = claim_domain(None)
    if domain != int(os.environ["ROS_DOMAIN_ID"]):
        return domain, lock
    try:
        return claim_domain(None)  # while the first lock is held, not the suite's domain again
    finally:
        lock.close()


class BackgroundPair:
    """The runs in a thread of their own: :meth:`start`, then :meth:`result` (waits), :meth:`close`.

    (Named for the first two; the PLM run joined them.)
    """

    def __init__(self, root: Path, timeout: float = 1500.0) -> None:
        self.outs = {"plant": root / "plant_ns" / "run", "r2c": root / "r2c" / "run",
                     "plm": root / "plm" / "run"}
        self.timeout = timeout
        self.domain, self._lock = _claim_other_domain()
        self._benches: list[subprocess.Popen[str]] = []
        self._runs: dict[str, Run] = {}
        self._error: BaseException | None = None
        self._closed = threading.Event()
        self._thread = threading.Thread(target=self._run, name="realtime-runs", daemon=True)

    def start(self) -> BackgroundPair:
        self._thread.start()
        return self

    def result(self) -> dict[str, Run]:
        """Every run, keyed ``plant``, ``r2c`` and ``plm`` (waits for them to end)."""
        self._thread.join(self.timeout + 120.0)
        if self._error is not None:
            raise RuntimeError(f"the real-time runs could not run: {self._error!r}") from self._error
        if self._thread.is_alive() or len(self._runs) != len(self.outs):
            raise RuntimeError("the real-time runs did not end")
        return self._runs

    def close(self) -> None:
        """Stop whatever still runs (a session that ended early) and release the domain."""
        self._closed.set()
        self._stop_benches()
        self._thread.join(60.0)
        self._lock.close()

    def _stop_benches(self) -> None:
        """SIGINT, as a user stops a bench (it stops its own processes and their shared memory),
        then SIGKILL for one that is still running after 30 s."""
        for popen in self._benches:
            if popen.poll() is None:
                popen.send_signal(signal.SIGINT)
        for popen in self._benches:
            try:
                popen.wait(30.0)
            except subprocess.TimeoutExpired:
                popen.kill()

    def _run(self) -> None:
        """Start the nodes, then the bench runs; wait for all; stop the nodes."""
        try:
            with launch.process_group(self.domain) as procs:
                script, args = _target()
                r2c_rig = ["-p", "interface:=ros2_control", "-r", f"__ns:={R2C_NS}"]
                nodes = [procs.start(script, args, name="target"), procs.start("rig.py", r2c_rig, name="rig"),
                         procs.start("rig.py", ["-r", f"__ns:={PLM_NS}"], name="plm-rig")]
                for node in nodes:
                    node.wait_for_line(r"ready", timeout=60.0)
                if self._closed.is_set():
                    return
                faces = {"plant": (PLANT_NS, [], QUICK_LOOK), "r2c": (R2C_NS, R2C_FACE, QUICK_LOOK),
                         "plm": (PLM_NS, [NO_SUPERVISOR], PLM_LOOK)}
                running = {name: _bench(ns, self.outs[name], face, self.domain, look)
                           for name, (ns, face, look) in faces.items()}
                self._benches.extend(running.values())
                if self._closed.is_set():  # close() ran meanwhile and may have missed them
                    self._stop_benches()
                self._runs = {name: Run(self.outs[name], _finish(p, self.timeout), self.domain)
                              for name, p in running.items()}
        except BaseException as exc:  # reported by result(), in the test that reads the runs
            self._error = exc
