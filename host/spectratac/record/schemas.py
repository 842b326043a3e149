"""The channels any MCAP tool can read (FORMAT.md, "Decoded channels"): JSON schemas, and
the JSON messages built from the compact rows.

A recording keeps its compact channels (raw frames, batched F/T rows, batched ground
truth: exact and cheap, read by `spectratac.record.reader`) and writes each row once more,
decoded, on a channel with a JSON schema, so that Foxglove or any other MCAP tool plots it
without a plug-in (`/ft/wrench.force.z`, `/spectratac/counts.s0.IR`). Foxglove's
well-known schemas have no wrench, count or estimate type, hence JSON schemas. The live
Foxglove bridge (`spectratac.apps.foxglove_bridge`) serves the same messages.

Values that are not finite (an invalid estimate's NaN) become null: JSON has no NaN.

>>> import numpy as np
>>> from spectratac.ft import FT_RECORD
>>> row = np.zeros(1, FT_RECORD)
>>> row["wrench"] = [[0.5, 0.0, -2.25, 0.0, 0.0, 0.01]]
>>> msg = json.loads(wrench_messages(row)[0])
>>> msg["force"], msg["torque"]["z"]
({'x': 0.5, 'y': 0.0, 'z': -2.25}, 0.01)
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from spectratac.hardware.generated import vocabulary as vocab
from spectratac.protocol.bulk import payload_dtype
from spectratac.protocol.framing import HEADER
from spectratac.protocol.generated import messages as m
from spectratac.protocol.schema import Message
from spectratac.record.format import JSON_TOPIC_DOCS, LABELS

COUNTS = "/spectratac/counts"  # one message per SAMPLE frame: counts per sensor and channel
ESTIMATES = "/spectratac/estimates"  # one per estimate: the device's ESTIMATE, or the host's
WRENCH = "/ft/wrench"  # one per reference F/T sample
TRUTH = "/spectratac/truth"  # one per sample of a link with ground truth
DECODED_TOPICS = (COUNTS, ESTIMATES, WRENCH, TRUTH)

_NUMBER: dict[str, Any] = {"type": "number"}
_NULLABLE: dict[str, Any] = {"type": ["number", "null"]}
_INT: dict[str, Any] = {"type": "integer"}


def _vector(axes: str, item: dict[str, Any], unit: str) -> dict[str, Any]:
    return {
        "type": "object",
        "description": unit,
        "properties": {a: item for a in axes},
        "required": list(axes),
    }


def _object(title: str, description: str, props: dict[str, Any]) -> dict[str, Any]:
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": title,
        "description": description,
        "type": "object",
        "properties": props,
        "required": list(props),
    }


_SENSOR = {
    "type": "object",
    "description": "one VEML3328's counts (R, G, B, C = clear, IR) and its SENSOR_* status bits",
    "properties": {**{c: _INT for c in vocab.CHANNELS}, "status": _INT},
    "required": [*vocab.CHANNELS, "status"],
}

SCHEMAS: dict[str, dict[str, Any]] = {
    COUNTS: _object(
        "spectratac.RawCounts",
        "One SAMPLE: raw counts per sensor; device times in µs on the device clock (u32, "
        "they wrap after 71.6 min)",
        {
            "sequence": _INT,
            "t_start_us": _INT,
            "t_end_us": _INT,
            "step": {**_INT, "description": "LED step lit during the integration"},
            "config_id": _INT,
            **{f"s{i}": _SENSOR for i in range(vocab.N_SENSORS)},
        },
    ),
    ESTIMATES: _object(
        "spectratac.Estimate",
        "Force, torque and contact region decoded from one sample, by the device's model "
        "(source 'device') or the host's decoder (source 'host'); null: not decoded",
        {
            "source": {"enum": ["device", "host"]},
            "sequence": {**_INT, "description": "the sample's sample_seq (host: estimate index)"},
            "t_end_us": {**_INT, "description": "the sample's end, device µs"},
            "force": _vector("xyz", _NULLABLE, "N, board axes"),
            "torque": _vector("xyz", _NULLABLE, "N·m, board axes"),
            "region": {**_INT, "description": "1..9; 0 or -1: none"},
            "region_prob": _NULLABLE,
            "contact": {"type": "boolean"},
            "ood": {"type": "boolean"},
            "invalid": {"type": "boolean"},
        },
    ),
    WRENCH: _object(
        "spectratac.Wrench",
        "One reference F/T sample: force (N) and torque (N·m) in the F/T sensor's axes",
        {
            "sensor_time": {**_NUMBER, "description": "s, on the F/T sensor's own clock"},
            "sequence": {**_INT, "description": "unwrapped; a jump of k = k - 1 lost"},
            "force": _vector("xyz", _NUMBER, "N"),
            "torque": _vector("xyz", _NUMBER, "N·m"),
            "status": {**_INT, "description": "the device's status word, 0 = healthy"},
        },
    ),
    TRUTH: _object(
        "spectratac.GroundTruth",
        "The simulated scene's truth at the centre of one sample's window",
        {
            "sequence": _INT,
            "t_start_us": {**_INT, "description": "device µs, unwrapped"},
            "t_end_us": {**_INT, "description": "device µs, unwrapped"},
            "region": {**_INT, "description": "1..9 on a firm contact, else -1"},
            "in_contact": {"type": "boolean"},
            "press": {**_INT, "description": "index of the press under way, -1 between"},
            "position_mm": _vector("xy", _NUMBER, "mm, board axes"),
            "force_n": _vector("xyz", _NUMBER, "N: shear x, y and the normal load z"),
        },
    ),
}


_LABEL = {
    "source": {"type": "string", "description": "scene, guided, ..."},
    "index": _INT,
    "region": {**_INT, "description": "1..9; -1: none"},
    "t_start": {**_NULLABLE, "description": "host monotonic s"},
    "t_end": {**_NULLABLE, "description": "host monotonic s"},
}


def metadata_schema(topic: str) -> dict[str, Any]:
    """The JSON schema of one of the recording's JSON topics (format.JSON_TOPICS): an object
    with a title and description; labels list their main fields. New keys may be added."""
    title, what = JSON_TOPIC_DOCS[topic]
    schema: dict[str, Any] = {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": title,
        "description": f"{what} (spectratac/record/FORMAT.md)",
        "type": "object",
    }
    if topic == LABELS:
        schema["properties"] = _LABEL
    return schema


def schema_bytes(schema: dict[str, Any]) -> bytes:
    return json.dumps(schema, ensure_ascii=False).encode()


# ---------------------------------------------------------------------- how many
#: Rows per second of host time a decoded channel copies whole: every real sensor's rate
#: (the optical sensor's samples, a Bota's or a Net F/T's usual 1 kHz). Faster streams (an
#: accelerated simulation, a Net F/T at 7 kHz) get an even subset at this rate: one JSON
#: message costs tens of µs of the recorder's thread, and at 10 kHz that starved the F/T
#: reader of the very process recording it (the compact channels keep every row).
RATE_CAP_HZ = 1000.0


class RateCap:
    """A token bucket in rows: `take(n, host_time)` says which of a batch of `n` rows to
    copy, every one while the stream stays under `rate_hz` (bursts up to one second's
    worth), else an even subset (a stride) that keeps it there.

    >>> cap = RateCap(100.0)
    >>> len(range(50)[cap.take(50, 0.0)]), len(range(500)[cap.take(500, 1.0)])
    (50, 100)
    """

    def __init__(self, rate_hz: float = RATE_CAP_HZ) -> None:
        self.rate_hz = rate_hz
        self._tokens = rate_hz  # one second's worth to start with
        self._last: float | None = None

    def take(self, n: int, host_time: float) -> slice:
        if self._last is not None:
            elapsed = max(0.0, host_time - self._last)
            self._tokens = min(self.rate_hz, self._tokens + elapsed * self.rate_hz)
        self._last = host_time if self._last is None else max(self._last, host_time)
        if n <= self._tokens:
            self._tokens -= n
            return slice(None)
        allowed = max(1, int(self._tokens))
        stride = -(-n // allowed)  # ceil: at most `allowed` rows
        self._tokens = max(0.0, self._tokens - len(range(0, n, stride)))
        return slice(None, None, stride)


# ---------------------------------------------------------------------- frames -> rows
SAMPLE_TYPE, ESTIMATE_TYPE = m.Sample.TYPE_ID, m.Estimate.TYPE_ID
_SAMPLE_PAYLOAD, _ESTIMATE_PAYLOAD = payload_dtype(m.Sample), payload_dtype(m.Estimate)


def _rows(raws: list[bytes], message: type[Message], dtype: np.dtype) -> np.ndarray:
    """Payloads of decoded frames of one message type as rows; a frame of another minor
    version is fitted to this one's layout first (Message.unpack/pack)."""
    size = dtype.itemsize
    body = b"".join(
        r[HEADER.size : -4]
        if len(r) - HEADER.size - 4 == size
        else message.unpack(r[HEADER.size : -4]).pack()
        for r in raws
    )
    return np.frombuffer(body, dtype)


