"""Estimates -> direction commands: one press, one command, only above the force threshold.

A press starts when the normal force (−Fz: the F/T convention reads a press as Fz < 0)
exceeds `threshold_n` (the paper's 1.0 N). Its region is decided once the decoded region
has stayed the same for `confirm` consecutive estimates above the threshold (a press
rising through the skin can be misread for a sample or two); a mapped region fires its
direction, a neutral one (the centre) fires nothing. Nothing more fires until the force
has fallen below `threshold_n − hysteresis_n` for `rearm` consecutive estimates: a
trembling finger near the threshold, or a press sliding to a neighbouring region, never
gives a second command. Invalid and (unless `accept_ood`) out-of-distribution estimates
count as no press.

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
        self._candidate = -1
        self._streak = 0
        self._below = 0

    @staticmethod
    def normal_force(estimate: Any) -> float:
        """Normal force in N (positive into the skin), NaN when not decoded."""
        fz = float(estimate.force[2])
        return -fz if math.isfinite(fz) else math.nan

    def feed(self, estimate: Any, t: float) -> Command | None:
        """Update with one estimate at time `t` (s); the press's command when decided."""
        usable = not estimate.invalid and (self.accept_ood or not estimate.ood)
        normal = self.normal_force(estimate) if usable else math.nan
        if not self.pressed:
            if normal > self.threshold_n:
                self.pressed, self.decided, self._streak, self._below = True, False, 0, 0
            else:
                return None
        if not normal >= self.release_n:  # NaN (unusable) counts as released
            self._below += 1
            self._streak = 0
            if self._below >= self.rearm:
                self.pressed = False
            return None
        self._below = 0
        if self.decided or normal <= self.threshold_n:
            return None
        region = int(estimate.region)
        self._streak = self._streak + 1 if region == self._candidate else 1
        self._candidate = region
        if self._streak < self.confirm or region < 1:
            return None
        self.decided = True
        return Command(self.mapping.direction(region), region, float(t), normal)
