"""Fault row "isolation": every UDP socket of every msd-bench process is bound to loopback; SHM stays on.

Three ways a process starts: through the launch code, as a launch script a user
runs directly, and as a console command (``msd-bench echo``). Each is started
here with ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and no Fast DDS profile
of its own, and its sockets are read from ``/proc/<pid>/net/udp``.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from msd_bench import dds
from msd_bench.graph import launch

pytestmark = pytest.mark.e2e

PROFILE_VARS = ("FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE")


def _user_env() -> dict[str, str]:
    """What a user's shell has: LOCALHOST, the test's domain, no Fast DDS profile."""
    env = {k: v for k, v in os.environ.items() if k not in PROFILE_VARS}
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["PYTHONUNBUFFERED"] = "1"
    return env


def _unconfined(sockets: list[tuple[str, int]]) -> list[tuple[str, int]]:
    return [s for s in sockets if not dds.is_confined(s[0])]


def _sockets(pid: int) -> list[tuple[str, int]]:
    return sorted(dds.own_udp_sockets(pid).values())


def _settled_sockets(pid: int, timeout: float = 30.0) -> list[tuple[str, int]]:
    """The process's UDP sockets once it has some and two reads 0.3 s apart agree."""
    deadline = time.monotonic() + timeout
    last: list[tuple[str, int]] = []
    while time.monotonic() < deadline:
        now = _sockets(pid)
        if now and now == last:
            return now
        last = now
        time.sleep(0.3)
    raise AssertionError(f"pid {pid} opened no stable set of UDP sockets within {timeout} s: {last}")


def _adopt(name: str, popen: subprocess.Popen[str]) -> launch.NodeProcess:
    """A process started by hand, wrapped so launch.stop stops it (and cleans its /dev/shm)."""
    proc = launch.NodeProcess(name, popen)
    proc.reader = threading.Thread(target=launch._pump, args=(proc,), daemon=True)
    proc.reader.start()
    return proc


def _start_by_hand(argv: list[str]) -> launch.NodeProcess:
    popen = subprocess.Popen([sys.executable, *argv], cwd=launch.REPO_ROOT, env=_user_env(), text=True,
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)
    return _adopt(Path(argv[0]).stem, popen)


def test_node_sockets_bind_only_to_loopback_and_shm_is_used() -> None:
    with launch.process_group() as procs:
        plant = procs.start("plant.py", ["-p", "duplicate_check:=0.0"])
        plant.wait_for_line(r"ready \(", 120.0)
        sockets = _sockets(plant.pid)
        shm = launch.shm_files_of(plant.pid)
    assert sockets, "the plant holds no UDP socket: nothing was checked"
    assert _unconfined(sockets) == [], sockets
    assert shm, "the shared-memory transport is off: lock-step traffic would go over UDP"


def test_a_launch_script_run_directly_binds_only_to_loopback() -> None:
    """``python launch_scripts/plant.py`` as the README shows it, not through the launch code."""
    plant = _start_by_hand(["launch_scripts/plant.py", "--ros-args", "-p", "duplicate_check:=0.0",
                            "-r", f"__ns:=/loopdirect{os.getpid()}"])
    try:
        plant.wait_for_line(r"ready \(", 60.0)
        sockets = _sockets(plant.pid)
        shm = launch.shm_files_of(plant.pid)
    finally:
        status = launch.stop(plant)
    assert status == 0, plant.output()
    assert sockets, "the plant holds no UDP socket: nothing was checked"
    assert _unconfined(sockets) == [], sockets
    assert shm, "the shared-memory transport is off"


@pytest.mark.parametrize("command", [["msd_bench", "echo"], ["msd_bench.commands.topics", "hz"]],
                         ids=["msd-bench-echo", "topics-hz"])
