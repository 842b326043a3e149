"""The channels any MCAP tool can read (FORMAT.md, "Decoded channels"): JSON schemas, and
the JSON messages built from the compact rows.

A recording keeps its compact channels (raw frames, batched F/T rows, batched ground
truth: exact and cheap, read by `spectratac.record.reader`) and writes each row once more,
decoded, on a channel with a JSON schema, so that Foxglove or any other MCAP tool plots it
without a plug-in (`/ft/wrench.force.z`, `/spectratac/counts.s0.IR`). Foxglove's
well-known schemas have no wrench, count or estimate type, hence JSON schemas. The live
Foxglove bridge (`spectratac.apps.foxglove_bridge`) serves the same messages.

Every schema stays inside what Foxglove/Lichtblick parses (FORMAT.md, "What Foxglove
shows"): one `type` per field, `properties` on every object, no `null`, no bare `enum`.
JSON has no NaN, so a value that is not finite (an invalid estimate's NaN) is left out of
its object, and a boolean beside it says whether the numbers are there (`decoded`, `valid`).

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
from spectratac.record.format import (
    CONFIG,
    END,
    EPOCH,
    FT_INFO,
    INFO,
    JSON_TOPIC_DOCS,
    LABELS,
    SESSION,
    STATS,
    TIME_SYNC,
)

COUNTS = "/spectratac/counts"  # one message per SAMPLE frame: counts per sensor and channel
ESTIMATES = "/spectratac/estimates"  # one per estimate: the device's ESTIMATE, or the host's
WRENCH = "/ft/wrench"  # one per reference F/T sample
TRUTH = "/spectratac/truth"  # one per sample of a link with ground truth
DECODED_TOPICS = (COUNTS, ESTIMATES, WRENCH, TRUTH)

_NUMBER: dict[str, Any] = {"type": "number"}
_INT: dict[str, Any] = {"type": "integer"}
_BOOL: dict[str, Any] = {"type": "boolean"}
_STRING: dict[str, Any] = {"type": "string"}
_ABSENT = "; an axis that is not finite is absent"


def _vector(axes: str, unit: str) -> dict[str, Any]:
    """x, y, z numbers; not required: a value that is not finite is left out (no NaN in JSON)."""
    return {"type": "object", "description": unit, "properties": dict.fromkeys(axes, _NUMBER)}


def _object(
    title: str, description: str, props: dict[str, Any], optional: Sequence[str] = ()
) -> dict[str, Any]:
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": title,
        "description": description,
        "type": "object",
        "properties": props,
        "required": [k for k in props if k not in optional],
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
        "(source 'device') or the host's decoder (source 'host'); `decoded` false: no "
        "numbers (every axis absent)",
        {
            "source": {**_STRING, "description": "'device' or 'host'"},
            "sequence": {**_INT, "description": "the sample's sample_seq (host: estimate index)"},
            "t_end_us": {**_INT, "description": "the sample's end, device µs"},
            "decoded": {
                **_BOOL,
                "description": "a model decoded the sample: the axes it "
                "estimates hold numbers (the others are absent)",
            },
            "force": _vector("xyz", "N, board axes" + _ABSENT),
            "torque": _vector("xyz", "N·m, board axes" + _ABSENT),
            "region": {**_INT, "description": "1..9; 0 or -1: none"},
            "region_prob": {**_NUMBER, "description": "0..1; absent when not finite"},
            "contact": _BOOL,
            "ood": _BOOL,
            "invalid": _BOOL,
        },
        optional=("region_prob",),
    ),
    WRENCH: _object(
        "spectratac.Wrench",
        "One reference F/T sample: force (N) and torque (N·m) in the F/T sensor's axes",
        {
            "sensor_time": {**_NUMBER, "description": "s, on the F/T sensor's own clock"},
            "sequence": {**_INT, "description": "unwrapped; a jump of k = k - 1 lost"},
            "valid": {**_BOOL, "description": "every value finite (else they are absent)"},
            "force": _vector("xyz", "N" + _ABSENT),
            "torque": _vector("xyz", "N·m" + _ABSENT),
            "status": {**_INT, "description": "the device's status word, 0 = healthy"},
        },
        optional=("sensor_time",),
    ),
    TRUTH: _object(
        "spectratac.GroundTruth",
        "The simulated scene's truth at the centre of one sample's window",
        {
            "sequence": _INT,
            "t_start_us": {**_INT, "description": "device µs, unwrapped"},
            "t_end_us": {**_INT, "description": "device µs, unwrapped"},
            "region": {**_INT, "description": "1..9 on a firm contact, else -1"},
            "in_contact": _BOOL,
            "press": {**_INT, "description": "index of the press under way, -1 between"},
            "valid": {**_BOOL, "description": "every value finite (else they are absent)"},
            "position_mm": _vector("xy", "mm, board axes" + _ABSENT),
            "force_n": _vector("xyz", "N: shear x, y and the normal load z" + _ABSENT),
        },
    ),
}


# The fields of the JSON topics that always have one type (FORMAT.md, "JSON messages");
# the messages hold more (nested, or null when unknown): Foxglove shows those in its Raw
# Message panel, and its Plot panel offers the fields listed here.
_HOST_S = {**_NUMBER, "description": "host monotonic s; absent when not known"}
_METADATA_FIELDS: dict[str, dict[str, Any]] = {
    SESSION: {
        "format": _STRING,
        "version": _INT,
        "library_version": _STRING,
        "started_unix": _NUMBER,
        "unix_minus_monotonic_ns": _INT,
    },
    INFO: {"unit_id": _STRING, "firmware": _STRING, "protocol": _STRING},
    CONFIG: {"config_id": _INT},
    TIME_SYNC: {},
    STATS: {"samples": _INT, "ft_samples": _INT},
    END: {"stopped_by": _STRING, "samples": _INT},
    FT_INFO: {"url": _STRING},
    LABELS: {
        "source": {**_STRING, "description": "scene, guided, ..."},
        "index": _INT,
        "region": {**_INT, "description": "1..9; -1: none"},
        "t_start": _HOST_S,
        "t_end": _HOST_S,
    },
    EPOCH: {
        "epoch": _INT,
        "reason": {**_STRING, "description": "'start' or 'reconnect'"},
        "host_time": _NUMBER,
    },
}


def metadata_schema(topic: str) -> dict[str, Any]:
    """The JSON schema of one of the recording's JSON topics (format.JSON_TOPICS): an object
    with a title, a description and the fields that always have one type (none required,
    none null: a label's unknown time is absent). New keys may be added."""
    title, what = JSON_TOPIC_DOCS[topic]
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": title,
        "description": f"{what}; more fields in spectratac/record/FORMAT.md",
        "type": "object",
        "properties": _METADATA_FIELDS[topic],
    }


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

    def take(self, n: int, host_time: float, first_time: float | None = None) -> slice:
        """`first_time`: the batch's first row's host time, when a batch spans more than a
        moment (a clip written at once): the bucket then also holds the span's worth, so a
        1 kHz sensor's ten seconds are copied whole."""
        span = 0.0 if first_time is None else max(0.0, host_time - first_time)
        if self._last is None and first_time is not None:
            self._last = first_time
        if self._last is not None:
            elapsed = max(0.0, host_time - self._last)
            room = self.rate_hz * (1.0 + span)  # one second's burst, plus the batch's span
            self._tokens = min(room, self._tokens + elapsed * self.rate_hz)
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
    '{"sensor_time":%r,"sequence":%d,"valid":true,"force":{"x":%r,"y":%r,"z":%r},'
    '"torque":{"x":%r,"y":%r,"z":%r},"status":%d}'
)
_TRUTH_FMT = (
    '{"sequence":%d,"t_start_us":%d,"t_end_us":%d,"region":%d,"in_contact":%s,"press":%d,'
    '"valid":true,"position_mm":{"x":%r,"y":%r},"force_n":{"x":%r,"y":%r,"z":%r}}'
)


