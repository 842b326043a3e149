"""A recording made without recording: a twin session (spectratac.twin.generate_session)
encoded as the real device's SAMPLE frames and the reference sensor's FT_RECORD rows, with
arrival latencies, TIME_SYNC exchanges, ground truth, scene labels and chunk flushes in the
order the recorder writes them. An hour of calibration data takes seconds; benchmarks and
tests of the dataset builder use it, and the builder cannot tell it from a `sim://`
recording.

>>> import tempfile
>>> from spectratac.twin import Scene, generate_session
>>> scene = Scene.single_press(x=0.0, normal_n=5.0)
>>> session = generate_session(scene, seed=1, ft_rate_hz=200)
>>> path = write_twin_recording(tempfile.mkdtemp() + "/t.mcap", session, scene, "press")
>>> from spectratac.record.reader import read_recording
>>> rec = read_recording(path)
>>> len(rec.frames) == len(session), len(rec.ft) == len(session.ft_t), rec.labels[0]["region"]
(True, True, 5)
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from spectratac.device.link_info import LinkInfo
from spectratac.protocol.bulk import SAMPLE_DTYPE
from spectratac.protocol.framing import crc32c
from spectratac.protocol.generated import messages as m
from spectratac.record.format import (
    CONFIG,
    END,
    FT_INFO,
    GROUND_TRUTH_RECORD,
    INFO,
    LABELS,
    TIME_SYNC,
)
from spectratac.record.labels import LabelQueue
from spectratac.record.writer import RecordingWriter
from spectratac.sim.ground_truth import SceneTruth
from spectratac.twin.generate import Session
from spectratac.twin.scene_model import Scene

_HEADER = [("major", "u1"), ("minor", "u1"), ("type", "u1"), ("seq", "<u2")]
_FRAME = np.dtype([*_HEADER, *SAMPLE_DTYPE.descr, ("crc", "<u4")])
_EXCHANGES = 8


def sample_frames(session: Session, config_id: int = 1) -> list[bytes]:
    """The session's samples as decoded SAMPLE frames (header, payload, CRC-32C)."""
    n = len(session)
    rows = np.zeros(n, dtype=_FRAME)
    rows["major"], rows["minor"] = m.PROTOCOL_MAJOR, m.PROTOCOL_MINOR
    rows["type"] = m.Sample.TYPE_ID
    rows["seq"] = np.arange(n) & 0xFFFF
    rows["sample_seq"] = np.arange(n)
    rows["t_start_us"] = np.rint(session.t_start * 1e6).astype(np.int64) & 0xFFFF_FFFF
    rows["t_end_us"] = np.rint(session.t_end * 1e6).astype(np.int64) & 0xFFFF_FFFF
    rows["led_step"] = session.step
    rows["config_id"] = config_id
    rows["sensor_status"] = np.where(session.saturated, int(m.SensorStatus.SENSOR_SATURATED), 0)
    rows["counts"] = session.counts
    size = _FRAME.itemsize
    buf = rows.tobytes()
    out = []
    for i in range(n):
        body = buf[i * size : (i + 1) * size - 4]
        out.append(body + crc32c(body).to_bytes(4, "little"))
    return out


