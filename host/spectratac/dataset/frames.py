"""Recorded device frames to a sample table: the bulk decoder over every SAMPLE frame at once,
device times unwrapped to 64 bits, each row stamped with its frame's host receive time.

>>> from spectratac.protocol.generated import messages as m
>>> from spectratac.protocol.framing import decode_frame, encode_frame
>>> raws = [decode_frame(encode_frame(m.Sample(sample_seq=i, t_start_us=0xFFFF_FF00 + 50 * i,
...         t_end_us=(0xFFFF_FF00 + 50 * i + 40) & 0xFFFF_FFFF), seq=i)[:-1]).raw
...         for i in range(6)]
>>> table = recorded_samples(raws, np.arange(6.0))
>>> table["t_end_us"].tolist()[-2:], table["host_time"].tolist()[:2]  # unwrapped past 2^32
([4294967280, 4294967330], [0.0, 1.0])
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from cobs import cobs

from spectratac.device.records import SAMPLE_TIME_INVERTED, SAMPLE_WINDOW_CLIPPED
from spectratac.protocol.bulk import decode_samples
from spectratac.protocol.generated import messages as m

#: One row per recorded SAMPLE frame. Device times are unwrapped µs (int64).
RECORDED_SAMPLE = np.dtype(
    [
        ("host_time", "<f8"),  # when the frame's bytes arrived (host monotonic s)
        ("t_start_us", "<i8"),
        ("t_end_us", "<i8"),
        ("sequence", "<u4"),  # SAMPLE.sample_seq
        ("frame_seq", "<u2"),  # the frame header's sequence number
        ("step", "u1"),
        ("config_id", "<u2"),
        ("counts", "<u2", (3, 5)),
        ("status", "u1", (3,)),
        ("flags", "u1"),  # SAMPLE_TIME_INVERTED / SAMPLE_WINDOW_CLIPPED, as Sensor flags them
    ]
)
_WRAP = 1 << 32


def unwrap_us(t32: np.ndarray) -> np.ndarray:
    """A wrapping u32 µs clock (in arrival order) as int64, assuming steps < 2^31 µs.

    >>> unwrap_us(np.array([4294967200, 10, 300], dtype=np.uint32)).tolist()
    [4294967200, 4294967306, 4294967596]
    """
    t = np.asarray(t32, dtype=np.int64)
    if t.size == 0:
        return t
    back = np.diff(t) < -(_WRAP >> 1)
    return t + _WRAP * np.concatenate([[0], np.cumsum(back)])


def recorded_samples(frames: Sequence[bytes], host_times: np.ndarray) -> np.ndarray:
    """The SAMPLE frames among decoded `frames` (arrival order) as RECORDED_SAMPLE rows."""
    host_times = np.asarray(host_times, dtype=np.float64)
    sample_type = m.Sample.TYPE_ID
    picked = [i for i, raw in enumerate(frames) if len(raw) > 2 and raw[2] == sample_type]
    encode = cobs.encode
    wire = b"".join([encode(frames[i]) + b"\x00" for i in picked])
    samples = decode_samples(wire).samples
    if len(samples) != len(picked):  # a frame the bulk path refused: find them one by one
        ok = [i for i in picked if len(decode_samples(encode(frames[i]) + b"\x00").samples)]
        picked = ok
    out = np.empty(len(picked), dtype=RECORDED_SAMPLE)
    out["host_time"] = host_times[picked]
    end = unwrap_us(samples["t_end_us"])
    span = (samples["t_end_us"].astype(np.int64) - samples["t_start_us"]) % _WRAP
    # the rules of Sensor._to_sample: a window ending before it starts (a clock fault) is
    # empty, one reaching back before the first time seen is clipped; both are flagged
    inverted = span >= _WRAP >> 1
    clipped = ~inverted & (span > end)
    span = np.where(inverted, 0, np.where(clipped, end, span))
    out["flags"] = np.where(inverted, SAMPLE_TIME_INVERTED, 0) | np.where(
        clipped, SAMPLE_WINDOW_CLIPPED, 0
    )
    out["t_end_us"] = end
    out["t_start_us"] = end - span
    out["sequence"] = samples["sample_seq"]
    out["frame_seq"] = samples["seq"]
    out["step"] = samples["led_step"]
    out["config_id"] = samples["config_id"]
    out["counts"] = samples["counts"]
    out["status"] = samples["sensor_status"]
    return out