def _xyz(values: Sequence[float | None], axes: str = "xyz") -> dict[str, float]:
    """The finite values by axis; one that is None or not finite is left out (no NaN in JSON)."""
    return {
        a: float(v) for a, v in zip(axes, values, strict=True) if v is not None and math.isfinite(v)
    }


def _finite_items(**values: float | None) -> dict[str, float]:
    return {k: float(v) for k, v in values.items() if v is not None and math.isfinite(v)}


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
    """One ESTIMATES message; None or NaN in force, torque or region_prob: not decoded
    (left out; `decoded` says whether any axis holds a number: a model decoded it)."""
    f, t = _xyz(force), _xyz(torque)
    return _dump(
        {
            "source": source,
            "sequence": int(sequence),
            "t_end_us": int(t_end_us),
            "decoded": bool(f or t),
            "force": f,
            "torque": t,
            "region": int(region),
            **_finite_items(region_prob=region_prob),
            "contact": bool(contact),
            "ood": bool(ood),
            "invalid": bool(invalid),
        }
    )


def host_estimate_message(row: dict[str, Any]) -> bytes:
    """An ESTIMATES message (source "host") from a decoded row of the live page's history
    (`spectratac.apps.live.history.CSV_COLUMNS`: Fx..Tz, region, region_prob, flags). A row
    no model decoded (region and flags None) gives a message that says so: `decoded` false,
    region -1, `invalid` true."""
    axes = vocab.FT_AXES
    region = row.get("region")
    return estimate_message(
        "host",
        int(row.get("key", 0)),
        round(float(row["device_time_s"]) * 1e6),
        [row.get(a) for a in axes[:3]],
        [row.get(a) for a in axes[3:]],
        -1 if region is None else int(region),
        row.get("region_prob"),
        contact=bool(row.get("contact")),
        ood=bool(row.get("ood")),
        invalid=region is None or bool(row.get("invalid")),
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
            out.append(_dump({**_finite_items(sensor_time=t), "sequence": seq, "valid": False,
                              "force": _xyz(w[:3]), "torque": _xyz(w[3:]),
                              "status": status}))  # fmt: skip
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
                              "valid": False, "position_mm": _xyz(pos, "xy"),
                              "force_n": _xyz(force)}))  # fmt: skip
    return out
