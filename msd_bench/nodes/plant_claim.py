"""One plant-like node per namespace, decided without a race (fault row "duplicate plants").

Why not "look for another publisher before starting": two plants started at
the same moment both look, both see nobody, both run, and their samples
interleave in every recording. Instead each plant-like node announces a
*claim* on ``<ns>/plant_claim`` (latched, re-sent every second). A claim is
live while it keeps being re-sent (heard again within :data:`STALE_S`, by the
hearer's clock: the sender's ``sent_ns`` is not trusted), and a claim from
this very process whose node was destroyed (tests build and destroy nodes in
one process; the graph and DDS caches lag) is never live: :data:`_LIVE_TOKENS`.

Who yields (docs/faults.md §Trust boundary): nothing on the topic can be
verified — any participant on the domain can publish any start time. So a
node arbitrates only the claims it first hears during its own start-up window
(:data:`ARBITRATION_S`, or its ``duplicate_check`` if longer, counted from when
the node first listens: :meth:`ClaimBook.begin_listening`): that is a
simultaneous start, and the earliest claim wins (start time, then pid, then
the random token). A claim first heard later, whatever start time it states,
never stops a node that is serving: it is reported once (:meth:`ClaimBook.ignored`).
Once past its window a node says so in its claim (``established``); a
newcomer that first hears an established claim yields to it whatever the
start times (so two hosts with skewed clocks still leave one plant).

All of the decision is :func:`earlier_rival`; nodes only feed it claims
through a :class:`ClaimBook`.
"""

from __future__ import annotations

import json
import os
import secrets
import time
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import NamedTuple

from msd_bench.core.errors import MsdBenchError
from msd_bench.io.storage.safe_read import loads_bounded

STALE_S = 3.0
"""A claim not re-sent for this long belongs to a node that is gone (re-sent every second)."""
HEARTBEAT_S = 1.0
"""How often a claim is re-sent and rivals re-checked after start-up."""
ARBITRATION_S = 3.0
"""Shortest start-up window: a claim first heard within this long of a node's own start (or within its
``duplicate_check``, if longer) is a simultaneous start and arbitrated; one heard later is a newcomer.
Discovery on one host takes well under a second, so a real rival is heard inside it."""
MAX_CLAIM_BYTES = 4096
"""Largest claim message read (a real one is about 150 bytes): anything bigger is not a claim."""
MAX_HEARD = 256
"""Most live claims one node keeps (a flood of fake claims must not grow it without bound)."""

_LIVE_TOKENS: set[str] = set()
"""Tokens of the claims of nodes alive in this process."""


@dataclass(frozen=True, order=True)
class Claim:
    """A plant-like node's claim on a namespace; the smaller claim has priority."""

    start_ns: int
    """Wall-clock time (ns) the node started, as the node states it (unverifiable)."""
    pid: int
    """Process id: first tie-break."""
    token: str
    """Random per node: last tie-break, and identity."""
    node: str = ""
    """Fully qualified node name, for the message."""

    def describe(self, other: Claim) -> str:
        """``/msd/plant, pid 12, started 0.8 s earlier`` (relative to ``other``)."""
        return f"{self.node}, pid {self.pid}, started {(other.start_ns - self.start_ns) / 1e9:.2f} s earlier"


class Heard(NamedTuple):
    """A rival's claim as one node heard it."""

    claim: Claim
    last_ns: int
    """This node's wall clock when it last heard the claim (liveness)."""
    first_ns: int
    """This node's wall clock when it first heard the claim."""
    established: bool
    """Whether the rival said it was past its start-up window when first heard (it was serving)."""


def new_claim(node: str) -> Claim:
    """A claim for a node starting now; registered live in this process."""
    claim = Claim(time.time_ns(), os.getpid(), secrets.token_hex(8), node)
    _LIVE_TOKENS.add(claim.token)
    return claim


def release(claim: Claim) -> None:
    """The node is destroyed: its claim is dead, whatever the caches still say."""
    _LIVE_TOKENS.discard(claim.token)


def encode(claim: Claim, established: bool = False) -> str:
    """The JSON sent on the claim topic (``sent_ns``: the sender's clock, informative; ``established``:
    past its start-up window)."""
    return json.dumps({**asdict(claim), "sent_ns": time.time_ns(), "established": established})


def decode(text: str) -> tuple[Claim, int, bool] | None:
    """(claim, sent_ns, established) of a received message, or None if it is not a claim.

    Bounded: the text comes from any participant on the domain.
    """
    try:
        doc = loads_bounded(text, "plant claim", max_bytes=MAX_CLAIM_BYTES, max_depth=1)
        claim = Claim(int(doc["start_ns"]), int(doc["pid"]), str(doc["token"]), str(doc["node"]))
        return claim, int(doc["sent_ns"]), doc.get("established") is True
    except (MsdBenchError, ValueError, KeyError, TypeError, AttributeError, OverflowError):
        return None


