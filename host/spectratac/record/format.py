"""The MCAP channel layout of a SpectraTac recording (described for people in FORMAT.md).

Times: every message's MCAP ``publish_time`` is the host's receive time, ``time.monotonic()``
in ns shifted by one constant per file (``unix_minus_monotonic_ns`` in the session message) so
that viewers such as Foxglove show wall-clock dates; the shift is undone exactly on reading.
``log_time`` is on the sensor's clock (`spectratac.record.timeline`).

>>> clock = HostClock(unix_minus_monotonic_ns=1_700_000_000_000_000_000)
>>> ns = clock.log_time(12.5)
>>> ns, clock.monotonic(ns)
(1700000012500000000, 12.5)
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from spectratac.device.ground_truth import CONTACT_TRUTH

FORMAT = "spectratac.recording"
#: 2 added GROUND_TRUTH: version-1 readers cannot skip a binary channel they do not know.
#: 3 put the link's facts in the session's "link" (LinkInfo) and its truth's description in
#: "truth", where older files have "sim": a version-2 reader would take the file for hardware.
#: 4 gave every JSON channel its own schema and wrote each compact row once more, decoded,
#: with a JSON schema (spectratac.record.schemas): counts, estimates, wrench, truth.
#: 5 wrapped the compact channels' bytes in a one-field protobuf message (record.wrapped) so
#: that players decode them, and kept every JSON schema inside Foxglove's parse rules
#: (no null: a value that is not finite is absent). A version-4 reader would take the
#: prefix for part of the frame.
VERSION = 5

# topic -> message encoding; JSON topics carry one JSON object per message.
SESSION = "/spectratac/session"  # once, first: URLs, link facts, truth, clocks, versions
FRAMES = "/spectratac/frames"  # one decoded device frame per message (header+payload+CRC)
INFO = "/spectratac/info"  # the device's INFO, on connect
CONFIG = "/spectratac/config"  # every configuration: id, request, GET_CONFIG reply
TIME_SYNC = "/spectratac/time_sync"  # a batch of TIME_SYNC exchanges
STATS = "/spectratac/stats"  # link health of both sensors, about once per second
END = "/spectratac/end"  # summary of a cleanly finished recording (absent after a crash)
FT_SAMPLES = "/ft/samples"  # a batch of FT_RECORD rows, raw little-endian bytes
FT_INFO = "/ft/info"  # the reference sensor's FTInfo and URL
LABELS = "/labels"  # one region-label event per message
GROUND_TRUTH = "/spectratac/ground_truth"  # truth of a batch of samples (simulated links)
EPOCH = "/spectratac/epoch"  # a connection to the device began: its clock and seq start afresh

# Compact channels: (protobuf message name, what it holds); files before version 5 used the
# encodings in LEGACY_ENCODINGS with no schema (record.wrapped says why that changed).
COMPACT = {
    FRAMES: ("Frame", "one device frame: header, payload, CRC-32C (protocol/SPEC.md)"),
    FT_SAMPLES: ("FTRecords", "a batch of FT_RECORD rows, little-endian (dtype metadata)"),
    GROUND_TRUTH: ("GroundTruthRecords", "a batch of GROUND_TRUTH_RECORD rows (dtype metadata)"),
}
LEGACY_ENCODINGS = {
    FRAMES: "spectratac.frame",
    FT_SAMPLES: "spectratac.ft_record",
    GROUND_TRUTH: "spectratac.ground_truth",
}
JSON_TOPICS = (SESSION, INFO, CONFIG, TIME_SYNC, STATS, END, FT_INFO, LABELS, EPOCH)
# What each JSON topic's message is (its JSON schema's title and description).
JSON_TOPIC_DOCS = {
    SESSION: ("spectratac.Session", "the session: URLs, link facts, truth, clocks, versions"),
    INFO: ("spectratac.Info", "the device's INFO, on connect"),
    CONFIG: ("spectratac.Config", "a configuration the device acknowledged"),
    TIME_SYNC: ("spectratac.TimeSync", "a batch of TIME_SYNC round trips"),
    STATS: ("spectratac.Stats", "link health of both sensors"),
    END: ("spectratac.End", "the summary of a cleanly finished recording"),
    FT_INFO: ("spectratac.FTInfo", "the reference F/T sensor's description and URL"),
    LABELS: ("spectratac.Label", "one region-label event (LABELS.md)"),
    EPOCH: ("spectratac.Epoch", "a connection to the device began"),
}

#: One row per SAMPLE frame of a link with ground truth: the sample's identity (its
#: sample_seq and its window on the device clock, unwrapped µs, as
#: spectratac.dataset.frames decodes them from the frame) and the truth at the window's
#: centre (spectratac.device.ground_truth.CONTACT_TRUTH).
GROUND_TRUTH_RECORD = np.dtype(
    [("sequence", "<u4"), ("t_start_us", "<i8"), ("t_end_us", "<i8"), *CONTACT_TRUTH.descr]
)


@dataclass(frozen=True)
class HostClock:
    """Maps host monotonic seconds to MCAP log_time (ns) and back."""

    unix_minus_monotonic_ns: int

    def log_time(self, monotonic_s: float) -> int:
        return round(monotonic_s * 1e9) + self.unix_minus_monotonic_ns

    def monotonic(self, log_time_ns: int) -> float:
        return (log_time_ns - self.unix_minus_monotonic_ns) / 1e9

    def monotonic_array(self, log_time_ns: np.ndarray) -> np.ndarray:
        """Vectorised monotonic(); int64 arithmetic first, so no nanosecond is lost."""
        return (np.asarray(log_time_ns, np.int64) - self.unix_minus_monotonic_ns) / 1e9


def dtype_to_json(dtype: np.dtype) -> str:
    """A structured dtype as JSON (the `descr` list), stored in a binary channel's metadata."""
    return json.dumps([list(d) if len(d) == 2 else [d[0], d[1], list(d[2])] for d in dtype.descr])


def dtype_from_json(text: str) -> np.dtype:
    """Inverse of dtype_to_json.

    >>> dt = np.dtype([("t", "<f8"), ("w", "<f8", (6,))])
    >>> dtype_from_json(dtype_to_json(dt)) == dt
    True
    """
    fields = json.loads(text)
    return np.dtype([tuple(d[:2]) if len(d) == 2 else (d[0], d[1], tuple(d[2])) for d in fields])
