"""Per-sample region, contact and press labels of a recorded session, from the recording alone.

Sessions with ground truth (labels "scene", a simulated link): the recorder stored each
sample's truth at its window's centre (the ground-truth channel, FORMAT.md); it is matched
to the samples by sample sequence number and device time: region (1..9 on firm contacts,
-1 elsewhere), in_contact, and the press under way. Guided sessions (labels "guided"): a
sample inside a prompt's hold span takes the prompted region when the reference F/T
confirms a firm contact (|F| >= LABEL_MIN_NORMAL_N), else -1; in_contact is
|F| >= `contact_n`. A guided session without a reference F/T is confirmed by the optical
counts themselves (`optical_guided_labels`). Without labels, region and press are -1 and
in_contact comes from the F/T.

>>> t = np.array([0.5, 1.5, 2.5, 3.5])
>>> events = [{"index": 0, "region": 4, "t_start": 1.0, "t_end": 3.0}]
>>> force = np.array([[0, 0, 0.0], [0, 0, -2.0], [0, 0, -0.4], [0, 0, -3.0]])
>>> region, press = guided_labels(events, t, force)
>>> region.tolist(), press.tolist()
([-1, 4, -1, -1], [-1, 0, 0, -1])
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from spectratac.dataset.schema import DatasetError

CONTACT_N = 0.5  # |F| above which the reference says something touches the skin
#: A guided sample takes its region only on a firm contact: the paper's interaction
#: threshold, the one the simulator's scene labels use (tests/dataset checks they agree).
LABEL_MIN_NORMAL_N = 1.0


def truth_rows(
    path: Path, truth: np.ndarray | None, samples: np.ndarray, damaged: bool
) -> np.ndarray:
    """Index of each of `samples`' (RECORDED_SAMPLE rows) ground-truth row (GROUND_TRUTH_RECORD),
    matched by sequence number and device time; -1 for a sample whose row went with a damaged
    chunk of a `damaged` recording (the caller drops it). A sample without a row in an intact
    recording means the file was not written by `spectratac record`: DatasetError."""
    if truth is None:
        raise DatasetError(
            f"{path} says its labels come from a simulated scene but holds no ground truth: "
            f"it was recorded by an older spectratac, before recordings carried their labels. "
            f"Re-record it with `spectratac record`"
        )
    row_of = {
        (int(s), int(t)): i
        for i, (s, t) in enumerate(zip(truth["sequence"], truth["t_end_us"], strict=True))
    }
    keys = zip(samples["sequence"].tolist(), samples["t_end_us"].tolist(), strict=True)
    rows = np.array([row_of.get(k, -1) for k in keys], dtype=np.int64)
    if len(rows) and rows.min() < 0 and not damaged:
        raise DatasetError(
            f"{path}: {int(np.sum(rows < 0))} of {len(rows)} samples have no ground-truth row; "
            f"the file was not written by `spectratac record`. Re-record it"
        )
    return rows


def truth_labels(
    path: Path, truth: np.ndarray | None, samples: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(region, in_contact, press) of `samples` (RECORDED_SAMPLE rows) from the recording's
    ground-truth rows (GROUND_TRUTH_RECORD), matched by sequence number and device time
    (`truth_rows` of an intact recording).

    >>> from spectratac.record.format import GROUND_TRUTH_RECORD
    >>> truth = np.zeros(2, GROUND_TRUTH_RECORD)
    >>> truth["sequence"], truth["t_end_us"], truth["region"] = [7, 8], [100, 200], [3, -1]
    >>> samples = np.zeros(1, [("sequence", "<u4"), ("t_end_us", "<i8")])
    >>> samples["sequence"], samples["t_end_us"] = 8, 200
    >>> truth_labels(Path("s.mcap"), truth, samples)[0].tolist()
    [-1]
    """
    rows = truth_rows(path, truth, samples, damaged=False)
    assert truth is not None  # truth_rows raised otherwise
    picked = truth[rows]
    return (
        picked["region"].astype(np.int8),
        picked["in_contact"].astype(bool),
        picked["press"].astype(np.int32),
    )


def spans(events: list[dict[str, Any]], t: np.ndarray) -> np.ndarray:
    """Index into `events` of the span (t_start <= t < t_end) holding each time; -1 if none."""
    out = np.full(t.shape, -1, dtype=np.int64)
    for i, e in enumerate(events):
        if e.get("t_start") is None or e.get("t_end") is None:
            continue
        out[(t >= e["t_start"]) & (t < e["t_end"])] = i
    return out


