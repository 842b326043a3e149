"""What `spectratac live` and `spectratac snake --web` share: the model and device options,
the Snake game's options and its controller, and serving the live page of a session."""

from __future__ import annotations

import argparse
import json
import math
import threading
import webbrowser
from pathlib import Path
from typing import Any

from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.options import add_decoding_checks, add_device_url, load_decoder
from spectratac.errors import SpectraTacError


def add_device_options(p: argparse.ArgumentParser, *, model_optional: bool = False) -> None:
    """Model and device options shared by the live verbs (as `spectratac decode` has them);
    `model_optional`: the verb also runs without a model (the live page: raw counts)."""
    if model_optional:
        p.add_argument("model", nargs="?", help="decoder file (.stac); without it: raw counts "
                       "and the reference only")  # fmt: skip
    else:
        p.add_argument("model", help="decoder file (.stac)")
    add_device_url(p, stalls=True)
    add_decoding_checks(p)


def add_game_options(p: argparse.ArgumentParser) -> None:
    """The options that set the Snake game up (`spectratac snake` and `spectratac live`)."""
    from spectratac.apps.snake.control import CONFIRM, HYSTERESIS_N, THRESHOLD_N
    from spectratac.apps.snake.controller import TICK_S

    g = p.add_argument_group("Snake game")
    g.add_argument(
        "--threshold",
        type=float,
        default=THRESHOLD_N,
        help="normal force (N) a press must exceed to command (default: %(default)s)",
    )
    g.add_argument(
        "--hysteresis",
        type=float,
        default=HYSTERESIS_N,
        help="re-arm once the force falls this far below the threshold (N)",
    )
    g.add_argument(
        "--confirm",
        type=int,
        default=CONFIRM,
        help="estimates the region must stay the same before a press is decided",
    )
    g.add_argument(
        "--map",
        default="cross",
        dest="mapping",
        help="region -> direction: cross | keypad | pairs like 1=up,3=right",
    )
    g.add_argument("--tick", type=float, default=TICK_S, help="seconds per snake move")
    g.add_argument("--grid", default="16x12", help="board columns x rows")
    g.add_argument("--game-seed", type=int, default=0, help="seed of the food positions")
    g.add_argument("--accept-ood", action="store_true",
                   help="let out-of-distribution estimates command too")  # fmt: skip


def controller_from_args(args: argparse.Namespace) -> Any:
    from spectratac.apps.snake.control import CommandDetector
    from spectratac.apps.snake.controller import SnakeController
    from spectratac.apps.snake.game import SnakeGame
    from spectratac.apps.snake.mapping import DirectionMap

    try:
        width, height = (int(v) for v in args.grid.lower().split("x"))
    except ValueError:
        raise SpectraTacError(f"--grid {args.grid!r}: give columns x rows, e.g. 16x12") from None
    detector = CommandDetector(
        DirectionMap.parse(args.mapping),
        threshold_n=args.threshold,
        hysteresis_n=args.hysteresis,
        confirm=args.confirm,
        accept_ood=args.accept_ood,
    )
    try:
        return SnakeController(SnakeGame(width, height, seed=args.game_seed), detector,
                               tick_s=args.tick)  # fmt: skip
    except ValueError as exc:
        raise SpectraTacError(f"--tick: {exc}") from None


def serve(args: argparse.Namespace, controller: Any, tab: str) -> int:
    """Serve the page of a live session on `args` until Ctrl-C or --duration."""
    from spectratac.apps.live.server import LiveServer, bind
    from spectratac.apps.live.session import NO_MODEL, TRAIN_HINT, LiveSession

    if not args.duration >= 0:  # nan too (the option's type refuses it already)
        raise SpectraTacError("--duration must be >= 0 (0 or inf: until Ctrl-C)")
    if args.model is None and args.url.endswith(".stac"):
        raise SpectraTacError(f"{args.url} is a model: give the device URL after it")
    decoder = None if args.model is None else load_decoder(args)
    session = LiveSession(
        decoder,
        args.url,
        ft_url=getattr(args, "ft", None),  # None: the F/T the link pairs, if any
        keep_config=args.keep_config,
        timeout=args.timeout,
        stall_timeout=args.stall_timeout,
        history_s=getattr(args, "history", 120.0),
        snake=controller,
        out_dir=getattr(args, "output", Path("live-clips")),
        model_path=None if args.model is None else str(args.model),
    )
    server = LiveServer(session, bind(args.port))
    url = server.url + ("#snake" if tab == "snake" else "")
    bridge = _foxglove_bridge(getattr(args, "foxglove", None), session)
    timer: threading.Timer | None = None
    try:
        if args.duration and math.isfinite(args.duration):  # inf, like 0: until Ctrl-C
            # a daemon timer, cancelled below: Ctrl-C never waits for it to fire
            timer = threading.Timer(args.duration, setattr, (server.server, "should_exit", True))
            timer.daemon = True
            timer.start()
        if getattr(args, "json", False):
            line = {"url": url, "model": session.model_path}
            print(json.dumps(line | ({"foxglove": bridge.url} if bridge else {})), flush=True)
        else:
            print(f"SpectraTac live: {url}  (Ctrl-C to stop)", flush=True)
            if decoder is None:
                print(f"{NO_MODEL}; {TRAIN_HINT}", flush=True)
            if bridge is not None:
                print(f"Foxglove bridge: {bridge.url}  (Foxglove: Open connection)", flush=True)
        if not args.no_browser:
            opener = threading.Timer(0.5, webbrowser.open, args=(url,))
            opener.daemon = True
            opener.start()
        server.run()
    finally:
        if timer is not None:
            timer.cancel()
        if bridge is not None:
            bridge.close()
    return ExitCode.OK


def _foxglove_bridge(port: int | None, session: Any) -> Any:
    """The Foxglove bridge on `port` fed by the session's history (None: no bridge)."""
    if port is None:
        return None
    from spectratac.apps.foxglove_bridge import FoxgloveBridge

    bridge = FoxgloveBridge(port).start()
    session.history.add_tap(bridge)
    return bridge
