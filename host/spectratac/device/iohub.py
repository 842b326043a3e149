"""One reader thread for every descriptor-backed link in the process (serial ports, ptys,
sockets): it waits on all of them with one selector (epoll on Linux) and hands each chunk of
bytes to its owner's callback.

A thread per link polling with a timeout (pyserial's read: select, read, an ioctl and a read
again per chunk, plus a thread switch each time) costs more than the bytes: 16 links at 20 Hz
spent ~12 % of a core. Here a chunk costs one wake-up and one read(). The thread starts with
the first link and ends when the last one is removed, so closing every sensor leaves no thread.

    >>> r, w = os.pipe()
    >>> got = queue.Queue()
    >>> link = shared_hub().add(r, lambda data, t: got.put(data), lambda exc: None, "pipe")
    >>> os.write(w, b"hello")
    5
    >>> got.get(timeout=5)
    b'hello'
    >>> link.close(); os.close(r); os.close(w)

Callbacks run on the hub thread: they must be quick and must not block on another link.
"""

from __future__ import annotations

import contextlib
import logging
import os
import queue  # noqa: F401  (the example above)
import selectors
import threading
import time
from collections.abc import Callable

log = logging.getLogger("spectratac.device")

OnData = Callable[[bytes, float], None]  # (bytes, host monotonic time when read)
OnLost = Callable[[OSError], None]  # the link ended: EOF or a read error (link removed)
CHUNK = 65536


class Watch:
    """One registered descriptor. close() removes it; no callback of it runs afterwards
    (except the one close() is called from, if any)."""

    def __init__(self, hub: IoHub, fd: int, on_data: OnData, on_lost: OnLost, name: str) -> None:
        self.hub = hub
        self.fd = fd
        self.name = name
        self.on_data = on_data
        self.on_lost = on_lost
        self.closed = False

    def close(self) -> None:
        self.hub.remove(self)


class IoHub:
    def __init__(self) -> None:
        self._lock = threading.Condition()
        self._sel: selectors.BaseSelector | None = None
        self._wake_r = self._wake_w = -1
        self._links: dict[int, Watch] = {}
        self._thread: threading.Thread | None = None
        self._busy: Watch | None = None  # the link whose callback is running

    @property
    def links(self) -> int:
        with self._lock:
            return len(self._links)

    @property
    def running(self) -> bool:
        thread = self._thread
        return thread is not None and thread.is_alive()

    def add(self, fd: int, on_data: OnData, on_lost: OnLost, name: str = "") -> Watch:
        """Watch `fd` (non-blocking, readable by os.read) from the hub thread."""
        link = Watch(self, fd, on_data, on_lost, name or f"fd {fd}")
        with self._lock:
            if fd in self._links:
                raise ValueError(f"fd {fd} is already watched ({self._links[fd].name})")
            if self._sel is None:
                self._sel = selectors.DefaultSelector()
                self._wake_r, self._wake_w = os.pipe()
                os.set_blocking(self._wake_r, False)
                os.set_blocking(self._wake_w, False)
                self._sel.register(self._wake_r, selectors.EVENT_READ, None)
            self._sel.register(fd, selectors.EVENT_READ, link)
            self._links[fd] = link
            if self._thread is None:
                self._thread = threading.Thread(
                    target=self._run, args=(self._sel,), name="spectratac-io", daemon=True
                )
                self._thread.start()
        self._wake()
        return link

    def remove(self, link: Watch) -> None:
        """Stop watching; returns once no callback of `link` is running (unless called from
        one). The caller closes the descriptor afterwards."""
        with self._lock:
            if link.closed:
                return
            self._drop(link)
            if threading.current_thread() is not self._thread:
                while self._busy is link:
                    self._lock.wait(0.5)
        self._wake()

    def _drop(self, link: Watch) -> None:  # under the lock
        link.closed = True
        if self._links.get(link.fd) is link:
            del self._links[link.fd]
            assert self._sel is not None
            with contextlib.suppress(KeyError, ValueError, OSError):
                self._sel.unregister(link.fd)

    def _wake(self) -> None:
        with self._lock:  # the pipe closes with the thread: never write to a stale number
            if self._wake_w >= 0:
                with contextlib.suppress(BlockingIOError, OSError):
                    os.write(self._wake_w, b"\x00")

    def _run(self, sel: selectors.BaseSelector) -> None:
        while True:
            with self._lock:
                if not self._links:  # the last link went: end, and let the next add() restart
                    self._sel = None
                    self._thread = None
                    sel.close()
                    os.close(self._wake_r)
                    os.close(self._wake_w)
                    self._wake_r = self._wake_w = -1
                    self._lock.notify_all()
                    return
            try:
                events = sel.select(1.0)
            except (OSError, ValueError):  # a descriptor closed under us: look again
                time.sleep(0.001)
                continue
            for key, _ in events:
                link = key.data
                if link is None:
                    with contextlib.suppress(BlockingIOError, OSError):
                        os.read(key.fd, 4096)
                    continue
                self._service(link)

    def _service(self, link: Watch) -> None:
        with self._lock:
            if link.closed:
                return
            self._busy = link
        try:
            try:
                data = os.read(link.fd, CHUNK)
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:  # EIO: the other end of a pty went away, a port vanished
                self._lost(link, exc)
                return
            if not data:  # EOF: socket closed, or a port that reports ready but has nothing
                self._lost(link, ConnectionResetError("the other end closed the link"))
                return
            link.on_data(data, time.monotonic())
        except Exception:  # one owner's bug must not stop the other links
            log.exception("%s: handling received bytes failed", link.name)
        finally:
            with self._lock:
                self._busy = None
                self._lock.notify_all()

    def _lost(self, link: Watch, exc: OSError) -> None:
        with self._lock:
            self._drop(link)
        link.on_lost(exc)


_shared: IoHub | None = None
_shared_lock = threading.Lock()


def shared_hub() -> IoHub:
    """The process's hub (created on first use)."""
    global _shared
    with _shared_lock:
        if _shared is None:
            _shared = IoHub()
        return _shared
