"""One fuzz target per reader: how to make its seeds, how to mutate them, how to feed one
input to the reader, and which errors are the reader's typed answer to bad input.

The property every target checks: any input gives a result or one of `allowed` (the module's
typed errors, SpectraTacError subclasses unless the module documents another), never another
exception. `per_second` is the measured rate of the target on the CI machine (2 shared
cores): the budget in seconds becomes a fixed iteration count through it.
"""

from __future__ import annotations

import contextlib
import socket
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import cobs.cobs as cobs
import numpy as np
from spectratac.errors import SpectraTacError

from tests.fuzz import seeds
from tests.fuzz.mutate import Mutator

Mutate = Callable[[Mutator, bytes, Sequence[bytes]], bytes]


@dataclass(frozen=True)
class Target:
    name: str
    make_seeds: Callable[[Path], list[bytes]]
    run: Callable[[bytes, Path], Any]
    mutate: Mutate
    per_second: float  # iterations per second on the CI machine (measured)
    weight: float = 1.0  # share of the fuzz budget
    memory_base: int = 64 << 20  # peak allocation allowed whatever the input (bytes)
    allowed: tuple[type[BaseException], ...] = (SpectraTacError,)


def _bytes(m: Mutator, data: bytes, pool: Sequence[bytes]) -> bytes:
    return m.mutate(data, pool)


def _zip(m: Mutator, data: bytes, pool: Sequence[bytes]) -> bytes:
    return m.mutate_zip(data, pool) if m.rng.random() < 0.8 else m.mutate(data, pool)


def _text(m: Mutator, data: bytes, pool: Sequence[bytes]) -> bytes:
    if m.rng.random() < 0.6:
        return m.mutate_text(data.decode("utf-8", "replace")).encode("utf-8", "surrogatepass")
    return m.mutate(data, pool)


def _write(workdir: Path, name: str, data: bytes) -> Path:
    path = workdir / name
    path.write_bytes(data)
    return path


# ---------------------------------------------------------------------- protocol
def _reframe(m: Mutator, data: bytes, pool: Sequence[bytes]) -> bytes:
    """Mutate the insides of frames and give them a valid CRC and COBS again, so the
    mutations reach the message decoders behind the CRC check."""
    from spectratac.protocol.framing import CRC, crc32c

    if m.rng.random() < 0.4:
        return m.mutate(data, pool)
    out = []
    for part in data.split(b"\x00"):
        try:
            raw = cobs.decode(part)
        except cobs.DecodeError:
            out.append(part)
            continue
        body = raw[:-4] if len(raw) > 4 else raw
        if m.rng.random() < 0.5:
            body = m.mutate(body, (), rounds=1)
        out.append(cobs.encode(body + CRC.pack(crc32c(body))))
    return b"\x00".join(out)


def _protocol_stream(data: bytes, workdir: Path) -> Any:
    from spectratac.protocol import StreamDecoder, decode_samples

    decoder = StreamDecoder()
    step = 1 + (len(data) * 7) % 97  # chunk sizes vary with the input, deterministically
    frames = []
    for at in range(0, len(data), step):
        frames += decoder.feed(data[at : at + step])
    for frame in frames:
        frame.message.validate()
    decoder.stats.as_dict()
    bulk = decode_samples(data)
    return len(frames), len(bulk.samples), bulk.samples.tolist()


def _protocol_frames(data: bytes, workdir: Path) -> Any:
    from spectratac.protocol import decode_frame

    return len([decode_frame(part) for part in data.split(b"\x00") if part])


# ---------------------------------------------------------------------- files
def _stac(data: bytes, workdir: Path) -> Any:
    from spectratac.decode.decoder import Decoder

    dec = Decoder.load(_write(workdir, "input.stac", data))
    return dec


def _dataset(data: bytes, workdir: Path) -> Any:
    from spectratac.dataset import Dataset

    return Dataset.load(_write(workdir, "input.npz", data))


def _generic_table(data: bytes, workdir: Path) -> Any:
    from spectratac.dataset.generic_io import load_any

    suffix = "npz" if data[:2] == b"PK" else "csv"
    return load_any(_write(workdir, f"input.{suffix}", data))


def _recording(data: bytes, workdir: Path) -> Any:
    from spectratac.record.reader import read_recording

    return read_recording(_write(workdir, "input.mcap", data))


