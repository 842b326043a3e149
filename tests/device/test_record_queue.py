"""RecordQueue: the one bounded buffer of samples, estimates and F/T records."""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence

import numpy as np
import pytest
from spectratac.device import BufferOverflowError, DisconnectedError, RecordQueue
from spectratac.device.record_queue import OverflowPolicy


def _ints(batches: list[Sequence[int]]) -> np.ndarray:
    return np.array([x for batch in batches for x in batch], dtype=np.int64)


def _queue(capacity: int = 5, overflow: OverflowPolicy = "drop_oldest") -> RecordQueue[int]:
    return RecordQueue(capacity, _ints, overflow=overflow, what="numbers")


def test_read_returns_records_in_order_across_batches() -> None:
    q = _queue(10)
    q.put([0, 1, 2])
    q.put([3, 4])
    assert q.read(2, timeout=0).tolist() == [0, 1]
    assert q.read(10, timeout=0).tolist() == [2, 3, 4]
    assert q.buffered == 0


def test_read_waits_for_records_put_later() -> None:
    q = _queue(10)
    threading.Timer(0.05, q.put, ([7, 8],)).start()
    assert q.read(2, timeout=10).tolist() == [7, 8]


def test_read_gives_fewer_on_timeout() -> None:
    q = _queue()
    q.put([1])
    assert q.read(3, timeout=0.01).tolist() == [1]


@pytest.mark.parametrize(
    ("policy", "kept"), [("drop_oldest", [3, 4, 5, 6, 7]), ("drop_newest", [0, 1, 2, 3, 4])]
)
def test_overflow_policies_count_what_they_drop(policy: OverflowPolicy, kept: list[int]) -> None:
    q = _queue(5, policy)
    assert q.put([0, 1, 2]) == 0
    assert q.put([3, 4, 5, 6, 7]) == 3
    assert q.dropped == 3
    assert q.read(10, timeout=0).tolist() == kept


def test_a_batch_larger_than_the_queue_keeps_its_newest_records() -> None:
    q = _queue(3)
    q.put([0])
    assert q.put([1, 2, 3, 4, 5]) == 3
    assert q.read(5, timeout=0).tolist() == [3, 4, 5]


def test_error_policy_raises_once_when_nothing_was_read() -> None:
    q = _queue(2, "error")
    q.put([0, 1, 2])
    assert q.read(5, timeout=0).tolist() == [0, 1]  # what was kept comes first
    q.put([3, 4, 5])
    q.read(2, timeout=0)
    with pytest.raises(BufferOverflowError, match="2 numbers were discarded"):
        q.read(1, timeout=0)
    assert q.read(1, timeout=0).tolist() == []  # said once


def test_failure_is_raised_after_the_buffered_records() -> None:
    q = _queue()
    q.put([1, 2])
    q.fail(DisconnectedError("gone"))
    assert q.read(5, timeout=5).tolist() == [1, 2]
    with pytest.raises(DisconnectedError, match="gone"):
        q.read(1, timeout=5)


def test_iteration_drains_then_stops_on_failure_end_or_close() -> None:
    for finish in ("fail", "end", "close"):
        q = _queue()
        q.put([1, 2, 3])
        if finish == "fail":
            q.fail(DisconnectedError("gone"))
        elif finish == "end":
            q.end()
        else:
            q.close()
        assert list(q) == [1, 2, 3], finish


def test_close_wakes_a_waiting_reader() -> None:
    q = _queue()
    threading.Timer(0.05, q.close).start()
    t0 = time.monotonic()
    assert q.read(1, timeout=30).tolist() == []
    assert time.monotonic() - t0 < 30


def test_a_failed_conversion_loses_nothing() -> None:
    def strict(batches: list[Sequence[int]]) -> np.ndarray:
        rows = [x for b in batches for x in b]
        if any(x < 0 for x in rows):
            raise ValueError("negative")
        return np.array(rows)

    q: RecordQueue[int] = RecordQueue(10, strict)
    q.put([1, -1, 2])
    with pytest.raises(ValueError, match="negative"):
        q.read(2, timeout=0)
    assert q.buffered == 3
    q.close()
    assert list(q) == [1, -1, 2]


def test_numpy_batches_are_sliced_not_copied_row_by_row() -> None:
    rec = np.dtype([("t", "<f8")])
    q: RecordQueue[np.void] = RecordQueue(
        4,
        lambda b: np.concatenate(b) if b else np.empty(0, rec),  # type: ignore[arg-type]
    )
    q.put(np.arange(3, dtype="<f8").view(rec))  # type: ignore[arg-type]
    q.put(np.arange(3, 6, dtype="<f8").view(rec))  # type: ignore[arg-type]
    assert q.read(3, timeout=0)["t"].tolist() == [2.0, 3.0, 4.0]
    assert q.read_available()["t"].tolist() == [5.0]


def test_bad_arguments_are_named() -> None:
    with pytest.raises(ValueError, match="overflow='sometimes'"):
        RecordQueue(5, _ints, overflow="sometimes")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="buffer_size=0"):
        RecordQueue(0, _ints)
