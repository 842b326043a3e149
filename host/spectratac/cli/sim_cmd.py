"""`spectratac sim serve|ft`: a simulated device on a pty or TCP socket, and a simulated
reference F/T sensor served to other programs.

    spectratac sim serve --pty --link /tmp/tac0
    spectratac sim ft --netft --port 49152 --scene calibration --speed 1
"""

from __future__ import annotations

import argparse
import json
import signal
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
    ft = verbs.add_parser("ft", help="serve a simulated reference F/T sensor")
    kind = ft.add_mutually_exclusive_group(required=True)
    kind.add_argument("--netft", action="store_true", help="ATI Net F/T: RDT on UDP + HTTP")
    kind.add_argument("--bota", action="store_true", help="Bota serial sensor on a pty")
    ft.add_argument("--port", type=int, default=49152, help="netft: UDP port (0: any free)")
    ft.add_argument("--link", type=Path, help="bota: keep a symlink to the pty here")
    ft.add_argument("--scene", default="calibration", help="idle, press, tour, calibration, …")
    ft.add_argument("--seed", type=int, default=0)
    ft.add_argument("--speed", default="1", help="time scale (a number: F/T needs a clock)")
    ft.add_argument("--rate", type=float, default=1000.0, help="samples per scene second")
    ft.add_argument("--loss", type=float, default=0.001, help="fraction of samples lost")
    ft.add_argument("--offset", type=float, default=0.05, help="sensor clock offset, s")
    ft.add_argument("--drift", type=float, default=1e-4, help="sensor clock drift (ratio - 1)")
    ft.add_argument("--json", action="store_true", help="announce the address as JSON")
    ft.set_defaults(func=_serve_ft)


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


def _serve_ft(args: argparse.Namespace) -> int:
    from spectratac.record import StopRequest, stopping_on
    from spectratac.sim.ft_serve import serving, simulated_ft_url

    kind = "netft" if args.netft else "bota"
    url = simulated_ft_url(
        kind,
        scene=args.scene,
        seed=args.seed,
        speed=args.speed,
        rate=args.rate,
        loss=args.loss,
        offset=args.offset,
        drift=args.drift,
    )
    # SIGTERM sets a lock-free StopRequest: Event.set() in a handler could deadlock
    try:
        with (
            StopRequest() as stop,
            stopping_on(stop, (signal.SIGTERM,)),
            serving(url, port=args.port, link=args.link) as server,
        ):
            if args.json:
                print(json.dumps({"url": server.url, "kind": kind, "sim": url}), flush=True)
            else:
                print(f"serving simulated {kind} at {server.url} (Ctrl-C to stop)", flush=True)
            stop.wait()
    except KeyboardInterrupt:
        pass
    except OSError as exc:
        raise SpectraTacError(
            f"cannot serve a simulated F/T: {exc}; pick another --port (0: any free)"
        ) from None
    return ExitCode.OK
