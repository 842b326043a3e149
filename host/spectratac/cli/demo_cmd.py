"""`spectratac demo`: the full job on the built-in simulated sensor (record a calibration
session with a simulated reference F/T sensor, build the dataset, train and evaluate the
decoders; see spectratac.apps.calibration_demo). `spectratac demo --live` instead streams the
simulated sensor live while a scene presses each of the nine regions in turn.

The output folder (demo-output) is written beside its target and renamed into place, marked as
the demo's; --force (`make demo`) replaces only such a folder, or one holding exactly the
demo's own files (DEMO_FILES: folders made before the marker existed)."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.options import add_duration, add_output
from spectratac.cli.output import Table
from spectratac.cli.outputs import check_output, new_folder
from spectratac.cli.values import speed

VERB = "demo"
#: What a demo folder holds: recognised as the demo's own even without the marker.
DEMO_FILES = frozenset(
    {"session.mcap", "data.npz", "paper.stac", "paper.random.stac", "best.stac",
     "best.random.stac", "report-paper", "report-best"}
)  # fmt: skip


def demo_files(names: list[str]) -> bool:
    """Whether an unmarked folder holds only what an earlier demo wrote (and its recording)."""
    return "session.mcap" in names and set(names) <= DEMO_FILES


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "demo", help="record, build, train and evaluate on the simulated sensor (or --live)"
    )
    add_output(p, type=Path, default=Path("demo-output"), help="output folder")
    add_duration(p, None, "scene length (default 600: the calibration; --live: 10)")
    p.add_argument("--speed", default=None, type=speed,
                   help="time scale (default 60; --live: 1 or 'max')")  # fmt: skip
    p.add_argument("--epochs", type=int, default=40, help="training epochs per decoder")
    p.add_argument("--oracle-samples", type=int, default=300, help="rows the oracle decodes")
    p.add_argument("--live", action="store_true", help="only stream live (the first demo)")
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--every", type=int, default=4, help="--live: print every Nth sample")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true", help="only a JSON summary at the end")
    p.set_defaults(func=_dispatch)


def _dispatch(args: argparse.Namespace) -> int:
    if args.live:
        args.speed = args.speed or "1"
        args.seed = 3 if args.seed is None else args.seed
        args.duration = args.duration or 10.0
        return _demo(args)
    from spectratac.apps.calibration_demo import DEMO_SPEED, DemoOptions, run_demo
    from spectratac.cli.eta import announce
    from spectratac.studies.cost_model import demo_estimate
    from spectratac.studies.oracle_floor import OracleFloor

    out = check_output(args.output, args.force, verb=VERB, folder=True, recognise=demo_files)
    if not args.json:
        print("estimating how long the demo takes on this machine…", file=sys.stderr, flush=True)
    estimate = demo_estimate(
        args.duration or 600.0,
        float(args.speed or DEMO_SPEED),
        args.epochs,
        args.oracle_samples,
        seed=0 if args.seed is None else args.seed,
    )
    if not args.json:
        announce("the demo", estimate)
    opts = DemoOptions(
        out=out,
        scene_s=args.duration or 600.0,
        speed=float(args.speed or DEMO_SPEED),
        seed=0 if args.seed is None else args.seed,
        epochs=args.epochs,
        floor=OracleFloor(args.oracle_samples) if args.oracle_samples > 0 else None,
        progress=not (args.no_progress or args.json),
        estimates=dict(estimate.parts_s),
    )
    with new_folder(out, VERB, recognise=demo_files) as staged:
        opts.out, opts.named = staged, out
        summary = run_demo(opts, say=(lambda _: None) if args.json else print)
    opts.out = out
    summary["estimate"] = estimate.as_dict()
    if args.json:
        print(json.dumps(summary))
    else:
        t = summary["timings_s"]
        print(
            f"done in {t['total_s']:.0f} s (record {t['record_s']:.0f} s, dataset "
            f"{t['dataset_s']:.0f} s, train + evaluate {t['train_evaluate_s']:.0f} s; "
            f"estimated {estimate.total_s:.0f} s)"
        )
        print(
            f"watch the model you just trained live (force vs reference F/T, regions, Snake):\n"
            f'  spectratac live {opts.out / "best.stac"} "sim://?scene=presses&speed=1&ft=bota"'
        )
    return ExitCode.OK


def _demo(args: argparse.Namespace) -> int:
    from spectratac.device import Sensor
    from spectratac.sim.named_scenes import make_scene
    from spectratac.twin.geometry import region_of

    period = args.duration / 9
    url = f"sim://?scene=tour&period={period:.4f}&seed={args.seed}&speed={args.speed}"
    scene = make_scene("tour", period=f"{period:.4f}")  # the same scene, for ground truth
    expected = int(args.duration * 20)
    table = Table(["t_s", "pressed", "dC0_%", "dC1_%", "dC2_%", "strongest"], width=9)
    rows: list[np.ndarray] = []
    baseline = None
    t0 = time.monotonic()
    with Sensor.open(url) as sensor:
        if not args.json:
            print(
                f"{url}: {sensor.info.board}, firmware build {sensor.info.build_id}; "
                f"pressing regions 1-9 over {args.duration:.0f} s of device time"
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
    print(json.dumps(summary) if args.json else live_summary(summary))
    ok = got >= expected and stats["crc_errors"] == 0 and stats["sample_gaps"] == 0
    return ExitCode.OK if ok else ExitCode.FAILURE


def live_summary(summary: dict[str, Any]) -> str:
    """`demo --live`'s last lines for a person (--json prints `summary` itself): samples
    against the expected count, and the link's health with only its non-zero counters named.

    >>> print(live_summary({"samples": 200, "expected": 200, "wall_s": 10.1,
    ...     "stats": {"frames_received": 205, "samples_received": 200, "crc_errors": 0,
    ...               "sample_gaps": 0, "logs": 2}}))  # fmt: skip
    200 of 200 samples in 10.1 s: complete
    link: 205 frames received, 200 samples received, 2 logs; no CRC errors, no sample gaps
    """
    stats = summary["stats"]
    seen = [f"{v} {k.replace('_', ' ')}" for k, v in stats.items() if v]
    health = [f"no {name}" for key, name in _HEALTH.items() if key in stats and not stats[key]]
    got, expected = summary["samples"], summary["expected"]
    verdict = "complete" if got >= expected else f"{expected - got} missing"
    return (
        f"{got} of {expected} samples in {summary['wall_s']} s: {verdict}\n"
        f"link: {', '.join(seen) or 'nothing received'}; {', '.join(health)}"
    )


#: The counters whose zero the live demo's verdict rests on, as a person names them.
_HEALTH = {"crc_errors": "CRC errors", "sample_gaps": "sample gaps"}
