"""The game loop without a UI: sensor -> decoder -> controller, until told to stop.

    controller = SnakeController()
    outcome = play(Decoder.load("model.stac"), "sim://?scene=presses&speed=max", controller,
                   seconds=22, on_command=print)

The controller runs on the device's clock (`Sample.device_time_us`), so a simulated scene
played at `speed=max` gives the same commands and the same game as played in real time.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from spectratac.apps.sensor_setup import SampleTap, open_for_decoder
from spectratac.apps.snake.control import Command
from spectratac.apps.snake.controller import SnakeController, Update
from spectratac.apps.snake.game import Outcome

# (estimate, what it changed, sensor time s) -> False to stop
OnUpdate = Callable[[Any, Update, float], bool]


def play(
    decoder: Any,
    url: str,
    controller: SnakeController,
    *,
    seconds: float = 0.0,
    keep_config: bool = False,
    timeout: float = 2.0,
    stall_timeout: float | None = None,
    on_command: Callable[[Command], None] | None = None,
    on_update: OnUpdate | None = None,
) -> Outcome:
    """Play until `seconds` of the sensor's clock have passed (0: until `on_update` says
    stop or the link ends); returns the game's outcome."""
    with open_for_decoder(
        decoder, url, keep_config=keep_config, timeout=timeout, stall_timeout=stall_timeout
    ) as sensor:
        tap = SampleTap(sensor)
        t0: float | None = None
        for estimate in decoder.stream(tap):
            t = tap.last.device_time_us / 1e6
            t0 = t if t0 is None else t0
            update = controller.feed(estimate, t)
            if on_command is not None:
                for command in update.commands:
                    on_command(command)
            if on_update is not None and on_update(estimate, update, t) is False:
                break
            if seconds and t - t0 >= seconds:
                break
    return controller.game.outcome()
