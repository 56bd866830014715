"""Confine the DDS of every msd-bench process to 127.0.0.1 when the discovery range asks for it.

Why a profile: with ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` every *send*
goes to 127.0.0.1, but rmw_fastrtps still opens receive sockets on 0.0.0.0
and on the external interface (measured with ``ss -lunp``: five UDP sockets,
one on 0.0.0.0:7003 and one on the eth0 address). A Fast DDS XML profile
(:data:`LOOPBACK_PROFILE`) that allows only the 127.0.0.1 interface, plus the
shared-memory transport so same-host data keeps its speed, binds every socket
to loopback. rmw_fastrtps' own LOCALHOST mode adds a wildcard and an
external-interface socket on top of any profile, so under the profile the
process runs with the SUBNET range, which the profile's interface allowlist
then confines to the loopback interface (discovery multicast included).
A user's own profile (either variable set to another file) or another RMW is
left alone: the user's profile decides the sockets, and the range stays LOCALHOST.

Where: :func:`confine_to_loopback` edits a child's environment (the launch
code); :func:`confine_process` edits this process's own, and is called by
every entry point before rclpy initialises (``launch_scripts/_reexec.py``
for the launch scripts, :func:`msd_bench.cli.main` for the console
commands, :func:`start_confined` for the gym's ROS backend). Setting
``os.environ`` in-process is enough — no re-exec — because Fast DDS reads the
profile variable when the process creates its *first* participant (measured:
set after ``import rclpy`` and before the first ``rclpy.init``, every socket is
on 127.0.0.1). Set after a participant existed, it is never read, and the
SUBNET range alone would widen discovery: :func:`start_confined` checks the
new participant's sockets and undoes the change when that happened.
"""

from __future__ import annotations

import ipaddress
import logging
import os
import socket
import struct
from collections.abc import Callable, MutableMapping
from importlib import metadata
from pathlib import Path
from typing import TypeVar

LOOPBACK_PROFILE = Path(__file__).with_name("fastdds_loopback.xml")
"""UDPv4 on 127.0.0.1 only + shared memory; the default participant profile."""
_PROFILE_VARS = ("FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE")
RANGE_VAR = "ROS_AUTOMATIC_DISCOVERY_RANGE"
_CHANGED = (*_PROFILE_VARS, RANGE_VAR)
T = TypeVar("T")
_log = logging.getLogger(__name__)
_PROFILE_MISSED: list[bool] = []
"""Non-empty once :func:`start_confined` found the profile unread in this process (it never will be)."""


def _profile_var() -> str:
    """Fast DDS 3 (Kilted) reads FASTDDS_..., 2.x (Jazzy) FASTRTPS_...; rmw warns on the other."""
    try:
        major = int(metadata.version("ros-fastdds").split(".")[0])
    except (metadata.PackageNotFoundError, ValueError):
        major = 3
    return _PROFILE_VARS[0] if major >= 3 else _PROFILE_VARS[1]


def _ours(env: MutableMapping[str, str]) -> bool:
    """Whether the profile variable set is our own (an environment confined before, e.g. a parent's)."""
    return any(env.get(v) == str(LOOPBACK_PROFILE) for v in _PROFILE_VARS)


def confine_to_loopback(env: MutableMapping[str, str]) -> None:
    """Apply the loopback profile to an environment whose discovery range is LOCALHOST.

    Idempotent: an environment that already carries our profile ends with the
    SUBNET range whatever its range says now (a test harness may have reset it).
    """
    if env.get(RANGE_VAR) != "LOCALHOST":
        return
    if env.get("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp") != "rmw_fastrtps_cpp":
        return
    if not _ours(env):
        if any(v in env for v in _PROFILE_VARS):
            return  # the user's own Fast DDS profile wins
        env[_profile_var()] = str(LOOPBACK_PROFILE)
    env[RANGE_VAR] = "SUBNET"  # confined by the profile; see the module docstring


def confine_process() -> dict[str, str | None]:
    """Confine this process (``os.environ``) before rclpy initialises; return what to undo.

    The returned mapping holds the previous value (None: unset) of every
    variable changed; it is empty when nothing changed.
    """
    before = {name: os.environ.get(name) for name in _CHANGED}
    confine_to_loopback(os.environ)
    return {name: old for name, old in before.items() if os.environ.get(name) != old}


def undo(changes: dict[str, str | None]) -> None:
    """Put back the variables :func:`confine_process` changed."""
    for name, old in changes.items():
        if old is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = old


def start_confined(start: Callable[[], T], stop: Callable[[T], None]) -> T:
    """``start()`` (an rclpy context's init) confined to loopback, or as before if that cannot hold.

    Why the check: a library call (the gym backend) may come after the process
    created a participant without the profile; then Fast DDS ignores the
    profile and the SUBNET range alone would open discovery beyond this host.
    The new participant's sockets tell: if any is off loopback, ``stop`` it,
    undo the change, start again with the caller's environment, and log why.
    """
    if _PROFILE_MISSED:
        return start()  # this process's Fast DDS has read its profiles already: do not try again
    before = set(own_udp_sockets())
    changes = confine_process()
    started = start()
    if not changes:
        return started
    opened = {inode: addr for inode, addr in own_udp_sockets().items() if inode not in before}
    if all(is_confined(addr) for addr, _port in opened.values()):
        return started
    stop(started)
    undo(changes)
    _PROFILE_MISSED.append(True)
    _log.warning("DDS not confined to loopback: this process started ROS before msd-bench could set its "
                 "Fast DDS profile; call msd_bench.dds.confine_process() before any rclpy.init")
    return start()


def is_confined(address: str) -> bool:
    """An address the loopback profile allows: 127.0.0.0/8, ::1, or the discovery group on loopback."""
    ip = ipaddress.ip_address(address)
    return ip.is_loopback or (ip.is_multicast and address.startswith("239.255."))


def own_udp_sockets(pid: int | None = None) -> dict[str, tuple[str, int]]:
    """(local address, port) by socket inode of the UDP sockets ``pid`` (default: this process) holds.

    Read from /proc (no ss, no psutil); empty where /proc is not there.
    """
    pid = os.getpid() if pid is None else pid
    inodes = _socket_inodes(pid)
    found: dict[str, tuple[str, int]] = {}
    for table, family in (("udp", socket.AF_INET), ("udp6", socket.AF_INET6)):
        try:
            lines = Path(f"/proc/{pid}/net/{table}").read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            cols = line.split()
            if cols[9] in inodes:
                found[cols[9]] = _address(cols[1], family)
    return found


def _socket_inodes(pid: int) -> set[str]:
    inodes: set[str] = set()
    try:
        fds = list(Path(f"/proc/{pid}/fd").iterdir())
    except OSError:
        return inodes
    for fd in fds:
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    return inodes


def _address(hex_pair: str, family: int) -> tuple[str, int]:
    """/proc/net/udp's ``HEXADDR:HEXPORT`` (addresses in host byte order, 32-bit words) decoded."""
    hex_addr, hex_port = hex_pair.split(":")
    if family == socket.AF_INET:
        raw = struct.pack("<I", int(hex_addr, 16))
    else:
        raw = b"".join(struct.pack("<I", w) for w in struct.unpack(">4I", bytes.fromhex(hex_addr)))
    return socket.inet_ntop(family, raw), int(hex_port, 16)
