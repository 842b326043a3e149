"""A simulated ATI Net F/T on loopback: RDT over UDP and its netftapi2.xml over HTTP.

It answers RDT requests like the device: command 2 streams one record per packet, command
3 several (comrdtbsiz) per packet, each with a sample count (0 = until stopped); command 0
stops; 0x42 zeroes the readings at the current load. rdt_sequence counts every record of a
stream from 1, including those it "loses" (the host sees the gap); ft_sequence is the
sample index on the sensor's own clock. The HTTP page carries cfgcpf/cfgcpt/comrdtrate.

>>> from spectratac.sim.url import parse_sim_url
>>> from spectratac.sim.world import SimWorld
>>> from spectratac.sim.ft_source import FTParams, FTSource
>>> world = SimWorld.join(parse_sim_url("sim://?scene=press&seed=1&speed=10"))
>>> with NetFTServer(FTSource(world, FTParams())) as server:
...     server.port > 0, server.http_port > 0
(True, True)
>>> world.release()
"""

from __future__ import annotations

import contextlib
import http.server
import select
import socket
import threading
import time

import numpy as np

from spectratac.ft import rdt
from spectratac.ft.errors import FTProtocolError
from spectratac.sim.ft_source import FTSource

COUNTS_PER_FORCE = 1_000_000
COUNTS_PER_TORQUE = 1_000_000
BUFFERED_RECORDS = 40  # records per packet in buffered mode (the device's comrdtbsiz)
#: speed=max: the server waits while this many bytes wait unread at the host's socket. A real
#: Net F/T sends at its rate and a host that lags loses packets; unpaced, the scene runs tens of
#: times faster, so a host thread descheduled for 10 ms on a busy machine would lose hundreds
#: (a README recording lost 13 % at load 15). The host's receive buffer is at least 208 KB.
UNPACED_BACKLOG_BYTES = 64 * 1024
UNPACED_CHECK_EVERY = 64  # records between looks: 64 packets stay well inside the margin
UNPACED_PATIENCE_S = 5.0  # a host that stopped reading loses what follows, as behind a real link


