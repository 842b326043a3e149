"""FTSensor: the one interface of every reference F/T driver.

A driver connects in its constructor (so a wrong URL fails at open), then a background
reader thread parses whatever arrives into FT_RECORD batches and appends them to a bounded
RecordQueue (spectratac.device.record_queue; oldest records are dropped first when it is
full, counted in stats.overflows).
Users read NumPy batches (read, read_available) or iterate record by record. Closing is
idempotent and thread-safe; records received before a link loss stay readable, the error
is raised once they are all read.
Every wait ends: the reader watches for a stall (a streaming sensor that sends nothing for
`stall_timeout` s, default spectratac.ft.stall.default_ft_stall_timeout of its rate): it
counts it in stats.stalls and keeps `stall_message` (what to tell the user, once), so a
recorder goes on with the optical stream, and iteration ends with FTStalledError.

>>> with FTSensor.open("csv://" + _example_csv()) as ft:
...     rows = ft.read(3, timeout=1.0)
>>> rows["wrench"][:, 2].tolist(), ft.info.kind, ft.stats.received
([-1.0, -2.0, -3.0], 'csv', 3)
"""

from __future__ import annotations

import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Sequence
from typing import Any, ClassVar, cast

import numpy as np

from spectratac.device.record_queue import RecordQueue
from spectratac.ft.errors import FTDisconnectedError, FTError, FTStalledError
from spectratac.ft.records import FT_RECORD, FTInfo, FTStats
from spectratac.ft.stall import default_ft_stall_timeout, stall_message


