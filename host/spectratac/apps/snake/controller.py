"""The game driven by the sensor: estimates in, commands and game steps out.

The snake waits for the first direction command, then moves one cell at every multiple
of `tick_s` on the *sensor's* clock (the time given with each estimate; the apps pass the
device's own clock), not the host's: the game runs at the same pace whatever the host
does, and a replay or a simulated session accelerated to `speed=max` plays exactly the
same game. After a game over, the next direction command starts a new game.

>>> from types import SimpleNamespace as E
>>> ctl = SnakeController(SnakeGame(width=8, height=6, seed=1), tick_s=0.5)
>>> est = lambda f, r: E(force=[0, 0, -f], region=r, invalid=False, ood=False)
>>> events = [ctl.feed(est(2.0 if 10 <= i < 20 else 0.0, 2), i * 0.05) for i in range(40)]
>>> [c.direction for e in events for c in e.commands], ctl.game.head, ctl.game.steps
(['up'], (4, 1), 2)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from spectratac.apps.snake.control import Command, CommandDetector
from spectratac.apps.snake.game import SnakeGame

TICK_S = 0.5  # one cell per half second: time for a deliberate press between moves


@dataclass
class Update:
    """What one estimate changed: commands decided, game steps taken."""

    commands: list[Command] = field(default_factory=list)
    steps: int = 0


class SnakeController:
    def __init__(
        self,
        game: SnakeGame | None = None,
        detector: CommandDetector | None = None,
        *,
        tick_s: float = TICK_S,
    ) -> None:
        if not tick_s > 0:
            raise ValueError(f"tick_s={tick_s}: give a positive game period in seconds")
        self.game = game or SnakeGame()
        self.detector = detector or CommandDetector()
        self.tick_s = float(tick_s)
        self.history: list[Command] = []
        self.started = False  # the snake moves once the first direction command came
        self._next_tick = math.inf

    def restart(self) -> None:
        """A new game from the seed, waiting for its first command; the history goes on."""
        self.game.reset()
        self.started = False
        self._next_tick = math.inf

    def feed(self, estimate: Any, t: float) -> Update:
        """One estimate at sensor time `t` (s): detect a command, turn, step the game."""
        out = Update()
        if not math.isfinite(t):
            return out
        command = self.detector.feed(estimate, t)
        if command is not None:
            self.history.append(command)
            out.commands.append(command)
            if command.direction is not None:
                if not self.game.alive:
                    self.restart()
                self.game.turn(command.direction)
                if not self.started:
                    self.started = True
                    self._next_tick = (math.floor(t / self.tick_s) + 1) * self.tick_s
        while t >= self._next_tick:
            self.game.step()
            out.steps += 1
            self._next_tick += self.tick_s
        return out

    def state(self) -> dict[str, Any]:
        return self.game.state() | {
            "commands": [c.as_dict() for c in self.history[-20:]],
            "pressed": self.detector.pressed,
            "started": self.started,
            "threshold_n": self.detector.threshold_n,
            "mapping": self.detector.mapping.as_dict(),
        }
