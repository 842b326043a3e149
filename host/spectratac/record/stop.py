"""A stop request a signal handler can make safely, and the handlers that make it.

`threading.Event.set()` must not be called from a signal handler: Python runs the handler in
the main thread between two bytecodes, possibly while that thread is inside `Event.wait`
holding the event's (non-reentrant) lock, and `set()` then waits for that lock forever.
`StopRequest.set()` takes no lock: it sets a plain flag and writes one byte to a self-pipe,
so a waiter in `select` wakes at once and a waiter that was about to block sees the flag.

>>> stop = StopRequest()
>>> stop.wait(0.01), stop.is_set()
(False, False)
>>> stop.set(); stop.wait(), stop.is_set()
(True, True)
>>> stop.close()
"""

from __future__ import annotations

import contextlib
import os
import select
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any, Protocol


class StopFlag(Protocol):
    """What a loop that can be asked to stop needs (a threading.Event is one too)."""

    def is_set(self) -> bool: ...

    def wait(self, timeout: float | None = None) -> bool: ...


class StopRequest:
    """A one-way stop flag whose `set` is safe in a signal handler (no lock, no allocation
    of Python-level locks); `wait` blocks in `select` on a self-pipe, so it ends as soon as
    the flag is set, from any thread or handler."""

    def __init__(self) -> None:
        self._requested = False
        self._read, self._write = os.pipe()
        os.set_blocking(self._read, False)
        os.set_blocking(self._write, False)

    def set(self) -> None:
        self._requested = True
        # the byte stays in the pipe (never drained): every later wait returns at once
        with contextlib.suppress(OSError):  # full (already woken) or closed (done)
            os.write(self._write, b"\0")

    def is_set(self) -> bool:
        return self._requested

    def wait(self, timeout: float | None = None) -> bool:
        """True once a stop was requested; waits up to `timeout` s (None: until then)."""
        if not self._requested:
            with contextlib.suppress(OSError, ValueError):  # closed: nothing left to wait on
                select.select([self._read], [], [], timeout)
        return self._requested

    def close(self) -> None:
        for fd in (self._read, self._write):
            with contextlib.suppress(OSError):
                os.close(fd)

    def __enter__(self) -> StopRequest:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class AnyStop:
    """Set when any of `flags` is: a caller's threading.Event (set from another thread)
    beside the StopRequest a signal handler sets. `wait` sleeps on the last flag in slices
    of at most POLL_S, so a set of the others is seen within that."""

    POLL_S = 0.05

    def __init__(self, *flags: StopFlag) -> None:
        if not flags:
            raise ValueError("AnyStop needs at least one flag")
        self.flags = flags

    def is_set(self) -> bool:
        return any(f.is_set() for f in self.flags)

    def wait(self, timeout: float | None = None) -> bool:
        deadline = None if timeout is None else time.monotonic() + timeout
        while not self.is_set():
            remaining = self.POLL_S if deadline is None else deadline - time.monotonic()
            if remaining <= 0:
                break
            self.flags[-1].wait(min(self.POLL_S, remaining))
        return self.is_set()


class SignalFlag:
    """A re-armable flag a signal handler may set (a plain attribute, no lock); its readers
    poll it. For events such as "unplug now" that a loop handles and then clears."""

    def __init__(self) -> None:
        self._set = False

    def set(self) -> None:
        self._set = True

    def clear(self) -> None:
        self._set = False

    def is_set(self) -> bool:
        return self._set


def stop_handler(stop: StopRequest, message: str | None = None) -> Callable[[int, Any], None]:
    """A signal handler that requests `stop`; a second signal while stopping raises
    KeyboardInterrupt (the user insists). `message` goes straight to fd 2: `print` to
    sys.stderr could re-enter a write the interrupted code was making."""

    def handler(_signum: int, _frame: Any) -> None:
        if stop.is_set():
            raise KeyboardInterrupt
        stop.set()
        if message:
            with contextlib.suppress(OSError):
                os.write(sys.stderr.fileno(), message.encode())

    return handler


@contextlib.contextmanager
def stopping_on(
    stop: StopRequest, signals: tuple[int, ...], message: str | None = None
) -> Iterator[StopRequest]:
    """Within the block, `signals` request `stop` (see stop_handler); the previous handlers
    come back after it. Outside the main thread (where handlers cannot be set) it does
    nothing: the caller stops by setting `stop` itself."""
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    handler = stop_handler(stop, message)
    previous = {sig: signal.signal(sig, handler) for sig in signals}
    try:
        yield stop
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)