def split_frames(
    frames: Sequence[tuple[bytes, float]],
) -> tuple[np.ndarray, list[float], np.ndarray, list[float]]:
    """(SAMPLE payload rows, their host times, ESTIMATE payload rows, their host times) of
    decoded frames (header, payload, CRC); frames of other types are skipped."""
    samples, sample_t, estimates, estimate_t = [], [], [], []
    for raw, t in frames:
        kind = raw[2] if len(raw) > 2 else -1
        if kind == SAMPLE_TYPE:
            samples.append(raw)
            sample_t.append(t)
        elif kind == ESTIMATE_TYPE:
            estimates.append(raw)
            estimate_t.append(t)
    return (
        _rows(samples, m.Sample, _SAMPLE_PAYLOAD),
        sample_t,
        _rows(estimates, m.Estimate, _ESTIMATE_PAYLOAD),
        estimate_t,
    )


# ---------------------------------------------------------------------- rows -> messages
_ENCODER = json.JSONEncoder(separators=(",", ":"), allow_nan=False, ensure_ascii=False)


def _dump(obj: dict[str, Any]) -> bytes:
    return _ENCODER.encode(obj).encode()


# The per-sample messages are written at the sensor's and the F/T sensor's full rates:
# filled in by %-formatting (several times faster than building and encoding dicts). repr()
# of a finite float is valid JSON; rows with a non-finite value take the dict path.
_SENSOR_FMT = ",".join(f'"{c}":%d' for c in (*vocab.CHANNELS, "status"))  # counts order
_COUNTS_FMT = (
    '{"sequence":%d,"t_start_us":%d,"t_end_us":%d,"step":%d,"config_id":%d'
    + "".join(f',"s{i}":{{{_SENSOR_FMT}}}' for i in range(vocab.N_SENSORS))
    + "}"
)
_WRENCH_FMT = (
    '{"sensor_time":%r,"sequence":%d,"force":{"x":%r,"y":%r,"z":%r},'
    '"torque":{"x":%r,"y":%r,"z":%r},"status":%d}'
)
_TRUTH_FMT = (
    '{"sequence":%d,"t_start_us":%d,"t_end_us":%d,"region":%d,"in_contact":%s,"press":%d,'
    '"position_mm":{"x":%r,"y":%r},"force_n":{"x":%r,"y":%r,"z":%r}}'
)


