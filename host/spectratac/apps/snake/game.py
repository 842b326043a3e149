"""The Snake game: a grid, a snake, food; no UI, no clock, deterministic for a seed.

The snake moves one cell per `step()`. `turn()` sets the direction taken at the next
step (a turn straight back into the neck is ignored, as in the classic game). Eating food
grows the snake by one and scores a point; running into a wall or into itself ends the
game. Food appears on a free cell drawn from the game's own seeded generator.

>>> g = SnakeGame(width=8, height=6, seed=1)
>>> g.head, g.direction, len(g.body)
((4, 3), 'right', 3)
>>> g.turn("up"); g.step(); g.head
(4, 2)
>>> g.turn("down"); g.step(); g.head  # straight back: ignored
(4, 1)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from spectratac.apps.snake.mapping import Direction
from spectratac.errors import SpectraTacError

MOVES: dict[str, tuple[int, int]] = {
    "up": (0, -1),
    "down": (0, 1),
    "left": (-1, 0),
    "right": (1, 0),
}
OPPOSITE = {"up": "down", "down": "up", "left": "right", "right": "left"}

Cell = tuple[int, int]  # (column, row), row 0 at the top


@dataclass(frozen=True)
class Outcome:
    """What a finished (or paused) game came to."""

    alive: bool
    score: int
    length: int
    head: Cell
    steps: int


class SnakeGame:
    def __init__(self, width: int = 16, height: int = 12, *, seed: int = 0, length: int = 3):
        if width < 5 or height < 3 or not 1 <= length <= width // 2:
            raise SpectraTacError(
                f"grid {width}x{height} with a snake of {length}: give at least 5x3 and a "
                "length from 1 to half the width"
            )
        self.width, self.height, self.seed, self.start_length = width, height, seed, length
        self.reset()

    def reset(self) -> None:
        self._rng = np.random.default_rng(self.seed)
        row, col = self.height // 2, self.width // 2
        self.body: list[Cell] = [(col - i, row) for i in range(self.start_length)]  # head first
        self.direction: Direction = "right"
        self._pending: Direction = "right"
        self.alive = True
        self.score = 0
        self.steps = 0
        self.food: Cell = self._place_food()

    @property
    def head(self) -> Cell:
        return self.body[0]

    def turn(self, direction: Direction) -> None:
        if direction not in MOVES:
            raise SpectraTacError(f"direction {direction!r}: give one of {', '.join(MOVES)}")
        if len(self.body) > 1 and direction == OPPOSITE[self.direction]:
            return
        self._pending = direction

    def step(self) -> None:
        """Move one cell (nothing once the game is over)."""
        if not self.alive:
            return
        self.direction = self._pending
        dx, dy = MOVES[self.direction]
        x, y = self.head
        new = (x + dx, y + dy)
        grows = new == self.food
        body = self.body if grows else self.body[:-1]
        if not (0 <= new[0] < self.width and 0 <= new[1] < self.height) or new in body:
            self.alive = False
            return
        self.body = [new, *body]
        self.steps += 1
        if grows:
            self.score += 1
            self.food = self._place_food()

    def outcome(self) -> Outcome:
        return Outcome(self.alive, self.score, len(self.body), self.head, self.steps)

    def state(self) -> dict[str, Any]:
        """JSON-ready state for a UI."""
        return {
            "width": self.width,
            "height": self.height,
            "body": [list(c) for c in self.body],
            "food": list(self.food),
            "direction": self.direction,
            "alive": self.alive,
            "score": self.score,
            "steps": self.steps,
        }

    def _place_food(self) -> Cell:
        occupied = set(self.body)
        free = [
            (x, y) for y in range(self.height) for x in range(self.width) if (x, y) not in occupied
        ]
        if not free:
            return self.head  # the snake fills the grid: nothing left to eat
        return free[int(self._rng.integers(len(free)))]
