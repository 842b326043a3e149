"""`spectratac ft info|stream URL`: reference F/T sensors from the shell (any URL
`spectratac.ft.FTSensor.open` takes; `spectratac sim ft` serves simulated ones).

    spectratac ft info netft://192.168.1.1 --json
    spectratac ft stream bota:///dev/ttyUSB0 --count 1000 --format csv > ft.csv
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

import numpy as np

from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.options import (
    add_count,
    add_device_url,
    add_duration,
    add_row_format,
    stop_count,
)
from spectratac.cli.output import RowWriter, reader_gone
from spectratac.errors import printable
from spectratac.hardware.generated import vocabulary as vocab

URL_HELP = (
    "netft://HOST?cpf=&cpt=, bota:///dev/ttyUSB0, csv://FILE, "
    "rosbag://BAG?topic=/ft_sensor/wrench, or sim://?…&ft=netft|bota"
)
COLUMNS = ("sensor_time", "host_time", "sequence", *vocab.FT_AXES, "status")


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("ft", help="reference force/torque sensors (Net F/T, Bota, CSV)")
    verbs = p.add_subparsers(dest="ft_verb", metavar="<ft verb>", required=True)
    info = verbs.add_parser("info", help="identity, scaling and rate of an F/T sensor")
    add_device_url(info, URL_HELP)
    add_count(info, 200, "records to read for a check (0: none)")
    info.add_argument("--json", action="store_true", help="machine-readable output")
    info.set_defaults(func=_info)
    stream = verbs.add_parser("stream", help="print F/T records")
    add_device_url(stream, URL_HELP, stalls=True)
    add_count(stream, None, "records to print (0: forever; default 20 unless --duration)")
    add_duration(stream, None, "stop after S seconds of the F/T sensor's clock")
    add_row_format(stream)
    stream.set_defaults(func=_stream)


# ------------------------------------------------------------------ ft info / stream
def _info(args: argparse.Namespace) -> int:
    from spectratac.ft import open_ft

    with open_ft(args.url, timeout=args.timeout) as ft:
        rows = ft.read(max(args.count, 0), timeout=args.timeout) if args.count else None
        report: dict[str, Any] = {"url": args.url, "info": ft.info.as_dict()}
        if rows is not None:
            report |= _check(rows)
        report["stats"] = ft.stats.as_dict()
    if args.json:
        print(json.dumps(report, default=str))
        return ExitCode.OK
    info = report["info"]
    # model, serial and extras come from the device: never let them drive the terminal
    print(printable(f"{args.url}: {info['model']} ({info['kind']}) {info['serial']}".rstrip()))
    print(f"  rate             {info['rate_hz']:g} Hz")
    print(f"  counts per unit  {info['counts_per_force']:g} /N, {info['counts_per_torque']:g} /N·m")
    for key, value in info["extra"].items():
        print(printable(f"  {key:<16} {value}"))
    if rows is not None:
        mean = " ".join(f"{v:+.3f}" for v in report["mean_wrench"])
        print(
            f"  read             {report['records']} records, {report['measured_rate_hz']:.1f} Hz"
        )
        print(f"  mean wrench      {mean}  (N, N·m)")
        print(f"  status words     {report['status_nonzero']} non-zero")
    print("  link             " + ", ".join(f"{k} {v}" for k, v in report["stats"].items()))
    return ExitCode.OK


def _check(rows: np.ndarray) -> dict[str, Any]:
    rate = 0.0
    if len(rows) > 1 and np.ptp(rows["sensor_time"]) > 0:
        rate = (len(rows) - 1) / float(np.ptp(rows["sensor_time"]))
    mean = rows["wrench"].mean(axis=0).tolist() if len(rows) else [float("nan")] * 6
    return {
        "records": len(rows),
        "measured_rate_hz": rate,
        "mean_wrench": mean,
        "status_nonzero": int(np.count_nonzero(rows["status"])),
    }


def _stream(args: argparse.Namespace) -> int:
    from spectratac.ft import FTStalledError, FTTimeoutError, open_ft

    count = stop_count(args.count, args.duration)
    printed = 0
    first: float | None = None
    with open_ft(args.url, timeout=args.timeout) as ft:
        writer = RowWriter(COLUMNS, args.format, width=10, table_cell=_rounded)
        # a quiet stream ends within the stall timeout: ten periods of the sensor, at least 5 s
        ft.stall_timeout = args.stall_timeout
        stall = ft.effective_stall_timeout
        try:
            while count == 0 or printed < count:
                want = 256 if count == 0 else min(256, count - printed)
                rows = ft.read(want, timeout=args.timeout if printed == 0 else stall)
                if len(rows) and args.duration is not None:
                    first = float(rows["sensor_time"][0]) if first is None else first
                    ended = rows["sensor_time"] - first >= args.duration  # the F/T's clock
                    if ended.any():
                        rows = rows[: int(np.argmax(ended))]
                        count = printed + len(rows)  # the last rows, then stop
                if len(rows) == 0:
                    if printed == 0:
                        raise FTTimeoutError(
                            f"no F/T records from {args.url} within {args.timeout:.1f} s"
                        )
                    if ft.streaming and not ft.ended:
                        raise FTStalledError(
                            f"{args.url} sent no F/T records for {stall:g} s after {printed}; "
                            f"check the sensor and its link, or allow a longer quiet with "
                            f"--stall-timeout S"
                        )
                    break
                for r in rows:
                    writer.row(_values(r))
                printed += len(rows)
                sys.stdout.flush()
        except BrokenPipeError:
            reader_gone()
            return ExitCode.OK
        stats = ft.stats.as_dict()
    print(f"{printed} records; " + ", ".join(f"{k} {v}" for k, v in stats.items()), file=sys.stderr)
    return ExitCode.OK if count == 0 or printed >= count else ExitCode.FAILURE


def _values(r: np.void) -> list[float | int]:
    return [
        float(r["sensor_time"]),
        float(r["host_time"]),
        int(r["sequence"]),
        *map(float, r["wrench"]),
        int(r["status"]),
    ]


def _rounded(v: object) -> object:
    return f"{v:.4f}" if isinstance(v, float) else v