def guided_labels(
    events: list[dict[str, Any]], t_mid_host: np.ndarray, force: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(region, press) for guided label events; `force` is (N, 3) F/T force, NaN unknown."""
    which = spans(events, t_mid_host)
    press = np.where(which >= 0, [events[i]["index"] if i >= 0 else -1 for i in which], -1)
    prompted = np.array([events[i]["region"] if i >= 0 else -1 for i in which], dtype=np.int8)
    with np.errstate(invalid="ignore"):
        firm = np.linalg.norm(force, axis=1) >= LABEL_MIN_NORMAL_N
    region = np.where((which >= 0) & firm, prompted, np.int8(-1)).astype(np.int8)
    return region, press.astype(np.int32)


def ft_contact(force: np.ndarray, contact_n: float = CONTACT_N) -> np.ndarray:
    """in_contact from the F/T force (N, 3); unknown (NaN) counts as no contact."""
    with np.errstate(invalid="ignore"):
        return np.linalg.norm(force, axis=1) >= contact_n


#: Without a reference, a sample inside a prompt's span takes the region once the counts
#: have moved from rest by FIRM of the press's largest move (users react late and let go
#: early: the span's first and last samples are often no press at all) ...
FIRM = 0.5
#: ... and counts as contact (anywhere) once they moved TOUCH of a typical press's move ...
TOUCH = 0.25
#: ... and never for a move below NOISE_FLOOR x the rest's own scatter (MAD) or MIN_MOVE.
NOISE_FLOOR = 8.0
MIN_MOVE = 0.01  # RMS log-count change: 1 %, below the twin's and the paper's press moves


def optical_move(counts: np.ndarray, rest_rows: np.ndarray, step: np.ndarray) -> np.ndarray:
    """RMS change in log counts of each sample from the median of `rest_rows` of its LED
    step: how far the skin moved the light (0 at rest; a press moves every channel)."""
    logc = np.log(np.maximum(np.asarray(counts, np.float64), 1.0))
    move = np.zeros(len(logc))
    for k in np.unique(step):
        rows = step == k
        ref = rest_rows & rows
        if not ref.any():
            ref = rows
        centre = np.median(logc[ref], axis=0)
        move[rows] = np.sqrt(np.mean((logc[rows] - centre) ** 2, axis=1))
    return move


def optical_guided_labels(
    events: list[dict[str, Any]], t_mid: np.ndarray, counts: np.ndarray, step: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(region, press, in_contact) of a guided session without a reference F/T: the rest is
    the samples outside every prompt's span; inside a span the prompted region holds where
    the counts moved at least FIRM of that press's largest move (and clearly above the
    rest's noise); in_contact where they moved TOUCH of the median press's.

    >>> t = np.arange(10.0)
    >>> counts = np.full((10, 2), 100.0); counts[4:6] = 130.0; counts[3] = 104.0
    >>> ev = [{"index": 0, "region": 2, "t_start": 2.5, "t_end": 7.5}]
    >>> region, press, touch = optical_guided_labels(ev, t, counts, np.zeros(10, int))
    >>> region.tolist(), press.tolist()[2:9], touch.tolist()[3:7]
    ([-1, -1, -1, -1, 2, 2, -1, -1, -1, -1], [-1, 0, 0, 0, 0, 0, -1], [False, True, True, False])
    """
    which = spans(events, t_mid)
    inside = which >= 0
    move = optical_move(counts, ~inside, step)
    rest = move[~inside]
    noise = float(np.median(np.abs(rest - np.median(rest)))) if rest.size else 0.0
    floor = max(NOISE_FLOOR * noise, MIN_MOVE)
    region = np.full(len(t_mid), -1, np.int8)
    press = np.full(len(t_mid), -1, np.int32)
    peaks = []
    for i, e in enumerate(events):
        rows = which == i
        if not rows.any():
            continue
        press[rows] = e["index"]
        peak = float(move[rows].max())
        if peak < floor:
            continue  # nothing pressed during this prompt
        peaks.append(peak)
        region[rows & (move >= max(FIRM * peak, floor))] = e["region"]
    typical = float(np.median(peaks)) if peaks else np.inf
    in_contact = move >= max(TOUCH * typical, floor)
    return region, press, in_contact
