"""Valid inputs of every reader, made by the project's own writers: the mutation loop starts
from these, so mutated inputs get past the first check of each format."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
from spectratac.ft import botaframe, rdt

REPO = Path(__file__).resolve().parents[2]
VECTORS = REPO / "protocol" / "vectors"


def protocol_frames() -> list[bytes]:
    """The golden vectors' wire bytes (valid and damaged), one seed each plus a stream."""
    wires = [
        bytes.fromhex(json.loads(p.read_text())["hex"]) for p in sorted(VECTORS.glob("*.json"))
    ]
    return [*wires, b"".join(wires), b"\x00" + b"".join(wires[12:15]) * 4]


def bota_streams() -> list[bytes]:
    n = 12
    k = np.arange(n)
    forces = np.stack([k * 0.5, -k, k * 2.0, k * 0.01, -k * 0.02, k * 0.03], axis=1)
    wire = botaframe.encode_frames(np.zeros(n), forces, k * 1000 + 500, np.full(n, 30.0))
    return [wire, b"r,0,C,0\r\n" + wire[: 37 * 5], wire[37 * 3 :] + b"App Init\r\n" + wire]


def rdt_packets() -> list[bytes]:
    n = 6
    k = np.arange(1, n + 1)
    counts = np.stack([k * 1000, -k, k * 7, k, -k * 3, k * 11], axis=1)
    records = rdt.encode_records(k, k * 4, np.zeros(n), counts)
    return [records, records[: rdt.RECORD_SIZE], rdt.encode_request(rdt.CMD_START_REALTIME, 0)]


def ft_csv() -> list[bytes]:
    rows = ["t,Fx,Fy,Fz,Tx,Ty,Tz,host_time,sequence,status"]
    rows += [f"{i / 1000},{i},{-i},{2 * i},0.1,0.2,0.3,{5 + i / 1000},{i},0" for i in range(8)]
    plain = ["time,fx,fy,fz,mx,my,mz"] + [f"{i * 0.01},1,2,3,4,5,6" for i in range(5)]
    return ["\n".join(rows).encode(), "\n".join(plain).encode()]


def _dataset() -> object:
    from spectratac.dataset import FT_NAMES, SPECTRATAC_INPUTS, Dataset

    rng = np.random.default_rng(0)
    n = 40
    return Dataset.generic(
        rng.uniform(1000, 30000, (n, 12)),
        rng.normal(size=(n, 6)),
        SPECTRATAC_INPUTS,
        FT_NAMES,
        region=rng.integers(-1, 9, n),
    )


def dataset_files(workdir: Path) -> list[bytes]:
    path = _dataset().save(workdir / "seed_dataset.npz")  # type: ignore[attr-defined]
    return [path.read_bytes()]


def stac_files(workdir: Path) -> list[bytes]:
    from spectratac.decode.decoder import Decoder

    ds = _dataset()
    seeds = []
    for i, (features, targets) in enumerate(
        [("generic", ("Fz", "region")), ("generic", ("Fx", "Fy", "Fz", "contact"))]
    ):
        dec = Decoder.untrained(ds, features=features, targets=targets, seed=i)  # type: ignore[arg-type]
        seeds.append(dec.save(workdir / f"seed_{i}.stac").read_bytes())
    return seeds


def generic_tables(workdir: Path) -> list[bytes]:
    """CSV text and a column .npz of a generic (any sensor) table."""
    rng = np.random.default_rng(1)
    n = 10
    cols = {
        "t": np.arange(n) * 0.01,
        "ch0": rng.uniform(0, 1, n),
        "ch1": rng.uniform(0, 1, n),
        "Fz": rng.normal(size=n),
        "Mx": rng.normal(size=n),
        "label": np.array(["a", "b"] * (n // 2)),
    }
    text = ",".join(cols) + "\n"
    text += "\n".join(",".join(str(c[i]) for c in cols.values()) for i in range(n))
    buf = io.BytesIO()
    np.savez(buf, **cols)
    return [text.encode(), buf.getvalue()]


def recordings(workdir: Path) -> list[bytes]:
    from spectratac.sim.synthetic_recording import write_twin_recording
    from spectratac.twin import Scene, generate_session

    scene = Scene.single_press(x=0.0, normal_n=5.0)
    session = generate_session(scene, seed=1, ft_rate_hz=200)
    path = write_twin_recording(workdir / "seed.mcap", session, scene, "press")
    return [path.read_bytes()]


def sim_urls() -> list[bytes]:
    return [
        b"sim://?scene=press&seed=3&speed=max",
        b"sim://?scene=tour&seed=1&speed=2.5&absent=1,2",
        b"sim://idle?seed=7",
        b"sim://?scene=press&seed=2&speed=5&ft=bota",
    ]


def ft_url_queries() -> list[bytes]:
    return [
        b"baud=460800&rate=1000&sinc=64&configure=0&force_range=500&torque_range=10",
        b"cpf=1000000&cpt=1000000&rate=1000&seq_rate=7000&mode=buffered&http_port=80",
        b"rate=100&realtime=0",
    ]


def live_ws_messages() -> list[bytes]:
    """What the live page sends its server (spectratac.apps.live.inbound)."""
    return [
        b'{"type": "latency", "values": [5.25, 6.0, 12, 0.5]}',
        b'{"type": "pong", "id": 17}',
        b'{"type": "snake_restart"}',
    ]


def live_http_requests() -> list[bytes]:
    """Requests the live page makes, as raw HTTP/1.1 (port 8765; the token is "T")."""
    host = b"Host: 127.0.0.1:8765\r\n"
    return [
        b"GET / HTTP/1.1\r\n" + host + b"\r\n",
        b"GET /api/stats HTTP/1.1\r\n" + host + b"Origin: http://127.0.0.1:8765\r\n\r\n",
        b"GET /static/app.js HTTP/1.1\r\n" + host + b"\r\n",
        b"POST /api/save HTTP/1.1\r\n" + host + b"Content-Type: application/json\r\n"
        b"X-SpectraTac-Token: T\r\nOrigin: http://localhost:8765\r\n\r\n"
        b'{"seconds": 10, "format": "mcap"}',
    ]
