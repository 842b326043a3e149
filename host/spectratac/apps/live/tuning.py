"""The interpreter settings the live server runs under: an estimate crosses three Python
threads (the sensor's reader, the decoding worker, the event loop) and each crossing waits
for the GIL.

- `SWITCH_INTERVAL_S`: a thread woken with a sample or a message waits at most this long for
  the GIL held by another thread (the simulated device, the F/T reader, a clock fit) before
  asking for it, instead of CPython's 5 ms; on a loaded machine each such wait is followed by
  a trip through the run queue, so every crossing paid it.
- `gc.freeze()` once everything is started: the tens of thousands of objects made at start-up
  (modules, the app, the model) leave the collector's reach, so a full collection, which holds
  the GIL (84 ms once in a 20-s run beside other work), only walks what the session made since.

`serving()` applies both and restores the previous settings when the last server using them
stops: tests and benchmarks serve from threads of their own process, several at a time.
"""

from __future__ import annotations

import contextlib
import gc
import sys
import threading
from collections.abc import Iterator

SWITCH_INTERVAL_S = 0.0005

_lock = threading.Lock()
_users = 0
_interval_before = 0.0


@contextlib.contextmanager
def serving() -> Iterator[None]:
    """Run the block with the live server's switch interval and the start-up objects frozen."""
    global _users, _interval_before
    with _lock:
        if _users == 0:
            _interval_before = sys.getswitchinterval()
            sys.setswitchinterval(SWITCH_INTERVAL_S)
            gc.collect()  # start-up's garbage goes now, not frozen with the rest
            gc.freeze()
        _users += 1
    try:
        yield
    finally:
        with _lock:
            _users -= 1
            if _users == 0:
                gc.unfreeze()
                sys.setswitchinterval(_interval_before)
