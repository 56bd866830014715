"""A minimal client of the Foxglove WebSocket protocol, written from the protocol, not from the SDK.

It does what a viewer does: connect with the subprotocol, read ``serverInfo``
and ``advertise``, ``subscribe``, and decode each binary ``messageData`` frame
(opcode 1, subscription id u32 LE, log time u64 LE, payload) with the schema
the server advertised: protobuf through a descriptor pool built from the
advertised FileDescriptorSet (google.protobuf comes with ray), JSON as JSON.
"""

from __future__ import annotations

import base64
import json
import struct
import time
from contextlib import ExitStack
from dataclasses import dataclass
from typing import Any

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from websockets.sync.client import ClientConnection, connect

from msd_bench.io.reports.live_server import SUBPROTOCOL

MESSAGE_DATA = 0x01


@dataclass(frozen=True)
class Received:
    """One decoded message: its topic, the server's log time (ns) and the decoded value."""

    topic: str
    log_time: int
    value: Any


def _message_class(schema_name: str, schema_b64: str) -> Any:
    """The protobuf class of ``schema_name`` from its advertised FileDescriptorSet."""
    fds = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(schema_b64))
    pool = descriptor_pool.DescriptorPool()
    pending = list(fds.file)
    while pending:  # dependencies first, whatever order the set lists them in
        added = [f for f in pending if all(pool_has(pool, d) for d in f.dependency)]
        assert added, f"unresolvable imports in the schema of {schema_name}"
        for f in added:
            pool.Add(f)
        pending = [f for f in pending if f not in added]
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema_name))


def pool_has(pool: descriptor_pool.DescriptorPool, name: str) -> bool:
    try:
        pool.FindFileByName(name)
    except KeyError:
        return False
    return True


class FoxgloveClient:
    """A connected viewer: ``info`` and ``channels`` (by topic) as the server advertised them."""

    def __init__(self, url: str, timeout: float = 30.0) -> None:
        self._stack = ExitStack()  # websockets 17 wants its connection entered as a context manager
        self.ws: ClientConnection = self._stack.enter_context(
            connect(url, subprotocols=[SUBPROTOCOL], open_timeout=timeout))  # type: ignore[list-item]
        assert self.ws.subprotocol == SUBPROTOCOL
        self.info = self._json(timeout)
        assert self.info["op"] == "serverInfo", self.info
        self.channels: dict[str, dict[str, Any]] = {}
        self._subs: dict[int, dict[str, Any]] = {}
        self._classes: dict[str, Any] = {}

    def _json(self, timeout: float) -> dict[str, Any]:
        frame = self.ws.recv(timeout)
        assert isinstance(frame, str), f"expected a JSON control frame, got {len(frame)} bytes"
        doc: dict[str, Any] = json.loads(frame)
        return doc

    def wait_for_channels(self, topics: list[str], timeout: float = 30.0) -> None:
        """Read ``advertise`` frames until every topic is advertised."""
        deadline = time.monotonic() + timeout
        while not set(topics) <= set(self.channels):
            doc = self._json(max(0.1, deadline - time.monotonic()))
            if doc["op"] == "advertise":
                self.channels.update({c["topic"]: c for c in doc["channels"]})

    def subscribe(self, topics: list[str]) -> None:
        """Subscribe to ``topics`` (advertised already), one subscription id each."""
        first = len(self._subs) + 1
        subs = [{"id": first + i, "channelId": self.channels[t]["id"]} for i, t in enumerate(topics)]
        for s, t in zip(subs, topics, strict=True):
            self._subs[s["id"]] = self.channels[t]
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

    def receive(self, timeout: float) -> Received | None:
        """The next data message (control frames skipped), or None if none came within ``timeout``."""
        deadline = time.monotonic() + timeout
        while (left := deadline - time.monotonic()) > 0:
            try:
                frame = self.ws.recv(left)
            except TimeoutError:
                return None
            if isinstance(frame, str) or frame[0] != MESSAGE_DATA:
                continue
            sub, log_time = struct.unpack_from("<IQ", frame, 1)
            return Received(self._subs[sub]["topic"], log_time, self._decode(self._subs[sub], frame[13:]))
        return None

    def _decode(self, channel: dict[str, Any], payload: bytes) -> Any:
        if channel["encoding"] == "json":
            return json.loads(payload)
        assert channel["encoding"] == "protobuf", channel["encoding"]
        name = channel["schemaName"]
        if name not in self._classes:
            self._classes[name] = _message_class(name, channel["schema"])
        return self._classes[name].FromString(payload)

    def close(self) -> None:
        self._stack.close()