def _live(own: Claim, heard: Heard, now_ns: int) -> bool:
    claim = heard.claim
    return (claim.token != own.token
            and now_ns - heard.last_ns <= STALE_S * 1e9
            and not (claim.pid == own.pid and claim.token not in _LIVE_TOKENS))


def earlier_rival(own: Claim, heard: Mapping[Claim, Heard], now_ns: int, window_ns: int,
                  listen_from_ns: int | None = None) -> Claim | None:
    """The live claim ``own`` must yield to, or None when ``own`` keeps the namespace.

    Only claims first heard within ``window_ns`` of ``listen_from_ns`` (``own``'s start unless
    given: when ``own``'s node began to listen) count; of
    those, one that was established when first heard wins outright (``own`` is
    the newcomer), else the earliest claim ahead of ``own``.
    """
    start = own.start_ns if listen_from_ns is None else listen_from_ns
    contenders = [h for h in heard.values()
                  if _live(own, h, now_ns) and h.first_ns - start <= window_ns]
    serving = [h.claim for h in contenders if h.established]
    if serving:
        return min(serving)
    ahead = [h.claim for h in contenders if h.claim < own]
    return min(ahead) if ahead else None


class ClaimBook:
    """The claims one node has heard, by its own clock, and the verdict on them."""

    def __init__(self, own: Claim, listen_s: float) -> None:
        """``listen_s``: the node's ``duplicate_check``; the window is at least :data:`ARBITRATION_S`."""
        self.own = own
        self.window_ns = int(max(listen_s, ARBITRATION_S) * 1e9)
        self.listen_from_ns = own.start_ns
        """Where the start-up window starts: the claim's start until :meth:`begin_listening` moves it."""
        self._listening = False
        self.heard: dict[Claim, Heard] = {}
        self._reported: set[Claim] = set()

    def begin_listening(self, now_ns: int | None = None) -> None:
        """The node can hear the topic from now on (it spins): its start-up window starts here, once.

        Why not at the claim's start: a node that skips the start-up wait builds and compiles its
        model before it first spins, which took longer than the whole window on a loaded machine, so
        a rival's latched claim reached it only after the window and was ignored (two plants ran)."""
        if not self._listening:
            self._listening = True
            now = time.time_ns() if now_ns is None else now_ns
            self.listen_from_ns = max(self.own.start_ns, now)

    def hear(self, text: str, now_ns: int | None = None) -> None:
        """Record one message from the claim topic (anything that is not a claim is dropped)."""
        got = decode(text)
        if got is None:
            return
        claim, _sent_ns, established = got
        now = time.time_ns() if now_ns is None else now_ns
        self.heard = {c: h for c, h in self.heard.items() if now - h.last_ns <= STALE_S * 1e9}
        first = self.heard.get(claim)  # keyed by all fields: a copied token, another start: another claim
        if first is not None:
            self.heard[claim] = first._replace(last_ns=now)
        elif len(self.heard) < MAX_HEARD:
            self.heard[claim] = Heard(claim, now, now, established)

    def established(self, now_ns: int | None = None) -> bool:
        """Whether this node is past its start-up window (it no longer arbitrates); never before it
        began to listen (it has not served yet)."""
        now = time.time_ns() if now_ns is None else now_ns
        return self._listening and now - self.listen_from_ns > self.window_ns

    def message(self, now_ns: int | None = None) -> str:
        """This node's claim as sent now."""
        return encode(self.own, self.established(now_ns))

    def rival(self, now_ns: int | None = None) -> Claim | None:
        """The claim to yield to now (:func:`earlier_rival`)."""
        now = time.time_ns() if now_ns is None else now_ns
        return earlier_rival(self.own, self.heard, now, self.window_ns, self.listen_from_ns)

    def ignored(self, now_ns: int | None = None) -> list[Heard]:
        """Live claims that would have priority but were first heard after the window; each once."""
        now = time.time_ns() if now_ns is None else now_ns
        late = [h for claim, h in self.heard.items()
                if claim not in self._reported and _live(self.own, h, now)
                and h.first_ns - self.listen_from_ns > self.window_ns
                and (h.claim < self.own or h.established)]
        self._reported = (self._reported & set(self.heard)) | {h.claim for h in late}
        return late


def ignored_text(late: Heard, own: Claim, listen_from_ns: int | None = None) -> str:
    """The one line a serving node logs for a claim it does not yield to."""
    c = late.claim
    start = own.start_ns if listen_from_ns is None else listen_from_ns
    return (f"ignoring the claim of {c.node or '?'} (pid {c.pid}, stated start "
            f"{(own.start_ns - c.start_ns) / 1e9:+.2f} s before this node's): first heard "
            f"{(late.first_ns - start) / 1e9:.1f} s after this node began listening; a serving plant-like "
            "node yields only to a rival heard during its start-up (docs/faults.md §Trust boundary)")
