"""`spectratac decode MODEL URL`: run a trained decoder live on a sensor.

Loads the model file (NumPy only: torch is never imported), configures the sensor as the
model was trained (integration time, gain, LED sequence; `--keep-config` uses the device's
own and refuses to decode if it differs), streams and prints one estimate per sample:
force (N), torque (N·m), contact region and its probability, contact and out-of-distribution
flags. Samples the decoder cannot use (LED sequence not complete yet, non-finite counts) are
printed as invalid, not dropped.

    spectratac decode model.stac "sim://?scene=tour&speed=1" --count 40
    spectratac decode model.stac /dev/ttyACM0 --seconds 60 --format jsonl > live.jsonl
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from typing import Any

from spectratac.apps.sensor_setup import sensor_settings
from spectratac.cli.output import Table
from spectratac.errors import SpectraTacError

# t_s: seconds since the first sample (host clock)
COLUMNS = ("t_s", "Fx", "Fy", "Fz", "Tx", "Ty", "Tz", "region", "p", "contact", "ood", "invalid")


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "decode",
        help="run a trained decoder live on a sensor: force, torque, region, flags",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("model", help="decoder file (.stac)")
    p.add_argument("url", help="serial port, socket://host:port, rfc2217://…, or sim://…")
    p.add_argument("--count", type=int, default=0, help="estimates to print (0: no limit)")
    p.add_argument("--seconds", type=float, default=0.0, help="stop after this long (0: never)")
    p.add_argument("--format", choices=("table", "csv", "jsonl"), default="table")
    p.add_argument(
        "--keep-config",
        action="store_true",
        help="do not configure the sensor; decode only if its configuration matches",
    )
    p.add_argument("--unit", help="unit id of the sensor (warns if the model is another unit's)")
    p.set_defaults(func=run)


def _cells(e: Any, t0: float) -> list[Any]:
    def num(v: float, fmt: str) -> str:
        return "nan" if math.isnan(v) else format(v, fmt)

    return [
        f"{e.time - t0:.3f}",
        *(num(float(v), ".3f") for v in e.force),
        *(num(float(v), ".4f") for v in e.torque),
        e.region,
        num(e.region_prob, ".2f"),
        int(e.contact),
        int(e.ood),
        int(e.invalid),
    ]


def _record(e: Any, t0: float) -> dict[str, Any]:
    def clean(v: float) -> float | None:
        return None if math.isnan(v) else round(float(v), 6)

    return {
        "t_s": round(e.time - t0, 6),
        "force": [clean(v) for v in e.force],
        "torque": [clean(v) for v in e.torque],
        "region": e.region,
        "region_prob": clean(e.region_prob),
        "contact": bool(e.contact),
        "contact_prob": clean(e.contact_prob),
        "ood": bool(e.ood),
        "invalid": bool(e.invalid),
        "std": None if e.std is None else [clean(v) for v in e.std],
    }


def run(args: argparse.Namespace) -> int:
    from spectratac.decode import Decoder
    from spectratac.device import Sensor

    if args.count < 0 or args.seconds < 0:
        raise SpectraTacError("--count and --seconds must be >= 0 (0: no limit)")
    decoder = Decoder.load(args.model, expect_unit=args.unit)
    settings = None if args.keep_config else sensor_settings(decoder.config)
    table = Table(COLUMNS, width=8) if args.format == "table" else None
    if args.format == "csv":
        print(",".join(COLUMNS))
    counts = {"estimates": 0, "invalid": 0, "ood": 0, "contact": 0}
    t0 = time.monotonic()
    with Sensor.open(args.url) as sensor:
        if settings is not None:
            sensor.configure(**settings)
        sensor.start()
        try:
            first: float | None = None  # host time of the first sample: t_s counts from it
            for e in decoder.stream(sensor):
                first = e.time if first is None else first
                if table:
                    table.row(_cells(e, first))
                elif args.format == "csv":
                    print(",".join(map(str, _cells(e, first))))
                else:
                    print(json.dumps(_record(e, first)))
                counts["estimates"] += 1
                counts["invalid"] += int(e.invalid)
                counts["ood"] += int(e.ood)
                counts["contact"] += int(e.contact)
                if (args.count and counts["estimates"] >= args.count) or (
                    args.seconds and time.monotonic() - t0 >= args.seconds
                ):
                    break
        finally:
            if not sensor.stats.reconnects:
                sensor.stop()
    rate = counts["estimates"] / max(time.monotonic() - t0, 1e-9)
    print(
        f"{counts['estimates']} estimates ({rate:.1f}/s): {counts['contact']} in contact, "
        f"{counts['ood']} out of distribution, {counts['invalid']} invalid",
        file=sys.stderr,
    )
    return 0
