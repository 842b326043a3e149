"""ATI Net F/T driver: netft://HOST[:PORT]?cpf=&cpt=&http_port=&rate=&seq_rate=&mode=.

Opening sends a one-record RDT request and waits for the answer (retrying every 0.25 s),
so a wrong address or a sensor that is off fails with FTTimeoutError within `timeout`.
Counts per force/torque come from cpf=/cpt=, else from the device's configuration page
http://HOST:http_port/netftapi2.xml (cfgcpf, cfgcpt; also comrdtrate, the RDT rate).

Records: sequence is the RDT sequence (per record, unwrapped, continued across restarts),
so lost and reordered UDP packets show in stats and as gaps; sensor_time is the sensor's
F/T sequence divided by the rate it advances at (seq_rate=, default the RDT rate times the
observed F/T-sequence step per record: a sensor streaming below its internal rate skips
internal samples); status is the device's status word (0 = healthy). mode=buffered asks
for several records per packet (RDT command 3) instead of one (command 2, the default).
"""

from __future__ import annotations

import logging
import select
import socket
import time
import urllib.request
import xml.etree.ElementTree as ET
from typing import Any
from urllib.parse import parse_qsl, urlsplit

import numpy as np

from spectratac.ft import rdt
from spectratac.ft.base import FTSensor
from spectratac.ft.errors import (
    FTConfigError,
    FTNotFoundError,
    FTProtocolError,
    FTTimeoutError,
    FTURLError,
)
from spectratac.ft.options import RATE, Options, Param
from spectratac.ft.records import FT_RECORD, FTInfo
from spectratac.ft.sequence import SequenceTracker, Unwrapper

log = logging.getLogger("spectratac.ft")

ASSUMED_INTERNAL_RATE_HZ = 7000.0  # classic Net F/T internal sample rate (used if no rate known)
_MAX_PACKETS_PER_POLL = 8192
QUIET_S = 0.1  # silence that ends a stopped stream (longer than a buffered packet's interval)
DRAIN_MAX_S = 1.0  # bound on waiting for it: a sensor that never goes quiet restarts anyway
#: netft:// options (spectratac.ft.options).
URL_PARAMS = {
    "cpf": Param("number", 1e-6, 1e12, "counts per force unit (else read from the sensor)"),
    "cpt": Param("number", 1e-6, 1e12, "counts per torque unit (else read from the sensor)"),
    "http_port": Param("integer", 1, 65535, "port of the sensor's web server"),
    "rate": RATE,
    "seq_rate": Param("number", 0.01, 1e6, "rate of the RDT sequence counter, Hz"),
    "mode": Param("choice", meaning="RDT streaming mode", choices=("realtime", "buffered")),
}


def read_netftapi2(host: str, port: int, timeout: float) -> dict[str, str]:
    """The flat tag -> text map of http://host:port/netftapi2.xml (OSError, ET.ParseError)."""
    with urllib.request.urlopen(f"http://{host}:{port}/netftapi2.xml", timeout=timeout) as r:
        root = ET.fromstring(r.read())
    return {el.tag.lower(): (el.text or "").strip() for el in root.iter()}


