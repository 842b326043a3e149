"""A minimal client of the Foxglove WebSocket protocol, written from the protocol's
specification (github.com/foxglove/ws-protocol): what Foxglove itself does on "Open
connection". Nothing here imports spectratac.

Lichtblick and every ``@foxglove/ws-protocol`` client offer the subprotocol
``foxglove.websocket.v1`` alone; the foxglove SDK's clients ``foxglove.sdk.v1``: the client
offers exactly one, as they do. Text frames are JSON (``serverInfo``, ``advertise``...);
binary ``messageData`` frames are opcode 0x01, u32 subscription id, u64 log time (ns), then
the message in the channel's encoding.
"""

from __future__ import annotations

import json
import struct
import time
from dataclasses import dataclass, field
from typing import Any

import websocket
from jsonschema import Draft202012Validator

SUBPROTOCOL = "foxglove.websocket.v1"  # Lichtblick's
MESSAGE_DATA = 0x01
_HEADER = struct.Struct("<BIQ")


@dataclass
class Received:
    topic: str
    log_time: int
    message: dict[str, Any]


@dataclass
class FoxgloveClient:
    url: str
    subprotocol: str = SUBPROTOCOL
    server_info: dict[str, Any] = field(default_factory=dict)
    channels: dict[str, dict[str, Any]] = field(default_factory=dict)  # by topic
    _ws: Any = None
    _subscriptions: dict[int, str] = field(default_factory=dict)
    _validators: dict[str, Draft202012Validator] = field(default_factory=dict)

    def connect(self, topics: tuple[str, ...], timeout: float = 30.0) -> FoxgloveClient:
        """Connect; wait for serverInfo and the advertisement of every one of `topics`."""
        self._ws = websocket.create_connection(self.url, subprotocols=[self.subprotocol],
                                               timeout=timeout)  # fmt: skip
        assert self._ws.getsubprotocol() == self.subprotocol
        deadline = time.monotonic() + timeout
        while not (self.server_info and set(topics) <= set(self.channels)):
            if time.monotonic() > deadline:
                raise AssertionError(
                    f"no advertisement of {sorted(set(topics) - set(self.channels))} within "
                    f"{timeout} s (serverInfo: {bool(self.server_info)})"
                )
            frame = self._ws.recv()
            if isinstance(frame, str):
                self._control(json.loads(frame))
        return self

    def _control(self, msg: dict[str, Any]) -> None:
        if msg["op"] == "serverInfo":
            self.server_info = msg
        elif msg["op"] == "advertise":
            for channel in msg["channels"]:
                self.channels[channel["topic"]] = channel

    def subscribe(self, *topics: str) -> None:
        subs = []
        for topic in topics:
            channel = self.channels[topic]
            assert channel["encoding"] == "json" and channel["schemaEncoding"] == "jsonschema"
            schema = json.loads(channel["schema"])
            Draft202012Validator.check_schema(schema)
            self._validators[topic] = Draft202012Validator(schema)
            sub_id = len(self._subscriptions) + 1
            self._subscriptions[sub_id] = topic
            subs.append({"id": sub_id, "channelId": channel["id"]})
        self._ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

    def receive(self, seconds: float, until: int | None = None) -> list[Received]:
        """Every message of the subscriptions in the next `seconds`, each validated against
        its channel's advertised schema; with `until`, as soon as that many have arrived
        (`seconds` is then a hang guard)."""
        out: list[Received] = []
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0 and (until is None or len(out) < until):
            self._ws.settimeout(left)
            try:
                frame = self._ws.recv()
            except websocket.WebSocketTimeoutException:
                break
            if isinstance(frame, str):
                self._control(json.loads(frame))
                continue
            op, sub_id, log_time = _HEADER.unpack_from(frame)
            assert op == MESSAGE_DATA, f"unexpected binary opcode {op:#x}"
            topic = self._subscriptions[sub_id]
            message = json.loads(frame[_HEADER.size :])
            self._validators[topic].validate(message)
            out.append(Received(topic, log_time, message))
        return out

    def closed_by_server(self, timeout: float = 30.0) -> bool:
        """True once the server ends the connection (it stopped)."""
        self._ws.settimeout(timeout)
        try:
            while True:
                if not self._ws.recv():
                    return True
        except (websocket.WebSocketConnectionClosedException, ConnectionError):
            return True
        except websocket.WebSocketTimeoutException:
            return False

    def close(self) -> None:
        if self._ws is not None:
            self._ws.close()