class NetFTServer:
    """RDT server on host:port (0 = any free port) and its configuration page on http_port."""

    def __init__(
        self,
        source: FTSource,
        host: str = "127.0.0.1",
        port: int = 0,
        http_port: int = 0,
        cpf: int = COUNTS_PER_FORCE,
        cpt: int = COUNTS_PER_TORQUE,
    ) -> None:
        self.source = source
        self.cpf, self.cpt = cpf, cpt
        self._scale = np.array([cpf] * 3 + [cpt] * 3, dtype=np.float64)
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 4 << 20)
        self._sock.bind((host, port))
        self._sock.setblocking(False)
        self._reader_gone = False  # speed=max: the host let a wait for it run out
        self.host, self.port = self._sock.getsockname()
        self._http = http.server.ThreadingHTTPServer((host, http_port), _page_handler(self))
        self.http_port = self._http.server_address[1]
        self._stop = threading.Event()
        self._client: tuple[str, int] | None = None
        self._remaining = 0  # records left in the current stream (-1: until stopped)
        self._per_packet = 1
        self._rdt_seq = 0
        self._bias = np.zeros(6)
        self._last = np.zeros(6)
        self.sent = 0
        self.dropped = 0
        self.bad_requests = 0
        self._threads = [
            threading.Thread(target=self._run, name="sim-netft", daemon=True),
            threading.Thread(target=self._http.serve_forever, name="sim-netft-http", daemon=True),
        ]
        for t in self._threads:
            t.start()

    @property
    def url(self) -> str:
        """The netft:// URL a driver opens (counts per unit read from the HTTP page)."""
        return f"netft://{self.host}:{self.port}?http_port={self.http_port}"

    def page(self) -> bytes:
        p = self.source.params
        fields = {
            "cfgcpf": self.cpf,
            "cfgcpt": self.cpt,
            "scfgfu": "N",
            "scfgtu": "N-m",
            "comrdte": "Enabled",
            "comrdtrate": f"{p.rate:g}",
            "comrdtbsiz": BUFFERED_RECORDS,
            "runstat": "0x00000000",
            "setserial": "SIM-NETFT",
        }
        body = "".join(f"<{k}>{v}</{k}>" for k, v in fields.items())
        return f'<?xml version="1.0"?><netft>{body}</netft>'.encode()

    def stop(self) -> None:
        self.source.streaming(False)
        self._stop.set()
        self._http.shutdown()
        for t in self._threads:
            t.join(timeout=2.0)
        self._http.server_close()
        self._sock.close()

    def __enter__(self) -> NetFTServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ------------------------------------------------------------------ RDT
    def _run(self) -> None:
        while not self._stop.is_set():
            wait = 0.05
            if self._remaining:
                wait = min(wait, max(0.0, self.source.next_due_host() - time.monotonic()))
            readable, _, _ = select.select([self._sock], [], [], max(wait, 0.0002))
            if readable:
                self._requests()
            if self._remaining:
                self._emit()

    def _requests(self) -> None:
        while True:
            try:
                data, client = self._sock.recvfrom(64)
            except (BlockingIOError, ConnectionRefusedError):
                return
            try:
                command, count = rdt.decode_request(data)
            except FTProtocolError:
                self.bad_requests += 1
                continue
            if command in (rdt.CMD_START_REALTIME, rdt.CMD_START_BUFFERED):
                self.source.skip()  # a new stream starts with the next sample
                self._client = client
                self._remaining = count if count else -1
                self.source.streaming(not count)  # speed=max: a stream until stopped paces
                self._per_packet = BUFFERED_RECORDS if command == rdt.CMD_START_BUFFERED else 1
                self._rdt_seq = 0
            elif command == rdt.CMD_STOP:
                self._remaining = 0
                self.source.streaming(False)
            elif command == rdt.CMD_SET_SOFTWARE_BIAS:
                self._bias = self._bias + self._last
            else:
                self.bad_requests += 1

    def _emit(self) -> None:
        batch = self.source.pop_due()
        if self._remaining == 1 and self.source.waiting:
            batch = self.source.rest_sample()  # a probe before the scene's clock started
        n = len(batch.k)
        if n == 0 or self._client is None:
            return
        if self._remaining > 0:
            n = min(n, self._remaining)
            self._remaining -= n
        wrench = batch.wrench[:n] - self._bias
        self._last = wrench[-1]
        counts = np.clip(np.rint(wrench * self._scale), -(2**31), 2**31 - 1).astype(np.int64)
        seq = (self._rdt_seq + 1 + np.arange(n)) & 0xFFFF_FFFF
        self._rdt_seq += n
        status = np.zeros(n, dtype=np.uint32)
        wire = rdt.encode_records(seq, batch.k[:n] & 0xFFFF_FFFF, status, counts)
        lost = batch.lost[:n]
        size, step = rdt.RECORD_SIZE, self._per_packet
        send = self._sock.sendto
        unpaced = not self.source.world.paced
        for i in range(0, n, step):
            if unpaced and i % UNPACED_CHECK_EVERY < step:  # a batch can be seconds of scene
                self._wait_for_reader(self._client[1])
                if self._stop.is_set():
                    return  # stopped: the socket is about to close
            j = min(i + step, n)
            if step == 1 and lost[i]:
                self.dropped += 1
                continue
            # in buffered mode a lost packet takes its records with it
            if step > 1 and lost[i:j].any():
                self.dropped += j - i
                continue
            with contextlib.suppress(BlockingIOError, ConnectionRefusedError):
                send(wire[i * size : j * size], self._client)
                self.sent += j - i

    def _wait_for_reader(self, port: int) -> None:
        """Unpaced: wait (bounded) until the host has read most of what was sent; a host
        that let the wait run out is not waited for again until it reads."""
        deadline = time.monotonic() + UNPACED_PATIENCE_S
        while (backlog := udp_backlog(port)) is not None and backlog > UNPACED_BACKLOG_BYTES:
            if self._reader_gone or time.monotonic() > deadline or self._stop.wait(0.001):
                self._reader_gone = True
                return
        self._reader_gone = False


def udp_backlog(port: int, table: str = "/proc/net/udp") -> int | None:
    """Bytes waiting unread at the local UDP socket bound to `port` (Linux: the rx_queue
    column of /proc/net/udp); None where the table cannot tell.

    >>> with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as rx:
    ...     rx.bind(("127.0.0.1", 0))
    ...     with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as tx:
    ...         _ = tx.sendto(b"x" * 100, rx.getsockname())
    ...     udp_backlog(rx.getsockname()[1]) > 0
    True
    """
    try:
        with open(table, encoding="ascii") as f:
            next(f)  # the header
            for line in f:
                fields = line.split()
                if int(fields[1].rpartition(":")[2], 16) == port:
                    return int(fields[4].partition(":")[2], 16)
    except (OSError, StopIteration, ValueError, IndexError):
        return None
    return None


def _page_handler(server: NetFTServer) -> type[http.server.BaseHTTPRequestHandler]:
    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self) -> None:
            if self.path.split("?")[0] != "/netftapi2.xml":
                self.send_error(404)
                return
            body = server.page()
            self.send_response(200)
            self.send_header("Content-Type", "text/xml")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, *args: object) -> None:
            pass  # quiet: a test harness or CLI would drown in request lines

    return Handler