class NetFTSensor(FTSensor):
    """ATI Net F/T over UDP RDT (see the module documentation)."""

    scheme = "netft"

    @classmethod
    def connect(cls, url: str, *, timeout: float, buffer_size: int, **options: Any) -> NetFTSensor:
        parts = urlsplit(url)
        hostname = parts.hostname
        if not hostname:
            raise FTURLError(
                f"{url}: no host; example: netft://192.168.1.1?cpf=1000000&cpt=1000000"
            )
        try:
            port = parts.port or rdt.RDT_PORT
        except ValueError:
            raise FTURLError(f"{url}: bad port") from None
        opts = Options(url, {**dict(parse_qsl(parts.query)), **options}, URL_PARAMS)
        cpf, cpt = opts.number("cpf"), opts.number("cpt")
        http_port = opts.integer("http_port", 80)
        rate = opts.number("rate")
        seq_rate = opts.number("seq_rate")
        mode = opts.text("mode", "realtime")
        deadline = time.monotonic() + timeout
        try:
            infos = socket.getaddrinfo(hostname, port, socket.AF_INET, socket.SOCK_DGRAM)
        except socket.gaierror as exc:
            raise FTNotFoundError(f"{url}: cannot resolve host {hostname!r}: {exc}") from None
        address = infos[0][4]
        # Probe from a socket of its own: late answers to retried probes then go to a closed
        # port instead of posing as the first records of the stream.
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.connect(address)  # only the sensor's packets, and ICMP errors surface
            status = _probe(probe, url, timeout, deadline)
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
            sock.connect(address)
            sock.setblocking(False)
            config: dict[str, str] = {}
            if cpf is None or cpt is None or rate is None:
                config = _config(
                    url, hostname, http_port, deadline, need=cpf is None or cpt is None
                )
        except BaseException:
            sock.close()
            raise
        try:
            cpf = cpf if cpf is not None else float(config["cfgcpf"])
            cpt = cpt if cpt is not None else float(config["cfgcpt"])
            rate = rate if rate is not None else float(config.get("comrdtrate") or 0.0)
        except (KeyError, ValueError):
            sock.close()
            raise FTConfigError(
                f"{url}: the device's netftapi2.xml has no usable cfgcpf/cfgcpt: pass them, e.g. "
                f"netft://{hostname}?cpf=1000000&cpt=1000000"
            ) from None
        if cpf <= 0 or cpt <= 0:
            sock.close()
            raise FTConfigError(f"{url}: counts per force/torque must be > 0 (got {cpf}, {cpt})")
        info = FTInfo(
            "netft",
            model="ATI Net F/T",
            serial=config.get("setserial", ""),
            rate_hz=rate,
            counts_per_force=cpf,
            counts_per_torque=cpt,
            extra={
                "host": address[0],
                "port": address[1],
                "mode": mode,
                "status_at_open": status,
                "force_unit": config.get("scfgfu", ""),
                "torque_unit": config.get("scfgtu", ""),
            },
        )
        sensor = cls(url, info, timeout=timeout, buffer_size=buffer_size)
        sensor._setup(sock, mode, seq_rate)
        return sensor

    def _setup(self, sock: socket.socket, mode: str, seq_rate: float | None) -> None:
        self._sock = sock
        self._mode = mode
        self._seq_rate = seq_rate
        self._scale = np.array([self.info.counts_per_force] * 3 + [self.info.counts_per_torque] * 3)
        self._rdt_unwrap = Unwrapper(32)
        self._ft_unwrap = Unwrapper(32)
        self._tracker = SequenceTracker(self.stats)
        self._held: list[tuple[np.ndarray, np.ndarray]] = []  # records before seq_rate is known

    # ------------------------------------------------------------------ commands
    def _send(self, command: int, count: int = 0) -> None:
        self._sock.send(rdt.encode_request(command, count))

    def _send_start(self) -> None:
        self._drain()
        # A new stream numbers records from 1 again: continue our sequence after the last.
        base = self._tracker.expected if self._tracker.expected is not None else 1
        self._rdt_unwrap.rebase(base - 1)
        cmd = rdt.CMD_START_BUFFERED if self._mode == "buffered" else rdt.CMD_START_REALTIME
        self._send(cmd, 0)

    def _send_stop(self) -> None:
        self._send(rdt.CMD_STOP)

    def bias(self) -> None:
        """Ask the sensor to zero its readings at the current load (RDT software bias)."""
        self._send(rdt.CMD_SET_SOFTWARE_BIAS)

    def _close_link(self) -> None:
        self._sock.close()

    def _drain(self) -> None:
        """Discard what a previous stream left in flight, so it does not pose as the new one.
        After a stream, wait for QUIET_S of silence (at most DRAIN_MAX_S): a sensor still
        sends until it has handled STOP, and a packet of the old stream read after the restart
        was numbered in the new one (2 duplicates and 200 'reordered' records seen in CI)."""
        self._sock.setblocking(False)
        deadline = time.monotonic() + (DRAIN_MAX_S if self._tracker.expected is not None else 0.0)
        while True:
            try:
                while True:
                    self._sock.recv(65536)
            except (BlockingIOError, ConnectionRefusedError):
                pass
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self._sock], [], [], min(QUIET_S, left))[0]:
                return

    # ------------------------------------------------------------------ receiving
    def _poll(self, timeout: float) -> np.ndarray:
        readable, _, _ = select.select([self._sock], [], [], timeout)
        if not readable:
            return np.empty(0, dtype=FT_RECORD)
        packets: list[bytes] = []
        times: list[float] = []
        recv, now = self._sock.recv, time.monotonic
        try:
            while len(packets) < _MAX_PACKETS_PER_POLL:
                packets.append(recv(65536))
                times.append(now())
        except BlockingIOError:
            pass
        except ConnectionRefusedError:
            pass  # ICMP from a sensor that went away: its silence shows as a gap
        return self._parse(packets, times)

    def _parse(self, packets: list[bytes], times: list[float]) -> np.ndarray:
        sizes = np.fromiter(map(len, packets), dtype=np.int64, count=len(packets))
        good = (sizes > 0) & (sizes % rdt.RECORD_SIZE == 0)
        if not good.all():
            self.stats.bad_frames += int(np.count_nonzero(~good))
            packets = [p for p, g in zip(packets, good, strict=True) if g]
            times = [t for t, g in zip(times, good, strict=True) if g]
            sizes = sizes[good]
        if not packets:
            return np.empty(0, dtype=FT_RECORD)
        recs = rdt.decode_records(b"".join(packets))
        host = np.repeat(np.asarray(times), sizes // rdt.RECORD_SIZE)
        if self._seq_rate is None:
            self._held.append((recs, host))
            recs = np.concatenate([r for r, _ in self._held])
            host = np.concatenate([h for _, h in self._held])
            if not self._learn_seq_rate(recs):
                return np.empty(0, dtype=FT_RECORD)
            self._held.clear()
        seq_rate = self._seq_rate
        assert seq_rate is not None  # given, or learned from the records held above
        seq = self._rdt_unwrap(recs["rdt_sequence"])
        ft_seq = self._ft_unwrap(recs["ft_sequence"])
        keep = self._tracker.update(seq)
        out = np.empty(len(recs), dtype=FT_RECORD)
        out["sensor_time"] = ft_seq / seq_rate
        out["host_time"] = host
        out["sequence"] = seq
        out["wrench"] = recs["counts"] / self._scale
        out["status"] = recs["status"]
        if not keep.all():
            out = out[keep]
        if len(out) > 1 and np.any(np.diff(out["sequence"].astype(np.int64)) < 0):
            out = out[np.argsort(out["sequence"], kind="stable")]
        return out

    def _learn_seq_rate(self, recs: np.ndarray) -> bool:
        """Fix the F/T-sequence clock rate from consecutive records (True once known)."""
        rate = self.info.rate_hz
        if not rate:
            self._seq_rate = ASSUMED_INTERNAL_RATE_HZ
            self.info.extra["seq_rate_source"] = "assumed"
            log.warning(
                "%s: RDT rate unknown; assuming the F/T sequence counts at %.0f Hz. Pass "
                "rate= (RDT rate) or seq_rate= for exact sensor times",
                self.url,
                ASSUMED_INTERNAL_RATE_HZ,
            )
            self.info.extra["seq_rate"] = self._seq_rate
            return True
        rdt_seq = recs["rdt_sequence"].astype(np.int64)
        step = np.diff(recs["ft_sequence"].astype(np.int64))[np.diff(rdt_seq) == 1]
        step = step[(step > 0) & (step < 1 << 20)]
        if len(step) == 0:
            return len(recs) > 64 and self._give_up_learning()
        self._seq_rate = rate * max(1, round(float(np.median(step))))
        self.info.extra["seq_rate"] = self._seq_rate
        self.info.extra["seq_rate_source"] = "rate x observed step"
        return True

    def _give_up_learning(self) -> bool:
        self._seq_rate = self.info.rate_hz
        self.info.extra["seq_rate"] = self._seq_rate
        self.info.extra["seq_rate_source"] = "rate"
        return True


def _probe(sock: socket.socket, url: str, timeout: float, deadline: float) -> int:
    """Ask for one record until one comes back; its status word. FTTimeoutError otherwise."""
    refused = False
    request = rdt.encode_request(rdt.CMD_START_REALTIME, 1)
    while True:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            why = (
                "nothing listens on that UDP port (connection refused)" if refused else "no answer"
            )
            raise FTTimeoutError(
                f"no RDT reply from {url} within {timeout:.1f} s ({why}): check the address and "
                f"port, that the Net F/T is powered and RDT is enabled, and that no firewall "
                f"blocks UDP {rdt.RDT_PORT}"
            )
        try:
            sock.send(request)
            sock.settimeout(min(0.25, remaining))
            data = sock.recv(65536)
        except TimeoutError:
            continue
        except ConnectionRefusedError:
            refused = True
            time.sleep(min(0.05, max(0.0, deadline - time.monotonic())))
            continue
        except OSError:  # no route to host, network down: keep trying until the deadline
            time.sleep(min(0.05, max(0.0, deadline - time.monotonic())))
            continue
        if len(data) >= rdt.RECORD_SIZE and len(data) % rdt.RECORD_SIZE == 0:
            return int(rdt.decode_records(data)["status"][0])
        raise FTProtocolError(
            f"{url} answered an RDT request with {len(data)} bytes, not 36-byte records: "
            f"is it a Net F/T?"
        )


def _config(url: str, host: str, http_port: int, deadline: float, *, need: bool) -> dict[str, str]:
    """netftapi2.xml, within the open deadline; FTConfigError if `need`ed and unavailable."""
    remaining = deadline - time.monotonic()
    try:
        if remaining <= 0:
            raise TimeoutError("no time left within the open timeout")
        return read_netftapi2(host, http_port, remaining)
    except (OSError, ET.ParseError) as exc:
        if need:
            raise FTConfigError(
                f"{url}: could not read counts per force/torque from "
                f"http://{host}:{http_port}/netftapi2.xml ({exc}): pass them in the URL, e.g. "
                f"netft://{host}?cpf=1000000&cpt=1000000 (values from the sensor's calibration)"
            ) from None
        return {}