class FTSensor(ABC):
    """Base class of the F/T drivers. Open one with FTSensor.open(url)."""

    #: Subclasses set their URL scheme.
    scheme: ClassVar[str] = ""
    #: open()'s dispatch by URL scheme, registered by the scheme registry (spectratac.ft.open,
    #: which the package imports with this module): the registry imports this base class and
    #: returns its instances, this class never imports the registry.
    _dispatch: ClassVar[Callable[..., FTSensor]]

    def __init__(self, url: str, info: FTInfo, *, timeout: float, buffer_size: int) -> None:
        if buffer_size < 1:
            raise FTError(f"buffer_size={buffer_size}: give at least 1 record")
        self.url = url
        self.info = info
        self.stats = FTStats()
        self.timeout = float(timeout)
        self.buffer_size = int(buffer_size)
        #: FT_RECORD rows, in the batches the reader parsed them in
        self._queue: RecordQueue[np.void] = RecordQueue(self.buffer_size, _join, what="records")
        self._lock = threading.Lock()  # open/streaming state
        self._closed = False
        self._streaming = False
        self._thread: threading.Thread | None = None  # started by the first start()
        self._on_close: list[Callable[[], object]] = []  # run after the driver closed (sim)
        #: set once the sensor has confirmed a stop(): every record it sent before stopping is
        #: in the queue. Only drivers whose protocol acknowledges a stop set it
        #: (`confirms_stop`); for the others a reader waits for the link to go quiet.
        self.stream_stopped = threading.Event()
        self.confirms_stop = False
        self._stop_seen = False  # the driver's _poll saw the acknowledgement
        #: s without a record while streaming before a stall counts (None: from the rate;
        #: inf: no stall watch); the reader checks it on every poll
        self.stall_timeout: float | None = None
        self.stalled = False  # quiet past the stall timeout since the last record
        self.stall_message: str | None = None  # the first stall, said once by the caller
        self._last_data = 0.0

    # ------------------------------------------------------------------ opening and closing
    @classmethod
    def open(
        cls, url: str, *, timeout: float = 2.0, buffer_size: int = 1 << 20, **options: Any
    ) -> FTSensor:
        """Connect to the F/T sensor named by `url`; dispatches on the scheme:
        netft://HOST[:PORT]?cpf=&cpt=&http_port=, bota:///dev/ttyUSB0?baud=460800,
        csv://PATH?rate=&realtime=1, and the schemes of plug-ins (spectratac.ft.open):
        sim://?scene=…&ft=netft|bota starts a simulated sensor in this process and
        connects the real driver to it. Options given as keywords override the URL's
        query. Raises FTURLError, FTNotFoundError or FTTimeoutError (within `timeout`)
        with what to do."""
        return FTSensor._dispatch(url, timeout=timeout, buffer_size=buffer_size, **options)

    def close(self) -> None:
        """Stop the stream and the reader, close the link. Safe to call more than once."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
        self._queue.close()
        try:
            if self._streaming:
                self._send_stop()
        except (OSError, FTError):
            pass  # the link may already be gone; closing must still succeed
        # the reader polls in short steps: let it finish before its descriptor is closed
        # (a closed descriptor's number can be reused by another file at once)
        if self._thread is not None and threading.current_thread() is not self._thread:
            self._thread.join(timeout=2.0)
        self._close_link()
        for hook in self._on_close:
            hook()
        self._on_close.clear()

    def __enter__(self) -> FTSensor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ streaming
    def start(self) -> None:
        """Ask the sensor to stream (idempotent); records then arrive in the buffer."""
        with self._lock:
            if self._closed:
                raise FTError(f"{self.url} is closed: open it again")
            if self._streaming:
                return
            self._streaming = True
        self._last_data = time.monotonic()  # the stall watch counts from the start
        self._send_start()
        if self._thread is None:
            self._thread = threading.Thread(
                target=self._reader, name=f"spectratac-ft-{self.scheme}", daemon=True
            )
            self._thread.start()

    def stop(self) -> None:
        """Ask the sensor to stop streaming; records already received stay readable."""
        with self._lock:
            if not self._streaming or self._closed:
                return
            self._streaming = False
        self.stream_stopped.clear()
        self._send_stop()

    def read(self, n: int, timeout: float | None = None) -> np.ndarray:
        """Up to `n` FT_RECORD rows, waiting up to `timeout` s (default: the open timeout) for
        all of them; fewer on timeout or at the end of a replay. Starts the stream if it was
        never started (after stop(), it returns what is left without restarting it).
        Raises the link's error only once everything received before it has been read."""
        if self._thread is None and not self._closed:
            self.start()
        return self._queue.read(n, self.timeout if timeout is None else timeout)

    def read_available(self) -> np.ndarray:
        """Everything buffered now (possibly nothing), without waiting."""
        return self._queue.read_available()

    def __iter__(self) -> Iterator[np.void]:
        """Records one by one until the sensor is closed, the replay ends or the link fails;
        a stall (nothing for `stall_timeout` s while streaming) raises FTStalledError once
        every record before it was read."""
        while True:
            batch = self.read(4096, timeout=0.5)
            if len(batch) == 0 and (self._closed or self._queue.ended):
                return
            if len(batch) == 0 and self.stalled and self.stall_message is not None:
                raise FTStalledError(self.stall_message)
            yield from batch

    @property
    def effective_stall_timeout(self) -> float:
        """The stall timeout in force: the one set, else the default of the sensor's rate."""
        if self.stall_timeout is not None:
            return self.stall_timeout
        return default_ft_stall_timeout(self.info.rate_hz)

    @property
    def buffered(self) -> int:
        return self._queue.buffered

    @property
    def ended(self) -> bool:
        """True once a replay has no more records (a live sensor never ends)."""
        return self._queue.ended

    @property
    def streaming(self) -> bool:
        return self._streaming

    # ------------------------------------------------------------------ for drivers
    def _send_start(self) -> None:
        """Tell the device to stream (drivers override)."""
        return None  # optional hook: a source without this step does nothing

    def _send_stop(self) -> None:
        """Tell the device to stop (drivers override)."""
        return None  # optional hook: a source without this step does nothing

    def _close_link(self) -> None:
        """Close the socket, port or file (drivers override)."""
        return None  # optional hook: a source without this step does nothing

    @abstractmethod
    def _poll(self, timeout: float) -> np.ndarray | None:
        """Wait up to `timeout` s for data; return the FT_RECORD rows it held (possibly none),
        or None at the end of the source. Raise FTDisconnectedError when the link is lost."""

    def _reader(self) -> None:
        while not self._closed:
            try:
                batch = self._poll(0.05)
            except FTError as exc:
                self._queue.fail(exc)
                return
            except OSError as exc:
                if not self._closed:
                    self._queue.fail(FTDisconnectedError(f"lost {self.url}: {exc}; reopen it"))
                return
            if batch is None:
                self._queue.end()
                return
            if len(batch):
                self._last_data = time.monotonic()
                self.stalled = False
                self._push(batch)
            else:
                self._watch_stall()
            if self._stop_seen:  # after the records that came before the acknowledgement
                self._stop_seen = False
                self.stream_stopped.set()

    def _watch_stall(self) -> None:
        """A streaming sensor quiet past the stall timeout: counted once per quiet spell."""
        if self.stalled or not self._streaming or self._closed:
            return
        limit = self.effective_stall_timeout
        quiet = time.monotonic() - self._last_data
        if quiet > limit:
            self.stalled = True
            self.stats.stalls += 1
            if self.stall_message is None:
                self.stall_message = stall_message(self.url, quiet, limit)

    def _push(self, batch: np.ndarray) -> None:
        self.stats.received += len(batch)
        # a structured array is a sequence of its rows (np.void)
        self.stats.overflows += self._queue.put(cast("Sequence[np.void]", batch))


def _join(batches: list[Sequence[np.void]]) -> np.ndarray:
    """FT_RECORD batches (or slices of them) as one new array. Copied into one preallocated
    array: np.concatenate promotes the structured dtype field by field for every batch
    (~0.1 ms each), and a reader of the live page joins a few dozen batches per sample."""
    arrays = cast("list[np.ndarray]", batches)
    out = np.empty(sum(len(a) for a in arrays), dtype=FT_RECORD)
    at = 0
    for a in arrays:
        out[at : at + len(a)] = a
        at += len(a)
    return out


def _example_csv() -> str:
    """A three-row replay file for the docstring example."""
    import tempfile

    with tempfile.NamedTemporaryFile("w", suffix=".csv", delete=False) as f:
        f.write("t,Fx,Fy,Fz,Tx,Ty,Tz\n")
        f.writelines(f"{i * 0.001},0,0,{-i - 1},0,0,0\n" for i in range(3))
    return f.name