def _finite(v: float) -> float | None:
    return v if math.isfinite(v) else None


def _xyz(values: Sequence[float], axes: str = "xyz") -> dict[str, float | None]:
    return {a: _finite(float(v)) for a, v in zip(axes, values, strict=True)}


def counts_messages(rows: np.ndarray) -> list[bytes]:
    """One COUNTS message per SAMPLE payload row."""
    n_channels = len(vocab.CHANNELS)
    cols = np.empty((len(rows), 5 + vocab.N_SENSORS * (n_channels + 1)), np.int64)
    cols[:, 0] = rows["sample_seq"]
    cols[:, 1] = rows["t_start_us"]
    cols[:, 2] = rows["t_end_us"]
    cols[:, 3] = rows["led_step"]
    cols[:, 4] = rows["config_id"]
    per_sensor = cols[:, 5:].reshape(len(rows), vocab.N_SENSORS, n_channels + 1)
    per_sensor[:, :, :n_channels] = rows["counts"]  # SAMPLE.counts: vocab.CHANNELS order
    per_sensor[:, :, n_channels] = rows["sensor_status"]
    fmt = _COUNTS_FMT
    return [(fmt % tuple(values)).encode() for values in cols.tolist()]


def device_estimate_messages(rows: np.ndarray) -> list[bytes]:
    """One ESTIMATES message per ESTIMATE payload row (source "device")."""
    bits = m.EstimateFlags
    out = []
    for seq, t1, flag, force, torque, region, prob in zip(
        rows["sample_seq"].tolist(),
        rows["t_end_us"].tolist(),
        rows["flags"].tolist(),
        rows["force"].tolist(),
        rows["torque"].tolist(),
        rows["region"].tolist(),
        rows["region_prob"].tolist(),
        strict=True,
    ):
        flags = {
            "contact": bool(flag & bits.EST_CONTACT),
            "ood": bool(flag & bits.EST_OOD),
            "invalid": bool(flag & bits.EST_INVALID),
        }
        out.append(estimate_message("device", seq, t1, force, torque, region, prob, **flags))
    return out


