"""`spectratac sim serve`: expose a simulated device as a pty or TCP socket."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from spectratac.cli.exit_codes import ExitCode
from spectratac.errors import SpectraTacError


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("sim", help="the simulated device (real firmware on the twin)")
    verbs = p.add_subparsers(dest="sim_verb", metavar="<sim verb>", required=True)
    serve = verbs.add_parser("serve", help="serve a simulated device on a pty or TCP port")
    where = serve.add_mutually_exclusive_group()
    where.add_argument("--pty", action="store_true", help="serial device (default)")
    where.add_argument("--tcp", type=int, metavar="PORT", help="TCP port on 127.0.0.1")
    serve.add_argument("--link", type=Path, help="with --pty: keep a symlink to the pty here")
    serve.add_argument(
        "--replug-after", type=float, default=1.0, help="seconds a SIGUSR1 'unplug' lasts"
    )
    serve.add_argument("--scene", default="tour", help="idle, press, tour, calibration, …")
    serve.add_argument("--seed", type=int, default=0)
    serve.add_argument("--speed", default="1", help="time scale, or 'max'")
    serve.add_argument("--absent", default="", help="sensors that do not answer, e.g. 1,2")
    serve.add_argument("--json", action="store_true", help="announce the address as JSON")
    serve.set_defaults(func=_serve)


def _serve(args: argparse.Namespace) -> int:
    from spectratac.sim.serve import serve_pty, serve_tcp
    from spectratac.sim.url import parse_sim_url

    url = f"sim://?scene={args.scene}&seed={args.seed}&speed={args.speed}"
    if args.absent:
        url += f"&absent={args.absent}"
    try:
        opts = parse_sim_url(url)
    except ValueError as exc:
        raise SpectraTacError(str(exc)) from None

    def announce(address: str) -> None:
        shown = str(args.link) if args.link else address
        if args.json:
            print(json.dumps({"url": shown, "device": address, "sim": url}), flush=True)
        else:
            print(f"serving {url} at {shown} (Ctrl-C to stop)", flush=True)

    try:
        if args.tcp is not None:
            serve_tcp(opts, args.tcp, announce=announce)
        else:
            serve_pty(opts, link=args.link, replug_after=args.replug_after, announce=announce)
    except KeyboardInterrupt:
        pass
    except OSError as exc:
        raise SpectraTacError(f"cannot serve: {exc}") from None
    return ExitCode.OK
