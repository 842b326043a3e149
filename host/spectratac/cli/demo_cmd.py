"""`spectratac demo`: the built-in simulated sensor, streamed live while a scene presses each of
the nine regions in turn (the firmware core runs natively on the digital twin)."""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from spectratac.cli import EXIT_FAILURE, EXIT_OK
from spectratac.cli.output import Table


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("demo", help="stream the simulated sensor while it is pressed")
    p.add_argument("--seconds", type=float, default=10.0, help="how long to stream")
    p.add_argument("--speed", default="1", help="time scale of the simulation, or 'max'")
    p.add_argument("--seed", type=int, default=3)
    p.add_argument("--every", type=int, default=4, help="print every Nth sample")
    p.add_argument("--json", action="store_true", help="only a JSON summary at the end")
    p.set_defaults(func=_demo)


def _demo(args: argparse.Namespace) -> int:
    from spectratac.device import Sensor
    from spectratac.sim.scenes import make_scene
    from spectratac.twin.geometry import region_of

    period = args.seconds / 9
    url = f"sim://?scene=tour&period={period:.4f}&seed={args.seed}&speed={args.speed}"
    scene = make_scene("tour", period=f"{period:.4f}")  # the same scene, for ground truth
    expected = int(args.seconds * 20)
    table = Table(["t_s", "pressed", "dC0_%", "dC1_%", "dC2_%", "strongest"], width=9)
    rows: list[np.ndarray] = []
    baseline = None
    t0 = time.monotonic()
    with Sensor.open(url) as sensor:
        if not args.json:
            print(
                f"{url}: {sensor.info.board}, firmware build {sensor.info.build_id}; "
                f"pressing regions 1-9 over {args.seconds:.0f} s of device time"
            )
        sensor.configure(integration_ms=50)
        sensor.start()
        while sum(len(r) for r in rows) < expected:
            batch = sensor.read(args.every, timeout=2.0)
            if not len(batch):
                break
            rows.append(batch)
            clear = batch["counts"][:, :, 3].astype(float)
            if baseline is None:
                baseline = clear[0]
            t_s = float(batch["device_time_us"][-1]) / 1e6  # sim devices boot at scene time 0
            contact = scene.contact(np.array([t_s]))
            region = int(region_of(contact.x, contact.y)[0]) if contact.in_contact[0] else 0
            change = 100 * (clear[-1] / baseline - 1)
            if not args.json:
                table.row(
                    [
                        f"{t_s:.2f}",
                        region or "-",
                        *(f"{c:+.1f}" for c in change),
                        f"sensor {int(np.argmax(np.abs(change)))}",
                    ]
                )
        sensor.stop()
        stats = sensor.stats.as_dict()
    got = sum(len(r) for r in rows)
    summary = {
        "samples": got,
        "expected": expected,
        "wall_s": round(time.monotonic() - t0, 2),
        "stats": stats,
    }
    print(
        json.dumps(summary)
        if args.json
        else f"{got}/{expected} samples in {summary['wall_s']} s; link: {stats}"
    )
    ok = got >= expected and stats["crc_errors"] == 0 and stats["sample_gaps"] == 0
    return EXIT_OK if ok else EXIT_FAILURE
