"""`spectratac live [MODEL] URL [--ft FT_URL]`: the real-time force tracking page.

Serves a local web page (127.0.0.1 only; the URL is printed and opened in the browser
unless --no-browser) with rolling plots of the decoded Fx, Fy, Fz and torques at the
sensor's rate; with a reference F/T sensor (--ft, or a sim:// URL with ft=...), the
reference drawn dashed on the same axes, time-aligned with the clock fit the dataset
builder uses, and a running MAE per axis, overall and during contact. Every plot zooms,
pans and reads values out at the cursor. Beside them: the sensor face with the decoded
region lit by its probability, contact / out-of-distribution / invalid flags, the raw
counts plotted per sensor and channel with saturation and dark bands, link statistics and
the latency to the browser; pause, rescale, and "save the last N seconds" as MCAP or CSV
(into --output). The Snake tab plays the paper's game on the same estimates.
Without a MODEL the page shows the raw counts and the reference F/T only (before training).
With --foxglove the same streams (raw counts, estimates, reference F/T) go to Foxglove too.

    spectratac live model.stac /dev/ttyACM0 --ft netft://192.168.1.1
    spectratac live /dev/ttyACM0 --ft netft://192.168.1.1      # no model yet
    spectratac live model.stac "sim://?scene=presses&speed=1&ft=bota"
    spectratac live model.stac "sim://?scene=presses&speed=1&ft=bota" --foxglove
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from spectratac.cli.live_page import (
    add_device_options,
    add_game_options,
    controller_from_args,
    serve,
)
from spectratac.cli.options import add_duration


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "live",
        help="live web page: force plots vs reference F/T, region map, raw counts, Snake",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_device_options(p, model_optional=True)
    p.add_argument(
        "--ft",
        metavar="FT_URL",
        help="reference F/T URL (netft://, bota://, csv://, rosbag://, sim://)",
    )
    p.add_argument("--port", type=int, default=0, help="port on 127.0.0.1 (0: any free one)")
    p.add_argument("--no-browser", action="store_true", help="only print the page's URL")
    p.add_argument("--foxglove", type=int, nargs="?", const=8765, default=None, metavar="PORT",
                   help="also serve the streams to Foxglove (WebSocket on 127.0.0.1:PORT; "
                   "default port %(const)s)")  # fmt: skip
    p.add_argument("-o", "--output", type=Path, default=Path("live-clips"),
                   help="folder for saved clips (default: %(default)s)")  # fmt: skip
    p.add_argument(
        "--history",
        type=float,
        default=120.0,
        help="seconds kept for 'save the last N seconds' (default: %(default)s)",
    )
    add_duration(p, 0.0, "serve for this long, then stop (0 or inf: until Ctrl-C)")
    p.add_argument("--json", action="store_true", help="print the page's URL as a JSON line")
    add_game_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    return serve(args, controller_from_args(args), tab="live")