def write_twin_recording(
    path: str | Path,
    session: Session,
    scene: Scene,
    scene_name: str,
    *,
    scene_params: dict[str, str] | None = None,
    speed: float = 1.0,
    epoch: float = 1000.0,
    latency_s: float = 1e-3,
    ft_offset: float = 0.05,
    ft_drift: float = 1e-4,
    sync_every_s: float = 5.0,
    frames: list[bytes] | None = None,
    decoded: bool = True,
) -> Path:
    """Write `session` (generated from `scene`, called `scene_name` in sim:// URLs) as a
    recording of a paced simulation at `speed` whose scene clock started at host `epoch`.
    Arrivals lag by `latency_s` plus exponential jitter; the F/T clock reads
    ft_offset + (1 + ft_drift) x scene time. `decoded=False`: the compact channels alone
    (RecordingWriter). Returns the path."""
    from spectratac.ft import FT_RECORD

    rng = np.random.default_rng(session.seed)
    params = dict(scene_params or {})
    url = f"sim://?scene={scene_name}&seed={session.seed}&speed={speed:g}&ft=bota" + "".join(
        f"&{k}={v}" for k, v in params.items()
    )

    def host(scene_t: np.ndarray) -> np.ndarray:
        return epoch + scene_t / speed + latency_s + rng.exponential(latency_s / 5, scene_t.shape)

    frame_host = host(session.t_end)
    ft = np.zeros(len(session.ft_t), dtype=FT_RECORD)
    ft["sensor_time"] = ft_offset + (1.0 + ft_drift) * session.ft_t
    ft["host_time"] = np.maximum.accumulate(host(session.ft_t))
    ft["sequence"] = np.arange(len(ft))
    ft["wrench"] = session.ft
    sim = {
        "scene": scene_name,
        "seed": session.seed,
        "speed": speed,
        "params": params,
        "absent": [],
        "epoch": epoch,
        "duration_s": scene.duration_s,
        "presses": len(scene.presses),
    }
    link = LinkInfo(clock_scale=speed, paired_ft_url=url, ground_truth=True)
    meta: dict[str, Any] = {
        "url": url,
        "ft_url": url,
        "labels": "scene",
        "link": link.as_dict(),
        "truth": sim,
    }
    t0 = epoch - 0.5 / speed
    writer = RecordingWriter(
        path, meta | {"synthetic": True}, ft_dtype=FT_RECORD, ground_truth=True, decoded=decoded
    )
    writer.json(INFO, _info(session.seed), t0)
    writer.json(FT_INFO, {"url": url, "kind": "bota", "model": "synthetic", "rate_hz": 0.0}, t0)
    cfg = session.config
    config = {
        "integration_ms": int(cfg.integration_ms),
        "gain": float(cfg.gain),
        "digital_gain": int(cfg.dg),
        "sensitivity": "low" if cfg.sens_low else "high",
        "leds": np.rint(session.led_steps * 1000).astype(int).tolist(),
        "settle_us": 0,
    }
    writer.json(CONFIG, {"config_id": 1, "request": config, "reply": {}, "config": config}, t0)
    truth = SceneTruth(scene, sim)
    truth_rows = ground_truth_rows(session, truth)
    labeler = LabelQueue(truth.label_events())
    frames = frames if frames is not None else sample_frames(session)
    end_s = float(session.t_end[-1]) if len(session) else 0.0
    second = 0
    next_sync = 0.0
    while second <= end_s:
        lo, hi = second, second + 1.0
        if lo >= next_sync:
            writer.json(TIME_SYNC, _exchanges(lo, epoch, speed), epoch + lo / speed)
            next_sync += sync_every_s
        i0, i1 = np.searchsorted(session.t_end, [lo, hi], side="left")
        if i1 > i0:
            writer.ground_truth(truth_rows[i0:i1], float(frame_host[i0]))
        writer.frames(list(zip(frames[i0:i1], frame_host[i0:i1].tolist(), strict=True)))
        j0, j1 = np.searchsorted(session.ft_t, [lo, hi], side="left")
        if j1 > j0:
            writer.ft(ft[j0:j1])
        for event in labeler.due(hi):
            writer.json(LABELS, event, event["t_end"])
        writer.flush()
        second += 1
    writer.json(TIME_SYNC, _exchanges(end_s, epoch, speed), epoch + end_s / speed)
    for event in labeler.started(end_s):
        writer.json(LABELS, event, epoch + end_s / speed)
    writer.json(END, {"stopped_by": "duration", "error": None, "samples": len(session)}, epoch)
    writer.close()
    return Path(path)


def ground_truth_rows(session: Session, truth: SceneTruth) -> np.ndarray:
    """GROUND_TRUTH_RECORD rows of the session's samples, as the recorder writes them."""
    rows = np.zeros(len(session), GROUND_TRUTH_RECORD)
    rows["sequence"] = np.arange(len(session))
    rows["t_start_us"] = np.rint(session.t_start * 1e6).astype(np.int64)
    rows["t_end_us"] = np.rint(session.t_end * 1e6).astype(np.int64)
    contact = truth.contact((rows["t_start_us"] + rows["t_end_us"]) / 2e6)
    for name in contact.dtype.names or ():
        rows[name] = contact[name]
    return rows


def _exchanges(scene_t: float, epoch: float, speed: float) -> dict[str, Any]:
    """Symmetric 100 µs round trips: the device answers halfway."""
    out = []
    for i in range(_EXCHANGES):
        sent = epoch + scene_t / speed + i * 1e-3
        device_us = round(((sent + 50e-6) - epoch) * speed * 1e6)
        out.append(
            {
                "host_sent": sent,
                "device_rx_us": device_us,
                "device_tx_us": device_us,
                "host_received": sent + 100e-6,
            }
        )
    return {"exchanges": out}


def _info(seed: int) -> dict[str, Any]:
    from spectratac.record.describe import info_dict

    uid = bytes(np.random.default_rng(seed).integers(0, 256, 12, dtype=np.uint8))
    info = m.Info(
        protocol_major=m.PROTOCOL_MAJOR,
        protocol_minor=m.PROTOCOL_MINOR,
        definition_hash=m.DEFINITION_HASH,
        firmware_version=(0, 0, 0),
        build_id="synthetic",
        device_uid=uid,
        board="twin-synthetic",
        sensor_count=3,
        sensor_present=7,
        channels_per_sensor=5,
    )
    return info_dict(info)
