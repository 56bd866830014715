"""Confine the DDS of every node process the launch code starts to 127.0.0.1.

Why a profile: with ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` every *send*
goes to 127.0.0.1, but rmw_fastrtps still opens receive sockets on 0.0.0.0
and on the external interface (measured with ``ss -lunp``: five UDP sockets,
one on 0.0.0.0:7003 and one on the eth0 address). A Fast DDS XML profile
(:data:`LOOPBACK_PROFILE`) that allows only the 127.0.0.1 interface, plus the
shared-memory transport so same-host data keeps its speed, binds every socket
to loopback. rmw_fastrtps' own LOCALHOST mode adds a wildcard and an
external-interface socket on top of any profile, so under the profile the
children run with the SUBNET range, which the profile's interface allowlist
then confines to the loopback interface (discovery multicast included).
A user's own profile or another RMW is left alone.
"""

from __future__ import annotations

from importlib import metadata
from pathlib import Path

LOOPBACK_PROFILE = Path(__file__).with_name("fastdds_loopback.xml")
"""UDPv4 on 127.0.0.1 only + shared memory; the default participant profile."""
_PROFILE_VARS = ("FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE")


def _profile_var() -> str:
    """Fast DDS 3 (Kilted) reads FASTDDS_..., 2.x (Jazzy) FASTRTPS_...; rmw warns on the other."""
    try:
        major = int(metadata.version("ros-fastdds").split(".")[0])
    except (metadata.PackageNotFoundError, ValueError):
        major = 3
    return _PROFILE_VARS[0] if major >= 3 else _PROFILE_VARS[1]


def confine_to_loopback(env: dict[str, str]) -> None:
    """Apply the loopback profile to a child environment whose discovery range is LOCALHOST."""
    if env.get("ROS_AUTOMATIC_DISCOVERY_RANGE") != "LOCALHOST":
        return
    if any(v in env for v in _PROFILE_VARS):
        return  # the user's own Fast DDS profile wins
    if env.get("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp") != "rmw_fastrtps_cpp":
        return
    env[_profile_var()] = str(LOOPBACK_PROFILE)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SUBNET"  # confined by the profile; see the module docstring
