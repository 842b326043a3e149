"""This host's Unix clock against its monotonic clock, read so that the scheduler is not in it.

Recordings, bags and the live page's latency stamps move times between the two clocks with
one offset, Unix minus monotonic. Read as ``time.time_ns() - time.monotonic_ns()``, a thread
descheduled between the two reads puts the offset off by as long as it waited (50 ms at
load 20; 50 µs on a CI worker beside busy loops), and every time converted with it. So the
Unix read sits between two monotonic reads, and the tightest of a few brackets is kept.

>>> offset = unix_minus_monotonic_ns()
>>> abs(offset - (time.time_ns() - time.monotonic_ns())) < 10**9
True
"""

from __future__ import annotations

import time

#: Brackets read; one of them is tight unless the thread is preempted in every one.
TRIES = 9


def unix_minus_monotonic_ns(tries: int = TRIES) -> int:
    """Unix time minus monotonic time (ns), from the tightest of `tries` brackets."""
    best = (float("inf"), 0)
    for _ in range(max(1, tries)):
        t0 = time.monotonic_ns()
        unix = time.time_ns()
        t1 = time.monotonic_ns()
        best = min(best, (t1 - t0, unix - (t0 + t1) // 2))
    return int(best[1])
