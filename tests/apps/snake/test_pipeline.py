"""The real pipeline plays the scripted scene: firmware sim -> Sensor -> Decoder -> controller.

The scene presses regions in a known order at known forces; the commands that come out
must be exactly the script's, nothing for the press under the threshold or the neutral
centre, and the game must end exactly as the script played by hand says.
"""

from __future__ import annotations

import pytest
from spectratac.apps.snake.controller import SnakeController
from spectratac.apps.snake.game import SnakeGame
from spectratac.apps.snake.play import play
from spectratac.decode import Decoder
from spectratac.sim.named_scenes import make_scene

from tests.apps.conftest import FORCES, ORDER, PRESSES_URL

NAMES = {"up": "up", "down": "down", "left": "left", "right": "right", "centre": None, "5": None}


def expected_commands() -> list[str | None]:
    """One command per press at or above 1.0 N: its direction, None for the centre."""
    return [NAMES[o] for o, f in zip(ORDER, FORCES, strict=True) if f > 1.0]


def replay_by_hand(scene, directions) -> tuple:
    """The game the script should give: each command turns the snake between the tick at
    its press's start and the next one (presses start on ticks: 1.5 s + 2 s k); after a
    game over the next command starts a new game."""
    game = SnakeGame()
    started, commands = False, iter(directions)
    firm = [float(s) for s, f in zip(scene.presses.start, FORCES, strict=True) if f > 1.0]
    t = 0.0
    while t <= scene.duration_s:
        if started:
            game.step()
        if firm and abs(t - firm[0]) < 1e-9:
            firm.pop(0)
            direction = next(commands)
            if direction is not None:
                if not game.alive:
                    game.reset()
                game.turn(direction)
                started = True
        t = round(t + 0.5, 9)
    return game.outcome()


@pytest.mark.slow
def test_scripted_presses_give_exactly_the_scripted_commands(press_model) -> None:
    decoder = Decoder.load(press_model)
    scene = make_scene("presses", order=",".join(ORDER), force=",".join(map(str, FORCES)))
    runs = []
    for _ in range(2):
        controller = SnakeController()
        outcome = play(decoder, PRESSES_URL + "&speed=max", controller,
                       on_update=lambda e, u, t: t < scene.duration_s)  # fmt: skip
        runs.append((controller.history, outcome))
    history, outcome = runs[0]
    assert [c.direction for c in history] == expected_commands()
    regions = [c.region for c in history]
    assert regions == [2, 6, 8, 4, 5, 4, 5, 8, 6]  # the 0.6 N press on 2 gave nothing
    assert all(c.force_n > 1.0 for c in history)
    # each command comes from its own press: within 0.5 s of that press's start
    starts = [s for s, f in zip(scene.presses.start, FORCES, strict=True) if f > 1.0]
    assert all(0 < c.time - s < 0.5 for c, s in zip(history, starts, strict=True))
    # deterministic: the same commands and game twice (the sample grid moves with the
    # moment streaming starts, so times differ by up to a sample), and the game the
    # script gives by hand
    assert [(c.direction, c.region) for c in runs[1][0]] == [
        (c.direction, c.region) for c in history
    ]
    assert runs[1][1] == outcome == replay_by_hand(scene, expected_commands())
    # the snake runs into the left wall at 14 s; the "down" press at 17.5 s starts a new
    # game, "right" turns it: 8 moves
    assert outcome.alive and outcome.steps == 8 and outcome.head == (12, 10)


@pytest.mark.slow
def test_no_command_below_the_threshold(press_model) -> None:
    decoder = Decoder.load(press_model)
    url = "sim://?scene=presses&order=up,left,down,right,centre&force=0.5&seed=0&speed=max"
    controller = SnakeController()
    end = make_scene("presses", force="0.5").duration_s
    outcome = play(decoder, url, controller, on_update=lambda e, u, t: t < end)
    assert controller.history == [] and not controller.started and outcome.steps == 0
