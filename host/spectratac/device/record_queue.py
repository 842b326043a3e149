"""`RecordQueue`: the bounded buffer between a reader thread and the readers of a stream.

A reader thread `put`s batches of records; users `read` NumPy batches (waiting up to a
timeout for n records), take what is there (`read_available`) or iterate record by record.
A full queue drops records by its overflow policy and counts them. A link error given to
`fail` is raised only once every record received before it has been read; `end` marks a
source that has no more records (a replay), `close` wakes every waiting reader.

>>> queue = RecordQueue(3, lambda batches: np.array([x for b in batches for x in b]))
>>> queue.put([1, 2]), queue.put([3, 4])  # records dropped: the oldest one goes
(0, 1)
>>> queue.read(5, timeout=0.0).tolist(), queue.dropped
([2, 3, 4], 1)
"""

from __future__ import annotations

import collections
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from typing import Generic, Literal, TypeVar

import numpy as np

from spectratac.device.errors import BufferOverflowError

T = TypeVar("T")
OverflowPolicy = Literal["drop_oldest", "drop_newest", "error"]
OVERFLOW_POLICIES: tuple[OverflowPolicy, ...] = ("drop_oldest", "drop_newest", "error")


class RecordQueue(Generic[T]):
    """A thread-safe FIFO of at most `capacity` records of type T.

    Records are kept in the batches they were put in (a list, or a NumPy structured array
    whose rows are the records), so a batch of ten thousand rows costs one entry.
    `to_array` turns records into one NumPy array; it receives the batches (or slices of
    them) in order. `overflow`: "drop_oldest" makes room for new records, "drop_newest"
    keeps what is buffered, "error" also keeps it and makes the next read that finds
    nothing raise BufferOverflowError naming `what` was lost.
    """

    def __init__(
        self,
        capacity: int,
        to_array: Callable[[list[Sequence[T]]], np.ndarray],
        *,
        overflow: OverflowPolicy = "drop_oldest",
        what: str = "records",
    ) -> None:
        if overflow not in OVERFLOW_POLICIES:
            raise ValueError(
                f"overflow={overflow!r}: choose 'drop_oldest', 'drop_newest' or 'error'"
            )
        if capacity < 1:
            raise ValueError(f"buffer_size={capacity}: must be at least 1")
        self.capacity = capacity
        self.overflow: OverflowPolicy = overflow
        self.what = what
        self._to_array = to_array
        self._batches: collections.deque[Sequence[T]] = collections.deque()
        self._head = 0  # records of the first batch already taken
        self._size = 0
        self._dropped = 0
        self._overflowed = False  # records were dropped since a read last said so
        self._error: BaseException | None = None
        self._ended = False
        self._closed = False
        self._cond = threading.Condition()

    # ------------------------------------------------------------------ the reader's side
    def put(self, records: Sequence[T]) -> int:
        """Append `records` (from the reader thread); returns how many records the overflow
        policy dropped to keep within capacity (old ones or some of these)."""
        if not len(records):
            return 0
        with self._cond:
            room = self.capacity - self._size
            dropped = 0
            if len(records) > room:
                if self.overflow == "drop_oldest":
                    if len(records) >= self.capacity:  # even the new batch does not fit
                        dropped = self._size + len(records) - self.capacity
                        records = records[len(records) - self.capacity :]
                        self._clear()
                    else:
                        dropped = len(records) - room
                        self._discard(dropped)
                else:  # drop_newest and error keep what is already buffered
                    dropped = len(records) - room
                    records = records[:room]
                self._dropped += dropped
                self._overflowed = True
            if len(records):
                self._batches.append(records)
                self._size += len(records)
            self._cond.notify_all()
            return dropped

    def fail(self, error: BaseException) -> None:
        """The source failed: readers get `error` once the buffered records are read."""
        with self._cond:
            if not self._closed:
                self._error = error
            self._cond.notify_all()

    def end(self) -> None:
        """The source has no more records: reads return what is left without waiting."""
        with self._cond:
            self._ended = True
            self._cond.notify_all()

    def close(self) -> None:
        """Wake every waiting reader; reads return what is buffered, iteration stops."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()

    # ------------------------------------------------------------------ the user's side
    def read(self, n: int, timeout: float) -> np.ndarray:
        """Up to `n` records as one array, waiting up to `timeout` s for all n; fewer on
        timeout, at the end of the source or after close. Raises the source's error (or
        BufferOverflowError, see the class) only if no record could be read."""
        deadline = time.monotonic() + timeout
        with self._cond:
            out: list[Sequence[T]] = []
            got = 0
            while True:
                got += self._take(n - got, out)
                if got >= n or self._stop_waiting(got):
                    break
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    break
                self._cond.wait(min(remaining, 3600.0))  # a wait beyond TIMEOUT_MAX overflows
            try:
                return self._to_array(out)
            except (OverflowError, ValueError):
                self._unread(out, got)  # nothing received is lost
                raise

    def read_available(self) -> np.ndarray:
        """Everything buffered now (possibly nothing), without waiting."""
        with self._cond:
            if self._size == 0 and self._error is not None:
                raise self._error
            out: list[Sequence[T]] = []
            self._take(self._size, out)
            return self._to_array(out)

    def __iter__(self) -> Iterator[T]:
        """Records one by one until the queue is closed, ended or failed and empty."""
        while True:
            with self._cond:
                while not self._size:
                    if self._error is not None or self._closed or self._ended:
                        return
                    self._cond.wait(0.5)
                batch = self._batches[0]
                record = batch[self._head]
                self._head += 1
                self._size -= 1
                if self._head == len(batch):
                    self._batches.popleft()
                    self._head = 0
            yield record

    @property
    def buffered(self) -> int:
        with self._cond:
            return self._size

    @property
    def dropped(self) -> int:
        """Records dropped by the overflow policy so far."""
        return self._dropped

    @property
    def ended(self) -> bool:
        return self._ended

    # ------------------------------------------------------------------ internals (locked)
    def _stop_waiting(self, got: int) -> bool:
        """True if a read with `got` records so far must return now (or raise)."""
        if self._overflowed and self.overflow == "error":
            self._overflowed = False
            if not got:
                raise BufferOverflowError(
                    f"{self._dropped} {self.what} were discarded: read more often or open "
                    f"with a larger buffer_size"
                )
            return True
        if self._error is not None:
            if got:
                return True
            raise self._error
        return self._closed or self._ended

    def _take(self, n: int, out: list[Sequence[T]]) -> int:
        """Move up to `n` records, oldest first, into `out` (as slices of batches)."""
        got = 0
        while got < n and self._batches:
            batch = self._batches[0]
            k = min(n - got, len(batch) - self._head)
            if self._head == 0 and k == len(batch):
                out.append(self._batches.popleft())
            else:
                out.append(batch[self._head : self._head + k])
                self._head += k
                if self._head == len(batch):
                    self._batches.popleft()
                    self._head = 0
            got += k
        self._size -= got
        return got

    def _unread(self, out: list[Sequence[T]], got: int) -> None:
        """Put `got` records taken into `out` back at the front, in order."""
        if self._head:  # the rest of a batch taken in part becomes a batch of its own
            self._batches[0] = self._batches[0][self._head :]
            self._head = 0
        self._batches.extendleft(reversed(out))
        self._size += got

    def _discard(self, n: int) -> None:
        """Drop the `n` oldest records."""
        self._take(n, [])

    def _clear(self) -> None:
        self._batches.clear()
        self._head = 0
        self._size = 0
