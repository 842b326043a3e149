"""The guided labelling protocol: the recorder tells the user which region to press next,
counts down, asks to hold, then to release, and records one label event per prompt with the
prompted region and the hold's time span (LABELS.md).

It is a state machine polled by the recorder's loop with the sensor's clock (seconds since
the session's first sample), so the prompts follow the sensor, not the host: a replayed or
accelerated session prompts at the same sensor times. The whole timeline is fixed before
the session starts (`schedule`: order from the seed, countdown, hold, rest), a published
schedule a scripted presser (the simulated person of `sim://?scene=guided`, a robot arm)
can follow as a person follows the terminal. The output stream is injected (tests drive it
without a terminal).

>>> import io
>>> out = io.StringIO()
>>> g = GuidedProtocol(1, regions=[6], countdown_s=1, hold_s=2.0, rest_s=1.0, out=out)
>>> [g.poll(t) for t in (0.0, 1.0, 2.5, 3.0)]
[[], [], [], [{'source': 'guided', 'index': 0, 'region': 6, 't_start': 1.0, 't_end': 3.0}]]
>>> print(out.getvalue().strip().splitlines()[-1])
[1/1] release
>>> g.done(3.9), g.done(4.0)
(False, True)
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, TextIO

import numpy as np

from spectratac.hardware.generated import vocabulary as vocab
from spectratac.record.errors import RecordingError


def region_map(highlight: int | None = None) -> str:
    """The keypad-style region map, the highlighted region in brackets.

    >>> print(region_map(5))
     1  2  3
     4 [5] 6
     7  8  9
    """
    rows = []
    for row in vocab.KEYPAD:
        cells = [f"[{r}]" if highlight == r else f" {r} " for r in row]
        rows.append("".join(cells).rstrip())
    return "\n".join(rows)


#: The order's seed when none is given: every session prompts the same published order, so
#: that a scripted presser knows it (`--guided-seed` picks another).
DEFAULT_SEED = 0
COUNTDOWN_S = 3
HOLD_S = 3.0
REST_S = 2.0


@dataclass(frozen=True)
class Prompt:
    """One prompt on the session's timeline (s from its first sample): the region to press,
    when PRESS is shown (`go`) and when release is (`release`)."""

    index: int
    region: int
    go: float
    release: float


def schedule(
    n: int,
    *,
    regions: Sequence[int] | None = None,
    countdown_s: int = COUNTDOWN_S,
    hold_s: float = HOLD_S,
    rest_s: float = REST_S,
    seed: int | None = DEFAULT_SEED,
) -> list[Prompt]:
    """The prompts of a guided session: prompt k shows its region at k x period, PRESS a
    countdown later, release `hold_s` after that; period = countdown + hold + rest.

    >>> [(p.region, p.go, p.release) for p in schedule(2, regions=[4, 8], hold_s=1.0)]
    [(4, 3.0, 4.0), (8, 9.0, 10.0)]
    """
    period = countdown_s + hold_s + rest_s
    order = list(regions) if regions is not None else prompt_order(n, seed)
    return [
        Prompt(k, int(order[k]), k * period + countdown_s, k * period + countdown_s + hold_s)
        for k in range(min(n, len(order)))
    ]


def prompt_order(n: int, seed: int | None = DEFAULT_SEED) -> list[int]:
    """`n` regions: shuffled rounds of every region, so each comes up equally often (None:
    a random order).

    >>> sorted(prompt_order(9, seed=1)) == list(range(1, 10))
    True
    >>> prompt_order(9) == prompt_order(9)
    True
    """
    rng = np.random.default_rng(seed)
    out: list[int] = []
    while len(out) < n:
        out += [int(r) for r in rng.permutation(np.array(vocab.REGIONS))]
    return out[:n]


class GuidedProtocol:
    """`n` prompts: countdown (`countdown_s` whole seconds), hold (`hold_s`), rest (`rest_s`)."""

    def __init__(
        self,
        n: int,
        *,
        regions: Sequence[int] | None = None,
        countdown_s: int = COUNTDOWN_S,
        hold_s: float = HOLD_S,
        rest_s: float = REST_S,
        seed: int | None = DEFAULT_SEED,
        out: TextIO | None = None,
    ) -> None:
        if n < 1:
            raise RecordingError(f"--guided {n}: give at least one prompt")
        if countdown_s < 0 or hold_s <= 0 or rest_s < 0:
            raise RecordingError("guided timing: countdown >= 0, hold > 0 and rest >= 0 s")
        self.regions = list(regions) if regions is not None else prompt_order(n, seed)
        if len(self.regions) < n or any(r not in vocab.REGIONS for r in self.regions):
            raise RecordingError(f"guided regions: give n regions, each 1..{vocab.N_REGIONS}")
        self.n = n
        self.countdown_s = int(countdown_s)
        self.hold_s = float(hold_s)
        self.rest_s = float(rest_s)
        self.out = out if out is not None else sys.stderr
        self.events: list[dict[str, Any]] = []
        self._t0: float | None = None  # None: the first poll's time
        self._said: set[tuple[int, str]] = set()

    @property
    def period(self) -> float:
        return self.countdown_s + self.hold_s + self.rest_s

    def prompts(self) -> list[Prompt]:
        """The schedule this protocol prompts, from its start."""
        return schedule(self.n, regions=self.regions, countdown_s=self.countdown_s,
                        hold_s=self.hold_s, rest_s=self.rest_s)  # fmt: skip

    def start_at(self, t0: float) -> None:
        """Put the schedule's start at `t0` (the recorder: 0, the first sample's start)."""
        self._t0 = float(t0)

    def done(self, now: float) -> bool:
        """True once the last prompt's rest is over."""
        return self._t0 is not None and now >= self._t0 + self.n * self.period

    def poll(self, now: float) -> list[dict[str, Any]]:
        """Advance to `now` (the recorder's sensor clock, s): print due prompts, return
        finished labels (t_start/t_end on the same clock)."""
        if self._t0 is None:
            self._t0 = now
        finished: list[dict[str, Any]] = []
        k_now = min(int((now - self._t0) // self.period), self.n)
        for k in range(len(self.events), self.n):
            go = self._t0 + k * self.period + self.countdown_s
            release = go + self.hold_s
            if now >= release:
                for what in ("ready", "press", "release"):  # in order, even if polled late
                    self._say(k, what, now)
                event = {
                    "source": "guided",
                    "index": k,
                    "region": self.regions[k],
                    "t_start": go,
                    "t_end": release,
                }
                self.events.append(event)
                finished.append(event)
            else:
                break
        if k_now < self.n and len(self.events) == k_now:
            self._announce(k_now, now)
        return finished

    def _announce(self, k: int, now: float) -> None:
        start = self._t0 + k * self.period  # type: ignore[operator]
        go = start + self.countdown_s
        if now < go:
            self._say(k, "ready", now)
            left = int(np.ceil(go - now))
            self._say(k, f"{left}", now)
        elif now < go + self.hold_s:
            self._say(k, "ready", now)
            self._say(k, "press", now)

    def _say(self, k: int, what: str, now: float) -> None:
        if (k, what) in self._said:
            return
        self._said.add((k, what))
        region = self.regions[k]
        head = f"[{k + 1}/{self.n}]"
        if what == "ready":
            name = vocab.REGION_PROMPTS[region]
            text = f"{head} next: press region {region} ({name})\n{region_map(region)}"
        elif what == "press":
            text = f"{head} PRESS region {region} now and hold for {self.hold_s:g} s"
        elif what == "release":
            text = f"{head} release"
        else:
            text = f"{head} {what}…"
        print(text, file=self.out, flush=True)
