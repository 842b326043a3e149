"""A fault-injecting UDP proxy for RDT: sits between a driver and a (simulated) Net F/T and
drops, duplicates or holds back chosen records by their RDT sequence number."""

from __future__ import annotations

import select
import socket
import threading

from spectratac.ft import rdt


class FaultyUDPProxy:
    """Forwards requests to `upstream`; answers go back to the last client with faults:
    drop (never delivered), duplicate (sent twice), delay (sent after the next record)."""

    def __init__(
        self,
        upstream: tuple[str, int],
        drop: set[int] = frozenset(),  # type: ignore[assignment]
        duplicate: set[int] = frozenset(),  # type: ignore[assignment]
        delay: set[int] = frozenset(),  # type: ignore[assignment]
        garbage_after: set[int] = frozenset(),  # type: ignore[assignment]
    ) -> None:
        self.upstream = upstream
        self.drop, self.duplicate, self.delay = set(drop), set(duplicate), set(delay)
        self.garbage_after = set(garbage_after)
        self.front = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.front.bind(("127.0.0.1", 0))
        self.back = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.back.connect(upstream)
        self.port = self.front.getsockname()[1]
        self.client: tuple[str, int] | None = None
        self._held: list[bytes] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            readable, _, _ = select.select([self.front, self.back], [], [], 0.05)
            for sock in readable:
                try:
                    data, addr = sock.recvfrom(65536)
                except OSError:
                    continue
                if sock is self.front:
                    self.client = addr
                    self.back.send(data)
                elif self.client is not None:
                    self._forward(data)

    def _forward(self, packet: bytes) -> None:
        assert self.client is not None
        seq = int(rdt.decode_records(packet[:36])["rdt_sequence"][0])
        out: list[bytes] = []
        if seq in self.drop:
            pass
        elif seq in self.delay:
            self._held.append(packet)
            return
        else:
            out.append(packet)
            if seq in self.duplicate:
                out.append(packet)
        out += self._held
        self._held = []
        if seq in self.garbage_after:
            out.append(b"\x00" * 35)  # not a whole record
        for p in out:
            self.front.sendto(p, self.client)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)
        self.front.close()
        self.back.close()
