"""How long a long verb will take, said before it starts: the estimate line on stderr, and a
progress bar that runs on the clock for work that has no finer steps.

The estimates come from probes of the user's own data (`spectratac.apps.estimates`: the
recording, the dataset, the model) and, for the twin's verbs, of twin work
(`spectratac.studies.cost_model`). A person reads the line on stderr before any work;
--json carries the same figures under "estimate" and never a progress line on stdout.
"""

from __future__ import annotations

import sys
import threading
import time
from typing import Any, TextIO

from spectratac.apps.durations import duration_text


def estimate_line(what: str, estimate: Any) -> str:
    """One line: the total, then each part, then how it was measured."""
    parts = ", ".join(f"{k} {duration_text(v)}" for k, v in estimate.parts_s.items())
    if estimate.calibration_s > 0:
        basis = f"; from rates measured on this machine just now, in {estimate.calibration_s:.1f} s"
    elif estimate.rates:
        basis = "; at " + ", ".join(f"{v:g} {k}" for k, v in estimate.rates.items())
    else:
        basis = ""
    return f"{what}: estimated {duration_text(estimate.total_s)} ({parts}){basis}"


def announce(what: str, estimate: Any, out: TextIO | None = None) -> None:
    """Print the estimate line on stderr (flushed: it must show before the work starts)."""
    stream = out or sys.stderr
    print(estimate_line(what, estimate), file=stream, flush=True)


class ClockBar:
    """A tqdm bar over the estimated seconds of one block of work, advanced by the wall clock
    from a thread (tqdm then shows the time left): for work that reports no steps of its own
    (the auto recipe's budgeted search, one twin session, one dataset build). The bar stops
    one step short of its total until the work really ends.

    >>> with ClockBar(0.05, "probe", enabled=False) as bar:
    ...     bar.enabled
    False
    """

    def __init__(self, seconds: float, desc: str, *, enabled: bool = True, every: float = 0.25):
        self.seconds = max(seconds, 0.1)
        self.desc = desc
        self.enabled = enabled
        self.every = every
        self._done = threading.Event()
        self._bar: Any = None
        self._thread: threading.Thread | None = None
        self._t0 = 0.0

    def __enter__(self) -> ClockBar:
        if self.enabled:
            from spectratac.progress import bar

            self._bar = bar(
                total=round(self.seconds, 1),
                desc=self.desc,
                unit="s",
                leave=False,
                bar_format="{desc}: {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}]",
            )
            if self._bar.disable:  # stderr is not a terminal: no bar, no clock thread
                self._bar = None
                return self
            self._t0 = time.monotonic()
            self._thread = threading.Thread(target=self._run, name="clock-bar", daemon=True)
            self._thread.start()
        return self

    def _run(self) -> None:
        while not self._done.wait(self.every):
            self._advance()

    def _advance(self) -> None:
        elapsed = min(time.monotonic() - self._t0, self.seconds * 0.99)
        self._bar.n = max(round(elapsed, 1), 0.1)  # > 0: tqdm shows the time left once n > 0
        self._bar.refresh()

    def __exit__(self, *exc: object) -> None:
        self._done.set()
        if self._thread is not None:
            self._thread.join()
        if self._bar is not None:
            # work shorter than one tick (a twin session now takes under a second) still shows
            # one frame with the time left before the bar is cleared
            self._advance()
            self._bar.close()
