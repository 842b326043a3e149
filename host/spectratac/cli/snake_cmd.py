"""`spectratac snake MODEL URL`: the paper's Snake game, steered by pressing the sensor.

The nine contact regions map to directions (keypad layout: 2 up, 4 left, 6 right, 8 down,
5 the neutral centre; corners neutral by default, `--map keypad` gives them to the top and
bottom rows, or give region=direction pairs). A command fires only when the normal force
exceeds `--threshold` (the paper's 1.0 N); it re-arms below threshold − `--hysteresis`,
so one press gives one command. The snake waits for the first command, then moves one
cell every `--tick` seconds of the sensor's clock.

Runs in the terminal (curses: works over SSH; q quits, r restarts), or with `--web` in the
live page's Snake tab, or with `--json` headless, one JSON line per command.

    spectratac snake model.stac /dev/ttyACM0
    spectratac snake model.stac "sim://?scene=presses&speed=1"         # a scripted demo
    spectratac snake model.stac "sim://?scene=presses&speed=max" --json --duration 22
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.live_page import (
    add_device_options,
    add_game_options,
    controller_from_args,
    serve,
)
from spectratac.cli.options import add_duration, load_decoder
from spectratac.errors import SpectraTacError


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "snake",
        help="play Snake by pressing the sensor (terminal, --web page, or --json)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_device_options(p)
    add_duration(p, 0.0, "stop after this many seconds of the sensor's clock (0: until quit)")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--web", action="store_true", help="play in the live page's Snake tab")
    mode.add_argument(
        "--json",
        action="store_true",
        help="no UI: one JSON line per command, then the game's outcome",
    )
    p.add_argument("--port", type=int, default=0, help="--web: port on 127.0.0.1 (0: any)")
    p.add_argument("--no-browser", action="store_true", help="--web: do not open a browser")
    add_game_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.duration < 0:
        raise SpectraTacError("--duration must be >= 0 (0: until quit)")
    controller = controller_from_args(args)
    if args.web:
        return serve(args, controller, tab="snake")
    decoder = load_decoder(args)
    from spectratac.apps.snake.play import play

    if args.json:
        outcome = play(decoder, args.url, controller, seconds=args.duration,
                       keep_config=args.keep_config, timeout=args.timeout,
                       stall_timeout=args.stall_timeout,
                       on_command=lambda c: print(json.dumps(c.as_dict()), flush=True))  # fmt: skip
        print(json.dumps({"outcome": outcome.__dict__}))
        return ExitCode.OK
    if not sys.stdout.isatty():
        raise SpectraTacError("the terminal game needs a terminal: use --json or --web")
    from spectratac.apps.snake.terminal import play_in_terminal

    outcome = play_in_terminal(decoder, args.url, controller, seconds=args.duration,
                               keep_config=args.keep_config, timeout=args.timeout,
                               stall_timeout=args.stall_timeout)  # fmt: skip
    print(f"score {outcome.score}, length {outcome.length}, {outcome.steps} moves"
          + ("" if outcome.alive else ", game over"))  # fmt: skip
    return ExitCode.OK
