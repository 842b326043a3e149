"""The Snake game in a terminal (curses), so that it runs over SSH.

Layout: the board on the left; on the right the keypad of regions with their directions
(the pressed one highlighted), the normal force against the threshold, and the last
commands. Keys: q quits, r starts a new game. The screen is redrawn on every estimate.
"""

from __future__ import annotations

import curses
import math
from typing import Any

from spectratac.apps.snake.control import CommandDetector
from spectratac.apps.snake.controller import SnakeController, Update
from spectratac.apps.snake.game import Outcome
from spectratac.apps.snake.play import play
from spectratac.hardware.generated import vocabulary as vocab

ARROWS = {"up": "^", "down": "v", "left": "<", "right": ">"}
BAR = 24  # characters of the force bar (full scale: 4x the threshold)


def play_in_terminal(
    decoder: Any,
    url: str,
    controller: SnakeController,
    *,
    seconds: float = 0.0,
    keep_config: bool = False,
    timeout: float = 2.0,
    stall_timeout: float | None = None,
) -> Outcome:
    """Play in the terminal until q (or `seconds` of the sensor's clock); the outcome."""

    def main(screen: Any) -> Outcome:
        curses.curs_set(0)
        screen.nodelay(True)
        curses.use_default_colors()
        for i, colour in enumerate((curses.COLOR_GREEN, curses.COLOR_RED, curses.COLOR_CYAN), 1):
            curses.init_pair(i, colour, -1)

        def on_update(estimate: Any, update: Update, t: float) -> bool:
            key = screen.getch()
            if key in (ord("q"), ord("Q")):
                return False
            if key in (ord("r"), ord("R")):
                controller.restart()
            draw(screen, controller, estimate, t)
            return True

        return play(decoder, url, controller, seconds=seconds, keep_config=keep_config,
                    timeout=timeout, stall_timeout=stall_timeout, on_update=on_update)  # fmt: skip

    return curses.wrapper(main)


def _put(screen: Any, y: int, x: int, text: str, attr: int = 0) -> None:
    h, w = screen.getmaxyx()
    if 0 <= y < h and 0 <= x < w:
        screen.addnstr(y, x, text, max(0, w - x - 1), attr)


def draw(screen: Any, controller: SnakeController, estimate: Any, t: float) -> None:
    game = controller.game
    det = controller.detector
    screen.erase()
    _put(screen, 0, 0, "SpectraTac Snake - press the sensor to steer   (q quits, r restarts)",
         curses.A_BOLD)  # fmt: skip
    top, left = 2, 0
    _put(screen, top, left, "+" + "--" * game.width + "+")
    for row in range(game.height):
        _put(screen, top + 1 + row, left, "|")
        _put(screen, top + 1 + row, left + 1 + 2 * game.width, "|")
    _put(screen, top + 1 + game.height, left, "+" + "--" * game.width + "+")
    fx, fy = game.food
    _put(screen, top + 1 + fy, left + 1 + 2 * fx, "()", curses.color_pair(2) | curses.A_BOLD)
    for i, (x, y) in enumerate(game.body):
        _put(screen, top + 1 + y, left + 1 + 2 * x, "@@" if i == 0 else "[]", curses.color_pair(1))
    status = f"score {game.score}  length {len(game.body)}  heading {game.direction}"
    if not game.alive:
        status += "  GAME OVER: press a direction to play again"
    elif not controller.started:
        status += "  waiting: press a direction to start"
    _put(screen, top + 2 + game.height, left, status, curses.A_BOLD)

    px = left + 2 * game.width + 5
    _put(screen, top, px, "regions (keypad layout)", curses.A_BOLD)
    normal = CommandDetector.normal_force(estimate)
    pressed = estimate.region if (estimate.contact and normal > det.threshold_n) else None
    for row, regions in enumerate(vocab.KEYPAD):
        for col, r in enumerate(regions):
            d = det.mapping.direction(r)
            label = f"{r}{ARROWS[d] if d else '.'}"
            attr = curses.A_REVERSE | curses.color_pair(3) if r == pressed else 0
            _put(screen, top + 1 + row, px + 5 * col, f"[{label}]", attr)
    mapping = det.mapping.describe() or "all neutral"
    _put(screen, top + 5, px, f"map {mapping}; {vocab.CENTRE_REGION} = centre (neutral)")
    n = 0.0 if math.isnan(normal) else max(normal, 0.0)
    full = 4 * det.threshold_n
    filled = min(BAR, round(BAR * n / full))
    mark = round(BAR * det.threshold_n / full)
    bar = "".join("#" if i < filled else ("|" if i == mark else "-") for i in range(BAR))
    _put(screen, top + 7, px, f"force [{bar}] {n:5.2f} N")
    _put(screen, top + 8, px, f"threshold {det.threshold_n:.1f} N (re-arm < {det.release_n:.1f} N)")
    region = estimate.region if estimate.region > 0 else "-"
    flags = " ".join(f for f, on in (("contact", estimate.contact), ("OOD", estimate.ood),
                                     ("invalid", estimate.invalid)) if on)  # fmt: skip
    _put(screen, top + 9, px, f"region {region}  {flags}  t {t:7.2f} s")
    _put(screen, top + 11, px, "commands", curses.A_BOLD)
    for i, c in enumerate(reversed(controller.history[-8:])):
        what = c.direction or "neutral"
        _put(
            screen,
            top + 12 + i,
            px,
            f"{what:<8} region {c.region}  {c.force_n:4.1f} N  {c.time:7.2f} s",
        )
    screen.refresh()
