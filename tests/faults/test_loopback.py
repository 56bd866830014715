"""Fault row "isolation": every UDP socket of a node process is bound to loopback; SHM stays on."""

from __future__ import annotations

import ipaddress
import os
import socket
import struct
from pathlib import Path

import pytest

from msd_bench.graph import launch

pytestmark = pytest.mark.e2e


def _udp_sockets(pid: int) -> list[tuple[str, int]]:
    """(local address, port) of the IPv4/IPv6 UDP sockets ``pid`` holds, from /proc (no ss, no psutil)."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    found = []
    for table, family in (("udp", socket.AF_INET), ("udp6", socket.AF_INET6)):
        path = Path(f"/proc/{pid}/net/{table}")
        if not path.exists():
            continue
        for line in path.read_text().splitlines()[1:]:
            cols = line.split()
            if cols[9] not in inodes:
                continue
            hex_addr, hex_port = cols[1].split(":")
            raw = bytes.fromhex(hex_addr)
            if family == socket.AF_INET:
                raw = struct.pack("<I", int(hex_addr, 16))
            else:
                raw = b"".join(struct.pack("<I", w) for w in struct.unpack(">4I", raw))
            found.append((socket.inet_ntop(family, raw), int(hex_port, 16)))
    return found


def _confined(address: str) -> bool:
    ip = ipaddress.ip_address(address)
    return ip.is_loopback or (ip.is_multicast and address.startswith("239.255."))


def test_node_sockets_bind_only_to_loopback_and_shm_is_used() -> None:
    with launch.process_group() as procs:
        plant = procs.start("plant.py", ["-p", "duplicate_check:=0.0"])
        plant.wait_for_line(r"ready \(", 30.0)
        sockets = _udp_sockets(plant.pid)
        shm = launch.shm_files_of(plant.pid)
    assert sockets, "the plant holds no UDP socket: nothing was checked"
    assert [s for s in sockets if not _confined(s[0])] == [], sockets
    assert shm, "the shared-memory transport is off: lock-step traffic would go over UDP"


def test_proc_parser_sees_a_wildcard_socket() -> None:
    """The check can fail: a socket on 0.0.0.0 in this process is reported as such."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("0.0.0.0", 0))
        port = s.getsockname()[1]
        assert ("0.0.0.0", port) in _udp_sockets(os.getpid())
        assert not _confined("0.0.0.0")