def _mcap(m: Mutator, data: bytes, pool: Sequence[bytes]) -> bytes:
    """Rewrite the recording with one message mutated (or dropped, or repeated), so the
    mutation gets past the chunk CRCs and compression into the reader's checks."""
    import io

    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    if m.rng.random() < 0.3:
        return m.mutate(data, pool)
    try:
        messages = list(make_reader(io.BytesIO(data)).iter_messages())
    except Exception:  # a seed already damaged: byte-level mutation only
        return m.mutate(data, pool)
    if not messages:
        return m.mutate(data, pool)
    pick = m.rng.randrange(len(messages))
    out = io.BytesIO()
    writer = Writer(out, compression=CompressionType.NONE)
    writer.start()
    schemas: dict[int, int] = {}
    channels: dict[int, int] = {}
    for i, (schema, channel, message) in enumerate(messages):
        if schema is not None and schema.id not in schemas:
            schemas[schema.id] = writer.register_schema(schema.name, schema.encoding, schema.data)
        if channel.id not in channels:
            channels[channel.id] = writer.register_channel(
                channel.topic, channel.message_encoding, schemas.get(channel.schema_id, 0)
            )
        payload = message.data
        copies = 1
        if i == pick:
            kind = m.rng.randrange(4)
            if kind == 0:
                copies = 0
            elif kind == 1:
                copies = 2
            elif channel.message_encoding == "json" and kind == 2:
                try:
                    import json

                    obj = json.loads(payload)
                    payload = json.dumps(m.mutate_json(obj)).encode()
                except ValueError:
                    payload = m.mutate(payload, ())
            else:
                payload = m.mutate(payload, ())
        for _ in range(copies):
            writer.add_message(
                channels[channel.id], message.log_time, payload, message.publish_time
            )
    writer.finish()
    return out.getvalue()


def _ft_csv(data: bytes, workdir: Path) -> Any:
    from spectratac.ft.csvfile import CsvFTSensor

    path = _write(workdir, "input.csv", data)
    with CsvFTSensor.connect(f"csv://{path}", timeout=1.0, buffer_size=1 << 16) as ft:
        return ft.info


# ---------------------------------------------------------------------- F/T streams
def _bota(data: bytes, workdir: Path) -> Any:
    from spectratac.ft import botaframe
    from spectratac.ft.bota import BotaSensor, plausible_limits
    from spectratac.ft.records import FTInfo
    from spectratac.ft.sequence import SequenceTracker, Unwrapper

    parser = botaframe.FrameParser(plausible_limits(500.0, 10.0))
    sensor = BotaSensor("bota://fuzz", FTInfo("bota", rate_hz=1000.0), timeout=1, buffer_size=8)
    sensor._unwrap = Unwrapper(32)
    sensor._tracker = SequenceTracker(sensor.stats)
    sensor._t0_us = None
    step = 1 + (len(data) * 5) % 113
    rows = 0
    for at in range(0, len(data), step):
        frames = parser.feed(data[at : at + step])
        if len(frames):
            out = sensor._records(frames, np.zeros(len(frames)))
            assert np.isfinite(out["wrench"]).all()
            rows += len(out)
    assert parser.frames + parser.implausible >= rows
    return rows


def _netft(data: bytes, workdir: Path) -> Any:
    from spectratac.ft import rdt
    from spectratac.ft.netft import NetFTSensor
    from spectratac.ft.records import FTInfo

    with contextlib.suppress(SpectraTacError):
        rdt.decode_request(data[: rdt.REQUEST_SIZE])
    with contextlib.suppress(SpectraTacError):
        rdt.decode_records(data)
    # The driver's packet path: the input cut into packets at lengths its first bytes give.
    info = FTInfo("netft", rate_hz=float(1 + data[0] % 3) * 500 if data else 0.0)
    sensor = NetFTSensor("netft://fuzz", info, timeout=1, buffer_size=8)
    sensor._setup(socket.socket(socket.AF_INET, socket.SOCK_DGRAM), "realtime", None)
    try:
        packets, pos, i = [], 0, 0
        while pos < len(data):
            size = rdt.RECORD_SIZE * (1 + data[i % len(data)] % 4) - (data[i % len(data)] % 9 == 0)
            packets.append(data[pos : pos + size])
            pos += size
            i += 1
        rows = sensor._parse(packets, [float(k) for k in range(len(packets))])
        return len(rows)
    finally:
        sensor._sock.close()


# ---------------------------------------------------------------------- URLs
def _sim_url(data: bytes, workdir: Path) -> Any:
    from spectratac.sim.url import parse_sim_url

    return parse_sim_url(data.decode("utf-8", "replace"))


def _ft_url(data: bytes, workdir: Path) -> Any:
    """Options of every F/T scheme: csv:// on a fixed valid file, bota:// on a port that does
    not exist (the options are checked before the port is opened); hosts and paths are
    fixed so no input can reach the network or another file."""
    from spectratac.ft import open_ft

    query = data.decode("utf-8", "replace").replace("#", "")
    csv = workdir / "ft_url.csv"
    if not csv.exists():
        csv.write_bytes(seeds.ft_csv()[0])
    for base in (f"csv://{csv}", "bota:///nonexistent/ttyFUZZ"):
        with contextlib.suppress(SpectraTacError):
            open_ft(f"{base}?{query}", timeout=0.5, buffer_size=16).close()
    return query


def _device_url(data: bytes, workdir: Path) -> Any:
    """Device URL dispatch: sim:// (the simulated device, opened and closed) and unknown
    schemes; port paths and pyserial's schemes would open real ports or sockets, so inputs
    naming them are passed over."""
    from spectratac.device.transport import _pyserial_knows, open_transport

    url = data.decode("utf-8", "replace")
    try:
        scheme = urlsplit(url).scheme
    except ValueError:
        scheme = ""
    if len(scheme) <= 1 or (scheme != "sim" and _pyserial_knows(scheme)):
        return None
    transport = open_transport(url)
    transport.close()
    return scheme


