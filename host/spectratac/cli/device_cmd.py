"""`spectratac info URL` and `spectratac stream URL`: talk to a device from the shell."""

from __future__ import annotations

import argparse
import json
import sys
import time

from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.options import add_count, add_device_url, add_row_format
from spectratac.cli.output import RowWriter, reader_gone
from spectratac.errors import SpectraTacError
from spectratac.hardware.veml3328 import INTEGRATION_MS


def register(subparsers: argparse._SubParsersAction) -> None:
    info = subparsers.add_parser("info", help="show a device's identity, versions and limits")
    add_device_url(info)
    info.add_argument("--json", action="store_true", help="machine-readable output")
    info.set_defaults(func=_info)
    stream = subparsers.add_parser("stream", help="stream samples to the terminal")
    add_device_url(stream)
    add_count(stream, 20, "samples to print (0: forever)")
    add_row_format(stream)
    stream.add_argument("--integration-ms", type=int, default=50, choices=INTEGRATION_MS)
    stream.add_argument("--duty", type=int, default=500, help="white LED duty, permille")
    stream.set_defaults(func=_stream)


def _info(args: argparse.Namespace) -> int:
    from spectratac.device import Sensor
    from spectratac.protocol import messages as m

    with Sensor.open(args.url, timeout=args.timeout) as sensor:
        info = sensor.info
        status = sensor.status()
    caps = [c.name for c in m.Capabilities if info.capabilities & c]
    row = info.to_dict() | {
        "definition_hash": f"0x{info.definition_hash:08X}",
        "capabilities": caps,
        "sensors_present": [k for k in range(3) if info.sensor_present >> k & 1],
        "uptime_ms": status.uptime_ms,
    }
    if args.json:
        print(json.dumps(row))
        return ExitCode.OK
    print(
        f"{args.url}: {info.board} firmware {'.'.join(map(str, info.firmware_version))} "
        f"({info.build_id}), protocol {info.protocol_major}.{info.protocol_minor}"
    )
    print(f"  unique id        {info.device_uid.hex()}")
    print(f"  definition hash  0x{info.definition_hash:08X}")
    print(
        f"  sensors present  {row['sensors_present']} of {info.sensor_count}, "
        f"{info.channels_per_sensor} channels each"
    )
    print(f"  capabilities     {', '.join(caps)}")
    print(
        f"  limits           {info.max_led_steps} LED steps, max frame {info.max_frame} B, "
        f"baud {info.baud or 'n/a'}"
    )
    print(f"  uptime           {status.uptime_ms / 1000:.1f} s")
    return ExitCode.OK


CHANNELS = ("R", "G", "B", "C", "IR")


def _stream(args: argparse.Namespace) -> int:
    from spectratac.device import Sensor

    if args.count < 0:
        raise SpectraTacError("--count must be >= 0 (0 streams until interrupted)")
    if not 0 <= args.duty <= 1000:
        raise SpectraTacError("--duty is in permille: 0..1000")
    columns = ["seq", "t_ms", "step", *(f"s{k}{c}" for k in range(3) for c in CHANNELS), "status"]
    printed = 0
    with Sensor.open(args.url, timeout=args.timeout) as sensor:
        sensor.configure(integration_ms=args.integration_ms, leds=[[[args.duty] * 3] * 3])
        writer = RowWriter(columns, args.format, width=7)
        sensor.start()
        t0 = time.monotonic()
        try:
            for sample in sensor:
                values = [
                    sample.sequence,
                    sample.device_time_us // 1000,
                    sample.step,
                    *(v for counts in sample.counts for v in counts),
                ]
                status = "".join(f"{s:x}" for s in sample.status)
                record = dict(zip(columns, [*values, list(sample.status)], strict=True))
                writer.row([*values, status], record)
                printed += 1
                if args.count and printed >= args.count:
                    break
        except BrokenPipeError:
            reader_gone()
            return ExitCode.OK
        finally:
            if not sensor.stats.reconnects:
                sensor.stop()
        stats = sensor.stats
    rate = printed / max(time.monotonic() - t0, 1e-9)
    print(
        f"{printed} samples ({rate:.1f}/s); CRC errors {stats.crc_errors}, gaps "
        f"{stats.sample_gaps}, overflows {stats.buffer_overflows}",
        file=sys.stderr,
    )
    return ExitCode.OK if args.count == 0 or printed >= args.count else ExitCode.FAILURE
