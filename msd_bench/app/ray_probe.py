"""Probe ``--ray-address`` before a run writes anything: a bounded wait, then one line.

Why: ``ray.init(address=...)`` on an address where no Ray cluster answers retries
"Failed to get cluster ID from GCS server" for a long time (40 s and more in Ray 2.60,
then again on each attempt), and by then ``--out`` already held a manifest. The probe
asks the address's GCS for its node table in a child process that is killed after
:data:`PROBE_TIMEOUT_S` seconds (a hung C++ client inside the driver could not be
stopped), before the run directory is opened. It asks the address exactly as given
(Ray's own ``ray.init`` rewrites a loopback host to the machine's external interface;
see :func:`msd_bench.app.executor.start_ray` for how that is prevented).
"""

from __future__ import annotations

import socket
import subprocess
import sys

from msd_bench.core.errors import ConfigError

PROBE_TIMEOUT_S = 15.0
"""The longest a probe of ``--ray-address`` may take (stated in docs/cluster.md)."""

_CHILD = """
import sys
from ray._raylet import GcsClient
from ray.exceptions import AuthenticationError
try:
    nodes = GcsClient(address=sys.argv[1]).get_all_node_info(timeout=5)
except AuthenticationError:  # a Ray GCS answered, wanting a token this process was not told to send
    print("auth")
else:
    print(sum(1 for n in nodes.values() if n.state == 0))  # GcsNodeInfo.ALIVE
"""


def split_host_port(address: str) -> tuple[str, int] | None:
    """``host:port`` (or ``[v6]:port``) as a pair, or None when ``address`` is not of that form."""
    host, sep, port = address.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        return None
    return host.strip("[]"), int(port)


def probe_ray_address(address: str, timeout: float = PROBE_TIMEOUT_S) -> None:
    """Return when a Ray cluster answers at ``address``; otherwise raise a one-line ConfigError.

    ``auto`` is left to Ray (it reads the address of the last ``ray start`` on this machine); a
    ``ray://`` (Ray Client) address is checked for a listening port only.
    """
    if address == "auto":
        return
    client = address.startswith("ray://")
    pair = split_host_port(address.removeprefix("ray://"))
    if pair is None:
        raise ConfigError(f"--ray-address {address!r}: expected host:port, ray://host:port or auto")
    _tcp_probe(address, pair, timeout)
    if not client:
        _gcs_probe(address, timeout)


def _tcp_probe(address: str, pair: tuple[str, int], timeout: float) -> None:
    try:
        with socket.create_connection(pair, timeout=timeout):
            pass
    except OSError as exc:
        raise ConfigError(f"--ray-address {address}: nothing answers there "
                          f"({exc.strerror or type(exc).__name__}); is the Ray head running?") from None


def alive_nodes(address: str, timeout: float = PROBE_TIMEOUT_S) -> int:
    """How many live nodes the Ray cluster at ``address`` has (a one-line ConfigError if none answers)."""
    return _gcs_probe(address, timeout)


def _gcs_probe(address: str, timeout: float) -> int:
    try:
        done = subprocess.run([sys.executable, "-c", _CHILD, address], capture_output=True, text=True,
                              timeout=timeout, stdin=subprocess.DEVNULL, check=False)
    except subprocess.TimeoutExpired:
        raise ConfigError(f"--ray-address {address}: no Ray cluster answered within {timeout:g} s "
                          "(a port that is not a Ray head's GCS port?)") from None
    answer = done.stdout.strip()
    if answer == "auth":
        raise ConfigError(f"--ray-address {address}: the Ray cluster there wants token authentication; "
                          "set RAY_AUTH_MODE=token (with its token in ~/.ray/auth_token or RAY_AUTH_TOKEN) "
                          "and run again")
    if done.returncode != 0 or not answer.isdigit():
        raise ConfigError(f"--ray-address {address}: not a Ray cluster's GCS address "
                          f"(the probe failed: {_last_line(done.stderr)})")
    if int(answer) == 0:
        raise ConfigError(f"--ray-address {address}: the Ray cluster there has no live node")
    return int(answer)


def _last_line(text: str) -> str:
    lines = [ln.strip() for ln in text.strip().splitlines() if ln.strip()]
    return lines[-1][:200] if lines else "no answer"
