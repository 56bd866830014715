"""One plant-like node per namespace, decided without a race (fault row "duplicate plants").

Why not "look for another publisher before starting": two plants started at
the same moment both look, both see nobody, both run, and their samples
interleave in every recording. Instead each plant-like node announces a
*claim* on ``<ns>/plant_claim`` (latched, re-sent every second) and the
earliest claim wins: ordered by start time, ties broken by pid and a random
token. A node that finds an earlier live claim — while starting up or at any
time later — shuts down with one line. A claim is live while it keeps being
re-sent (``sent_ns`` newer than :data:`STALE_S`), and a claim from this very
process whose node was destroyed (tests build and destroy nodes in one
process; the graph and DDS caches lag) is never live: :data:`_LIVE_TOKENS`.

All of the decision is :func:`earlier_rival`; nodes only feed it claims.
"""

from __future__ import annotations

import json
import os
import secrets
import time
from dataclasses import asdict, dataclass

STALE_S = 3.0
"""A claim not re-sent for this long belongs to a node that is gone (re-sent every second)."""
HEARTBEAT_S = 1.0
"""How often a claim is re-sent and rivals re-checked after start-up."""

_LIVE_TOKENS: set[str] = set()
"""Tokens of the claims of nodes alive in this process."""


@dataclass(frozen=True, order=True)
class Claim:
    """A plant-like node's claim on a namespace; the smaller claim has priority."""

    start_ns: int
    """Wall-clock time (ns) the node started."""
    pid: int
    """Process id: first tie-break."""
    token: str
    """Random per node: last tie-break, and identity."""
    node: str = ""
    """Fully qualified node name, for the message."""

    def describe(self, other: Claim) -> str:
        """``/msd/plant, pid 12, started 0.8 s earlier`` (relative to ``other``)."""
        return f"{self.node}, pid {self.pid}, started {(other.start_ns - self.start_ns) / 1e9:.2f} s earlier"


def new_claim(node: str) -> Claim:
    """A claim for a node starting now; registered live in this process."""
    claim = Claim(time.time_ns(), os.getpid(), secrets.token_hex(8), node)
    _LIVE_TOKENS.add(claim.token)
    return claim


def release(claim: Claim) -> None:
    """The node is destroyed: its claim is dead, whatever the caches still say."""
    _LIVE_TOKENS.discard(claim.token)


def encode(claim: Claim) -> str:
    """The JSON sent on the claim topic (``sent_ns`` added: liveness)."""
    return json.dumps({**asdict(claim), "sent_ns": time.time_ns()})


def decode(text: str) -> tuple[Claim, int] | None:
    """(claim, sent_ns) of a received message, or None if it is not a claim."""
    try:
        doc = json.loads(text)
        return Claim(int(doc["start_ns"]), int(doc["pid"]), str(doc["token"]), str(doc["node"])), int(
            doc["sent_ns"])
    except (ValueError, KeyError, TypeError):
        return None


def earlier_rival(own: Claim, heard: dict[str, tuple[Claim, int]], now_ns: int) -> Claim | None:
    """The earliest live claim ahead of ``own``, or None when ``own`` keeps the namespace.

    ``heard`` maps token -> (latest claim, its sent_ns). Dead claims are skipped:
    not re-sent within :data:`STALE_S`, or from this process and released.
    """
    live = [
        claim for claim, sent in heard.values()
        if claim.token != own.token
        and now_ns - sent <= STALE_S * 1e9
        and not (claim.pid == own.pid and claim.token not in _LIVE_TOKENS)
    ]
    ahead = [c for c in live if c < own]
    return min(ahead) if ahead else None