def test_a_console_command_binds_only_to_loopback(command: list[str]) -> None:
    """``msd-bench echo`` (and the standalone topics module) waiting for a publisher that never comes."""
    echo = _start_by_hand(["-m", *command, f"/nobody{os.getpid()}/topic", "--timeout", "60"])
    try:
        sockets = _settled_sockets(echo.pid)
    finally:
        os.killpg(echo.pid, signal.SIGINT)
        launch.stop(echo)
    assert _unconfined(sockets) == [], sockets


def test_processes_run_by_hand_still_see_each_other() -> None:
    """The README's use: ``plant.py`` in one shell, ``echo`` in another, both confined by themselves."""
    ns = f"/loophand{os.getpid()}"
    plant = _start_by_hand(["launch_scripts/plant.py", "--ros-args", "-p", "duplicate_check:=0.0",
                            "-r", f"__ns:={ns}"])
    try:
        plant.wait_for_line(r"ready \(", 60.0)
        echo = subprocess.run([sys.executable, "-m", "msd_bench.commands.topics", "echo", f"{ns}/position",
                               "--count", "1", "--timeout", "30"], cwd=launch.REPO_ROOT, env=_user_env(),
                              capture_output=True, text=True, timeout=60)
    finally:
        launch.stop(plant)
    assert echo.returncode == 0, echo.stderr
    assert echo.stdout.startswith("data: ") and echo.stdout.rstrip().endswith("---"), echo.stdout


def test_a_users_own_profile_and_another_rmw_are_left_alone() -> None:
    own = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "FASTRTPS_DEFAULT_PROFILES_FILE": "/lab/dds.xml"}
    env = dict(own)
    dds.confine_to_loopback(env)
    assert env == own
    other = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "RMW_IMPLEMENTATION": "rmw_cyclonedds_cpp"}
    env = dict(other)
    dds.confine_to_loopback(env)
    assert env == other


def test_confining_is_idempotent_and_recognises_its_own_profile() -> None:
    """A child of a confined process (range reset to LOCALHOST by the launch code) is confined again."""
    env = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    dds.confine_to_loopback(env)
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SUBNET"
    assert str(dds.LOOPBACK_PROFILE) in env.values()
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    dds.confine_to_loopback(env)
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SUBNET"
    untouched = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}
    dds.confine_to_loopback(untouched)
    assert untouched == {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}


LATE = """
import os, sys
import rclpy
from rclpy.context import Context
from msd_bench import dds

def start():
    ctx = Context()
    rclpy.init(args=[], context=ctx)
    return ctx, rclpy.create_node("late", context=ctx, start_parameter_services=False)

def stop(session):
    session[1].destroy_node()
    session[0].shutdown()

if sys.argv[1] == "late":
    stop(start())  # a participant without the profile: Fast DDS never reads it afterwards
session = dds.start_confined(start, stop)
print(os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"], sorted(dds.own_udp_sockets().values()), flush=True)
stop(session)
stop(dds.start_confined(start, stop))  # a second backend in the same process: the same outcome
print(os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"], flush=True)
"""


@pytest.mark.parametrize("order", ["first", "late"])
def test_a_library_call_confines_when_first_and_never_widens_when_late(order: str) -> None:
    """The gym backend's path: first ROS user in the process -> loopback; after another -> unchanged."""
    proc = subprocess.run([sys.executable, "-c", LATE, order], cwd=launch.REPO_ROOT, env=_user_env(),
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    modes = [lines[0].split()[0], lines[1]]
    if order == "first":
        assert modes == ["SUBNET", "SUBNET"] and "('0.0.0.0'" not in lines[0], proc.stdout
        assert "not confined" not in proc.stderr
    else:
        assert modes == ["LOCALHOST", "LOCALHOST"], proc.stdout  # SUBNET without the profile would widen
        assert proc.stderr.count("DDS not confined to loopback") == 1, proc.stderr


def test_proc_parser_sees_a_wildcard_socket() -> None:
    """The check can fail: a socket on 0.0.0.0 in this process is reported as such."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("0.0.0.0", 0))
        port = s.getsockname()[1]
        assert ("0.0.0.0", port) in _sockets(os.getpid())
        assert not dds.is_confined("0.0.0.0")
