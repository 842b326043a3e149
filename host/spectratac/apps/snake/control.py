"""Estimates -> direction commands: one press, one command, only above the force threshold.

A press starts when the normal force (−Fz: the F/T convention reads a press as Fz < 0)
exceeds `threshold_n` (the paper's 1.0 N). Its region is decided on the press's steady part:
once `confirm` consecutive estimates above the threshold read the same region with forces
within STEADY of each other (a press rising through the skin is misread more often than a
held one); a press that never holds still is decided as it starts to fall (below FALLING of
its peak) or at its release, by the region most read near its peak. A mapped region fires
its direction, a neutral one (the centre) fires nothing. Nothing more fires until the force
has fallen below `threshold_n − hysteresis_n` for `rearm` consecutive usable estimates: a
trembling finger near the threshold, a press sliding to a neighbouring region, or an
out-of-distribution flag flickering during a press never gives a second command. Invalid
and (unless `accept_ood`) out-of-distribution estimates are not looked at: they neither
start, decide nor end a press.

>>> from types import SimpleNamespace as E
>>> det = CommandDetector(DirectionMap.parse("cross"), confirm=2, rearm=1)
>>> press = [(0.2, 2), (1.4, 2), (1.6, 2), (1.2, 2), (0.9, 2), (0.5, 2), (1.5, 6), (1.5, 6)]
>>> got = [det.feed(E(force=[0, 0, -f], region=r, invalid=False, ood=False), i * 0.05)
...        for i, (f, r) in enumerate(press)]
>>> [(c.direction, c.region) for c in got if c]
[('up', 2), ('right', 6)]
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from spectratac.apps.snake.mapping import Direction, DirectionMap
from spectratac.errors import SpectraTacError

THRESHOLD_N = 1.0  # the paper: commands only above 1.0 N of normal force
HYSTERESIS_N = 0.3
CONFIRM = 2  # estimates (100 ms at 20 Hz) with the same region before a press is decided
REARM = 2  # estimates below the release level before the next press can fire
STEADY = 0.10  # a press holds still while its last `confirm` forces are within 10 %
FALLING = 0.8  # below this fraction of its peak a press is ending: decide it now


@dataclass(frozen=True)
class Command:
    """A decided press: its direction (None for a neutral region), region, time, force."""

    direction: Direction | None
    region: int
    time: float
    force_n: float

    def as_dict(self) -> dict[str, Any]:
        return {
            "direction": self.direction,
            "region": self.region,
            "time": round(self.time, 4),
            "force_n": round(self.force_n, 3),
        }


class CommandDetector:
    """Feed it every estimate in order; it returns a `Command` when a press is decided."""

    def __init__(
        self,
        mapping: DirectionMap | None = None,
        *,
        threshold_n: float = THRESHOLD_N,
        hysteresis_n: float = HYSTERESIS_N,
        confirm: int = CONFIRM,
        rearm: int = REARM,
        accept_ood: bool = False,
    ) -> None:
        if not threshold_n > 0 or not 0 <= hysteresis_n < threshold_n:
            raise SpectraTacError(
                f"threshold {threshold_n} N, hysteresis {hysteresis_n} N: give a threshold > 0 "
                "and a hysteresis in [0, threshold)"
            )
        if confirm < 1 or rearm < 1:
            raise SpectraTacError("confirm and rearm count estimates: give 1 or more")
        self.mapping = mapping or DirectionMap()
        self.threshold_n = float(threshold_n)
        self.release_n = float(threshold_n - hysteresis_n)
        self.confirm = int(confirm)
        self.rearm = int(rearm)
        self.accept_ood = accept_ood
        self.reset()

    def reset(self) -> None:
        self.pressed = False  # above the threshold since the last re-arm
        self.decided = False  # this press has given its command (or was neutral)
        self._below = 0
        self._peak = 0.0
        self._reads: list[tuple[float, int]] = []  # (normal, region) above the release level

    @staticmethod
    def normal_force(estimate: Any) -> float:
        """Normal force in N (positive into the skin), NaN when not decoded."""
        fz = float(estimate.force[2])
        return -fz if math.isfinite(fz) else math.nan

    def feed(self, estimate: Any, t: float) -> Command | None:
        """Update with one estimate at time `t` (s); the press's command when decided."""
        if estimate.invalid or (estimate.ood and not self.accept_ood):
            return None  # unknown, not released: a flickering flag must not re-arm
        normal = self.normal_force(estimate)
        if not math.isfinite(normal):
            return None
        if not self.pressed:
            if normal <= self.threshold_n:
                return None
            self.pressed, self.decided, self._below = True, False, 0
            self._peak, self._reads = 0.0, []
        if normal < self.release_n:
            self._below += 1
            if self._below < self.rearm:
                return None
            self.pressed = False  # released: decide a press too brief to have held still
            return None if self.decided else self._decide(self._near_peak(), normal, t)
        self._below = 0
        if self.decided:
            return None
        self._peak = max(self._peak, normal)
        self._reads.append((normal, int(estimate.region)))
        if normal <= self.threshold_n:
            return None
        last = self._reads[-self.confirm :]
        forces = [f for f, _ in last]
        held = len(last) == self.confirm and len({r for _, r in last}) == 1
        if held and self.threshold_n < min(forces) and max(forces) <= (1 + STEADY) * min(forces):
            return self._decide(last[-1][1], normal, t)
        if normal < FALLING * self._peak:
            return self._decide(self._near_peak(), normal, t)
        return None

    def _near_peak(self) -> int:
        """The region read most often at forces near the press's peak (-1: none)."""
        votes: dict[int, int] = {}
        for f, r in self._reads:
            if f >= FALLING * self._peak and f > self.threshold_n and r >= 1:
                votes[r] = votes.get(r, 0) + 1
        return max(votes, key=lambda r: votes[r]) if votes else -1

    def _decide(self, region: int, normal: float, t: float) -> Command | None:
        if region < 1:
            return None
        self.decided = True
        return Command(self.mapping.direction(region), region, float(t), normal)