# ---------------------------------------------------------------------- the live server
def _live_ws_message(data: bytes, workdir: Path) -> Any:
    from spectratac.apps.live.inbound import parse

    return parse(data.decode("utf-8", "replace"))


LIVE_STATUSES = {200, 304, 307, 400, 403, 404, 405, 413, 415}


def _live_http(data: bytes, workdir: Path) -> Any:
    """One raw request through the live server's ASGI app (Guard included) on a stand-in
    session: every answer is one of LIVE_STATUSES, never an exception; a save is made only
    with the page's token, from the served address."""
    import asyncio

    from spectratac.apps.live.server import Hub, create_app

    from tests.apps.live.fake_session import FakeSession

    head, _, body = data.partition(b"\r\n\r\n")
    request, *lines = head.decode("latin-1").split("\r\n")
    parts = request.split(" ")
    method, target = [*parts, "", ""][:2]
    path, _, query = target.partition("?")
    headers = [
        (k.strip().lower().encode("latin-1"), v.strip().encode("latin-1"))
        for k, sep, v in (line.partition(":") for line in lines)
        if sep and k.strip()
    ]
    session = FakeSession()
    app = create_app(session, Hub(), port=8765, token="T")  # type: ignore[arg-type]
    scope = {"type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1",
             "method": method.upper() or "GET", "scheme": "http", "path": "/" + path.lstrip("/"),
             "raw_path": path.encode("latin-1"), "query_string": query.encode("latin-1"),
             "root_path": "", "headers": headers, "client": ("127.0.0.1", 1),
             "server": ("127.0.0.1", 8765)}  # fmt: skip
    sent: list[dict[str, Any]] = []
    chunks = [body[i : i + 1024] for i in range(0, len(body), 1024)] or [b""]

    async def receive() -> dict[str, Any]:
        if chunks:
            chunk = chunks.pop(0)
            return {"type": "http.request", "body": chunk, "more_body": bool(chunks)}
        return {"type": "http.disconnect"}

    async def send(message: dict[str, Any]) -> None:
        sent.append(message)

    asyncio.run(app(scope, receive, send))
    status = next(m["status"] for m in sent if m["type"] == "http.response.start")
    if status not in LIVE_STATUSES:
        raise AssertionError(f"the live server answered {status}")
    if session.saves:
        allowed = {b"127.0.0.1:8765", b"localhost:8765"}
        tokens = [v for k, v in headers if k == b"x-spectratac-token"]
        hosts = [v for k, v in headers if k == b"host"]
        if tokens != [b"T"] or len(hosts) != 1 or hosts[0] not in allowed:
            raise AssertionError(f"a save was made with tokens {tokens} from hosts {hosts}")
    return status


TARGETS: dict[str, Target] = {
    t.name: t
    for t in [
        Target(
            "protocol_stream",
            lambda d: seeds.protocol_frames(),
            _protocol_stream,
            _reframe,
            per_second=16000,
            weight=1.0,
        ),
        Target(
            "protocol_frame",
            lambda d: seeds.protocol_frames(),
            _protocol_frames,
            _reframe,
            per_second=50000,
            weight=0.5,
        ),
        Target("stac_file", seeds.stac_files, _stac, _zip, per_second=500),
        Target("dataset_npz", seeds.dataset_files, _dataset, _zip, per_second=800),
        Target(
            "generic_table",
            seeds.generic_tables,
            _generic_table,
            lambda m, d, p: _zip(m, d, p) if d[:2] == b"PK" else _text(m, d, p),
            per_second=1000,
        ),
        Target("recording_mcap", seeds.recordings, _recording, _mcap, per_second=500),
        Target("ft_csv", lambda d: seeds.ft_csv(), _ft_csv, _text, per_second=1200),
        Target("bota_stream", lambda d: seeds.bota_streams(), _bota, _bytes, per_second=1600),
        Target("netft_rdt", lambda d: seeds.rdt_packets(), _netft, _bytes, per_second=12000),
        Target(
            "sim_url",
            lambda d: seeds.sim_urls(),
            _sim_url,
            _text,
            per_second=50000,
            weight=0.3,
            allowed=(ValueError,),
        ),
        Target(
            "ft_url", lambda d: seeds.ft_url_queries(), _ft_url, _text, per_second=2000, weight=0.5
        ),
        Target(
            "device_url",
            lambda d: seeds.sim_urls(),
            _device_url,
            _text,
            per_second=80,
            weight=0.5,
            memory_base=256 << 20,  # a sim:// world builds its twin (~90 MB)
        ),
        Target(
            "live_ws_message",
            lambda d: seeds.live_ws_messages(),
            _live_ws_message,
            _text,
            per_second=20000,
            weight=0.3,
        ),
        Target(
            "live_http", lambda d: seeds.live_http_requests(), _live_http, _text, per_second=300
        ),
    ]
}