def estimate_message(
    source: str,
    sequence: int,
    t_end_us: int,
    force: Sequence[float | None],
    torque: Sequence[float | None],
    region: int,
    region_prob: float | None,
    *,
    contact: bool,
    ood: bool,
    invalid: bool,
) -> bytes:
    """One ESTIMATES message; None or NaN in force, torque or region_prob: not decoded."""

    def num(v: float | None) -> float:
        return math.nan if v is None else float(v)

    return _dump(
        {
            "source": source,
            "sequence": int(sequence),
            "t_end_us": int(t_end_us),
            "force": _xyz([num(v) for v in force]),
            "torque": _xyz([num(v) for v in torque]),
            "region": int(region),
            "region_prob": _finite(num(region_prob)),
            "contact": bool(contact),
            "ood": bool(ood),
            "invalid": bool(invalid),
        }
    )


def host_estimate_message(row: dict[str, Any]) -> bytes:
    """An ESTIMATES message (source "host") from a decoded row of the live page's history
    (`spectratac.apps.live.history.CSV_COLUMNS`: Fx..Tz, region, region_prob, flags)."""
    axes = vocab.FT_AXES
    return estimate_message(
        "host",
        int(row.get("key", 0)),
        round(float(row["device_time_s"]) * 1e6),
        [row.get(a) for a in axes[:3]],
        [row.get(a) for a in axes[3:]],
        int(row["region"]),
        row.get("region_prob"),
        contact=bool(row["contact"]),
        ood=bool(row["ood"]),
        invalid=bool(row["invalid"]),
    )


def wrench_messages(rows: np.ndarray) -> list[bytes]:
    """One WRENCH message per FT_RECORD row."""
    finite = np.isfinite(rows["wrench"]).all(axis=1) & np.isfinite(rows["sensor_time"])
    out = []
    for ok, t, seq, w, status in zip(
        finite.tolist(),
        rows["sensor_time"].tolist(),
        rows["sequence"].tolist(),
        rows["wrench"].tolist(),
        rows["status"].tolist(),
        strict=True,
    ):
        if ok:
            out.append((_WRENCH_FMT % (t, seq, *w, status)).encode())
        else:
            out.append(_dump({"sensor_time": _finite(t), "sequence": seq, "force": _xyz(w[:3]),
                              "torque": _xyz(w[3:]), "status": status}))  # fmt: skip
    return out


def truth_messages(rows: np.ndarray) -> list[bytes]:
    """One TRUTH message per GROUND_TRUTH_RECORD row."""
    finite = np.isfinite(rows["position_mm"]).all(axis=1) & np.isfinite(rows["force_n"]).all(1)
    out = []
    for ok, seq, t0, t1, region, contact, press, pos, force in zip(
        finite.tolist(),
        rows["sequence"].tolist(),
        rows["t_start_us"].tolist(),
        rows["t_end_us"].tolist(),
        rows["region"].tolist(),
        rows["in_contact"].tolist(),
        rows["press"].tolist(),
        rows["position_mm"].tolist(),
        rows["force_n"].tolist(),
        strict=True,
    ):
        if ok:
            flag = "true" if contact else "false"
            out.append((_TRUTH_FMT % (seq, t0, t1, region, flag, press, *pos, *force)).encode())
        else:
            out.append(_dump({"sequence": seq, "t_start_us": t0, "t_end_us": t1,
                              "region": region, "in_contact": contact, "press": press,
                              "position_mm": _xyz(pos, "xy"), "force_n": _xyz(force)}))  # fmt: skip
    return out
