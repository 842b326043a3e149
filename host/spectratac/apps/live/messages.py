"""The JSON messages the live page receives, built from one estimate and its raw sample.

``estimate`` (one per sensor sample)::

    {"type": "estimate", "seq": 41, "t": 2.05, "arrival_ms": 1.7e12,
     "force": [Fx, Fy, Fz], "torque": [Tx, Ty, Tz],           N and N·m, null if not decoded
     "region": 2, "p": 0.97, "contact": true, "ood": false, "invalid": false,
     "no_rest": false,                       the drift baseline has not yet seen rest (Tare)
     "step": 0, "counts": [15 counts: s0 R G B C IR, s1 ..., s2 ...],
     "saturated": [15 bools], "dark": [3 bools: each sensor's Clear below the dark level],
     "status": [3 SENSOR_* bit sets: saturated 1, bus fault 2, stale 4, absent 8],
     "refs": [[seq, t, Fx, Fy, Fz, Tx, Ty, Tz], ...],   windows ready since the last message
     "mae": {"Fx": 0.12, ...}, "mae_contact": {"Fx": 0.3, ...},  overall, in contact
     "snake": {...} or absent}

Without a model (`spectratac live URL`) the session sends the same message per sample with
the estimate's fields (force, torque, region, p, contact, ood, invalid) null: raw counts and
the reference only. The page draws the count thresholds from the meta's ``raw`` entry
(`raw_config`: the VEML3328's full scale from its definition, the decoder guard's dark
level), never from numbers of its own.

``t`` is seconds since the session began on the host clock the estimates and the reference
share (see `alignment`); ``arrival_ms`` is when the sample's bytes were read, in Unix ms,
for the page to measure the latency to the browser.

Besides estimates the page gets ``meta`` (once, first), ``stats``, ``snake``,
``error`` (the session stopped) and ``refused`` (a message of the page's the server did not
act on, with a ``code``: see `spectratac.apps.live.inbound`); a benchmark's page also gets
``ping`` and ``probe`` (``sent_ms``: the latency reference, in an estimate's WebSocket
message; `spectratac.apps.live.server`). Messages the server queued in one turn of its event
loop arrive as one WebSocket message, a JSON array of them.

>>> msg = estimate_message(7, _example_estimate(), _example_sample(), 1.25, 5.0)
>>> msg["t"], msg["force"], msg["region"], msg["saturated"][3], msg["dark"]
(1.25, [0.1, -0.2, -2.5], 2, True, [False, True, False])
>>> estimate_message(7, None, _example_sample(), 1.25, 5.0)["force"] is None
True
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from spectratac.decode.guard import DARK_CHANNEL, DARK_COUNTS, SATURATION
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.protocol.generated.messages import SensorStatus

_DARK = vocab.CHANNELS.index(DARK_CHANNEL)
#: The estimate's fields, null in the messages of a session without a model.
ESTIMATE_FIELDS = ("force", "torque", "region", "p", "contact", "ood", "invalid", "no_rest")


def _num(v: float, digits: int) -> float | None:
    v = float(v)
    return None if not math.isfinite(v) else round(v, digits)


def raw_config() -> dict[str, Any]:
    """What the page needs to plot and flag raw counts (sent once, in the meta)."""
    return {
        "sensors": vocab.N_SENSORS,
        "channels": list(vocab.CHANNELS),
        "full_scale": int(SATURATION),
        "dark_counts": DARK_COUNTS,
        "dark_channel": DARK_CHANNEL,
        "status_bits": [
            [int(bit), str(bit.name).removeprefix("SENSOR_").lower().replace("_", " ")]
            for bit in SensorStatus
        ],
    }


def raw_flags(counts: Any, status: Any) -> tuple[list[int], list[bool], list[bool], list[int]]:
    """(15 counts, every channel of each sensor; saturated per count; dark per sensor;
    status bits per sensor)."""
    c = np.asarray(counts, dtype=np.int64)
    bits = np.asarray(status, dtype=np.int64)
    saturated = c >= SATURATION
    dark = c[:, _DARK] < DARK_COUNTS
    return c.reshape(-1).tolist(), saturated.reshape(-1).tolist(), dark.tolist(), bits.tolist()


def estimate_message(
    seq: int, estimate: Any | None, sample: Any, t: float, arrival_ms: float
) -> dict[str, Any]:
    """The page's message for one sample and its estimate (None: no model, fields null)."""
    counts, saturated, dark, status = raw_flags(sample.counts, sample.status)
    msg: dict[str, Any] = {"type": "estimate", "seq": seq, "t": round(t, 4),
                           "arrival_ms": round(arrival_ms, 3)}  # fmt: skip
    if estimate is None:
        msg.update(dict.fromkeys(ESTIMATE_FIELDS))
    else:
        msg.update(
            force=[_num(v, 4) for v in estimate.force],
            torque=[_num(v, 6) for v in estimate.torque],
            region=int(estimate.region),
            p=_num(estimate.region_prob, 3),
            contact=bool(estimate.contact),
            ood=bool(estimate.ood),
            invalid=bool(estimate.invalid),
            no_rest=bool(getattr(estimate, "no_rest", False)),
        )
    msg.update(step=int(sample.step), counts=counts, saturated=saturated, dark=dark,
               status=status)  # fmt: skip
    return msg


def _example_estimate() -> Any:
    from types import SimpleNamespace

    return SimpleNamespace(force=[0.1, -0.2, -2.5], torque=[math.nan] * 3, region=2,
                           region_prob=0.97, contact=True, ood=False, invalid=False)  # fmt: skip


def _example_sample() -> Any:
    from types import SimpleNamespace

    counts = ((900, 800, 700, 65535, 0), (10, 10, 10, 5, 0), (900, 800, 700, 2000, 0))
    return SimpleNamespace(step=0, counts=counts, status=(0, 0, 0))
