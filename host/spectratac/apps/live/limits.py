"""Connection limits of the live server: a header timeout and a connection cap.

A client that opens connections and sends its request headers a byte at a time (slowloris)
held one file descriptor each for as long as it liked: about a thousand of them exhausted the
process's file limit, the page timed out and asyncio logged "Too many open files" megabytes
at a time. So a connection must complete its request headers within `header_timeout_s` of
opening (or of its last response), and at most `max_connections` are open at once (a page
needs one WebSocket and a few requests); a connection past either limit is closed. Each limit
says so once on the log, the first time (later ones are counted in `Limits`), not once per
connection.

uvicorn runs its HTTP/1.1 protocol (h11) as `Limits.protocol()` makes it; WebSocket
connections count towards the cap from the upgrade on.
"""

from __future__ import annotations

import asyncio
import logging
from dataclasses import dataclass
from typing import Any

import h11
from uvicorn.protocols.http.h11_impl import H11Protocol

log = logging.getLogger("spectratac.live")

HEADER_TIMEOUT_S = 10.0  # a browser sends its request headers at once
MAX_CONNECTIONS = 64  # far below the usual file limit (1,024), far above what a page uses


@dataclass
class Limits:
    header_timeout_s: float = HEADER_TIMEOUT_S
    max_connections: int = MAX_CONNECTIONS
    timed_out: int = 0  # connections closed without complete request headers in time
    over_cap: int = 0  # connections closed because `max_connections` were open

    def protocol(self) -> type[H11Protocol]:
        """uvicorn's h11 protocol bound to these limits (uvicorn's `http=` takes a class)."""
        return type("LimitedH11Protocol", (_LimitedH11,), {"limits": self})

    def note_timeout(self, client: Any) -> None:
        self.timed_out += 1
        if self.timed_out == 1:
            log.warning(
                "closed a connection from %s that sent no complete request headers within "
                "%g s (a stalled or hostile client); later ones are closed without a word",
                _peer(client), self.header_timeout_s,
            )  # fmt: skip

    def note_over_cap(self, client: Any) -> None:
        self.over_cap += 1
        if self.over_cap == 1:
            log.warning(
                "%d connections are open, the most this server takes: closed one from %s; "
                "later ones are closed without a word until some close",
                self.max_connections, _peer(client),
            )  # fmt: skip


def _peer(client: Any) -> str:
    return f"{client[0]}:{client[1]}" if client else "an unknown address"


class _LimitedH11(H11Protocol):
    limits: Limits
    _deadline: asyncio.TimerHandle | None = None

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        super().connection_made(transport)
        if len(self.connections) > self.limits.max_connections:
            self.limits.note_over_cap(self.client)
            transport.close()
            return
        self._arm()

    def connection_lost(self, exc: Exception | None) -> None:
        self._disarm()
        super().connection_lost(exc)

    def on_response_complete(self) -> None:
        super().on_response_complete()
        self._arm()  # the next request's headers get the same time

    def _arm(self) -> None:
        self._disarm()
        self._deadline = self.loop.call_later(self.limits.header_timeout_s, self._headers_due)

    def _disarm(self) -> None:
        if self._deadline is not None:
            self._deadline.cancel()
            self._deadline = None

    def _headers_due(self) -> None:
        self._deadline = None
        transport = self.transport
        if transport.is_closing() or transport.get_protocol() is not self:
            return  # closed, or upgraded to a WebSocket
        if self.conn.their_state is h11.IDLE:  # still waiting for a request's headers
            self.limits.note_timeout(self.client)
            transport.close()
