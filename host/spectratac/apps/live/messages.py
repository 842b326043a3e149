"""The JSON messages the live page receives, built from one estimate and its raw sample.

``estimate`` (one per sensor sample)::

    {"type": "estimate", "seq": 41, "t": 2.05, "arrival_ms": 1.7e12,
     "force": [Fx, Fy, Fz], "torque": [Tx, Ty, Tz],           N and N·m, null if not decoded
     "region": 2, "p": 0.97, "contact": true, "ood": false, "invalid": false,
     "no_rest": false,                       the drift baseline has not yet seen rest (Tare)
     "step": 0, "counts": [12 counts: s0 R G B C, s1 ..., s2 ...],
     "saturated": [12 bools], "dark": [3 bools: each sensor's Clear below the dark level],
     "status": [3 SENSOR_* bit sets: saturated 1, bus fault 2, stale 4, absent 8],
     "refs": [[seq, t, Fx, Fy, Fz, Tx, Ty, Tz], ...],          reference windows now ready
     "mae": {"Fx": 0.12, ...}, "snake": {...} or absent}

``t`` is seconds since the session began on the host clock the estimates and the reference
share (see `alignment`); ``arrival_ms`` is when the sample's bytes were read, in Unix ms,
for the page to measure the latency to the browser.

Besides estimates the page gets ``meta`` (once, first), ``stats``, ``ping``, ``snake``,
``error`` (the session stopped) and ``refused`` (a message of the page's the server did not
act on, with a ``code``: see `spectratac.apps.live.inbound`).

>>> msg = estimate_message(7, _example_estimate(), _example_sample(), 1.25, 5.0)
>>> msg["t"], msg["force"], msg["region"], msg["saturated"][3], msg["dark"]
(1.25, [0.1, -0.2, -2.5], 2, True, [False, True, False])
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from spectratac.decode.guard import DARK_COUNTS, SATURATION


def _num(v: float, digits: int) -> float | None:
    v = float(v)
    return None if not math.isfinite(v) else round(v, digits)


def raw_flags(counts: Any, status: Any) -> tuple[list[int], list[bool], list[bool], list[int]]:
    """(12 RGBC counts, saturated per count, dark per sensor, status bits per sensor)."""
    c = np.asarray(counts, dtype=np.int64)[:, :4]
    bits = np.asarray(status, dtype=np.int64)
    saturated = c >= SATURATION
    dark = c[:, 3] < DARK_COUNTS
    return c.reshape(-1).tolist(), saturated.reshape(-1).tolist(), dark.tolist(), bits.tolist()


def estimate_message(
    seq: int, estimate: Any, sample: Any, t: float, arrival_ms: float
) -> dict[str, Any]:
    counts, saturated, dark, status = raw_flags(sample.counts, sample.status)
    return {
        "type": "estimate",
        "seq": seq,
        "t": round(t, 4),
        "arrival_ms": round(arrival_ms, 3),
        "force": [_num(v, 4) for v in estimate.force],
        "torque": [_num(v, 6) for v in estimate.torque],
        "region": int(estimate.region),
        "p": _num(estimate.region_prob, 3),
        "contact": bool(estimate.contact),
        "ood": bool(estimate.ood),
        "invalid": bool(estimate.invalid),
        "no_rest": bool(getattr(estimate, "no_rest", False)),
        "step": int(sample.step),
        "counts": counts,
        "saturated": saturated,
        "dark": dark,
        "status": status,
    }


def _example_estimate() -> Any:
    from types import SimpleNamespace

    return SimpleNamespace(force=[0.1, -0.2, -2.5], torque=[math.nan] * 3, region=2,
                           region_prob=0.97, contact=True, ood=False, invalid=False)  # fmt: skip


def _example_sample() -> Any:
    from types import SimpleNamespace

    counts = ((900, 800, 700, 65535, 0), (10, 10, 10, 5, 0), (900, 800, 700, 2000, 0))
    return SimpleNamespace(step=0, counts=counts, status=(0, 0, 0))
