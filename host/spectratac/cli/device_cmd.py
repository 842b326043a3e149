"""`spectratac info URL` and `spectratac stream URL`: talk to a device from the shell.

`info` also says how the device came up (protocol 1.4): its reset cause and fault record, safe
mode, brown-out level and measured flash erase (device/boot_report.py).

`stream --estimates beside|instead` adds the device's own estimates (protocol 1.1, a model
uploaded with `spectratac model upload`): beside each sample's counts, or instead of them."""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Iterator
from typing import Any

from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.options import (
    add_count,
    add_device_url,
    add_duration,
    add_row_format,
    stop_count,
)
from spectratac.cli.output import RowWriter, reader_gone
from spectratac.errors import SpectraTacError
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.hardware.generated.veml3328 import INTEGRATION_MS


def register(subparsers: argparse._SubParsersAction) -> None:
    info = subparsers.add_parser("info", help="show a device's identity, versions and limits")
    add_device_url(info)
    info.add_argument("--json", action="store_true", help="machine-readable output")
    info.set_defaults(func=_info)
    stream = subparsers.add_parser("stream", help="stream samples to the terminal")
    add_device_url(stream, stalls=True)
    add_count(stream, None, "samples to print (0: forever; default 20 unless --duration)")
    add_duration(stream, None, "stop after S seconds of the sensor's clock")
    add_row_format(stream)
    stream.add_argument("--integration-ms", type=int, default=50, choices=INTEGRATION_MS)
    stream.add_argument("--duty", type=int, default=500, help="white LED duty, permille")
    stream.add_argument(
        "--estimates",
        choices=("off", "beside", "instead"),
        default="off",
        help="on-device estimates (force, torque, region) beside or instead of the counts; "
        "needs a device that decodes (see `spectratac model`)",
    )
    stream.set_defaults(func=_stream)


def _info(args: argparse.Namespace) -> int:
    from spectratac.device import Sensor
    from spectratac.device.boot_report import BootReport
    from spectratac.device.cycles import CycleFigures
    from spectratac.protocol.generated import messages as m

    with Sensor.open(args.url, timeout=args.timeout) as sensor:
        info = sensor.info
        status = sensor.status()
    caps = [c.name for c in m.Capabilities if info.capabilities & c]
    cycles = CycleFigures.from_status(status, info.protocol_minor)
    boot = BootReport.from_status(status, info.protocol_minor)
    row = info.to_dict() | {
        "definition_hash": f"0x{info.definition_hash:08X}",
        "capabilities": caps,
        "sensors_present": [k for k in range(3) if info.sensor_present >> k & 1],
        "uptime_ms": status.uptime_ms,
        "cycles": cycles.as_dict(),
        "boot": boot.as_dict(),
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
    for line in cycles.describe() + boot.describe():
        print(f"  {line}")
    return ExitCode.OK


# Table columns spell a count without the dot of its dataset name: s0R, ..., s2IR.
#: t_ms: the window's end on the sensor's clock (a simulation at speed=10 covers 10 ms of it per
#: host ms); host_ms: the host's arrival time beside it, since the first row
SAMPLE_COLUMNS = [
    "seq", "t_ms", "host_ms", "step", *(n.replace(".", "") for n in vocab.SENSOR_CHANNELS)
]  # fmt: skip
ESTIMATE_COLUMNS = [*vocab.FT_AXES, "region", "est_flags"]
PAIRING_WAIT_S = 0.5  # how long a sample waits for its estimate (it follows the SAMPLE frame)


def _stream(args: argparse.Namespace) -> int:
    from spectratac.device import Sensor

    count = stop_count(args.count, args.duration)
    if not 0 <= args.duty <= 1000:
        raise SpectraTacError("--duty is in permille: 0..1000")
    mode = args.estimates
    if mode == "instead":
        columns = ["seq", "t_ms", "host_ms", *ESTIMATE_COLUMNS]
    else:
        columns = [*SAMPLE_COLUMNS, "status", *(ESTIMATE_COLUMNS if mode == "beside" else [])]
    printed = 0
    with Sensor.open(args.url, timeout=args.timeout, stall_timeout=args.stall_timeout) as sensor:
        sensor.configure(
            integration_ms=args.integration_ms, leds=[[[args.duty] * 3] * 3], estimates=mode
        )
        writer = RowWriter(columns, args.format, width=7, table_cell=_cell)
        sensor.start()
        t0 = time.monotonic()
        first_ms: int | None = None
        try:
            for cells, record in _rows(sensor, mode, columns):
                first_ms = cells[1] if first_ms is None else first_ms
                if args.duration is not None and cells[1] - first_ms >= args.duration * 1000:
                    break  # sensor time, whatever the device's speed
                writer.row(cells, record)
                printed += 1
                if count and printed >= count:
                    break
        except BrokenPipeError:
            reader_gone()
            return ExitCode.OK
        finally:
            if not sensor.stats.reconnects:
                sensor.stop()
        stats = sensor.stats
    rate = printed / max(time.monotonic() - t0, 1e-9)
    what = "estimates" if mode == "instead" else "samples"
    lost = f", lost estimates {stats.estimate_gaps}" if mode != "off" else ""
    print(
        f"{printed} {what} ({rate:.1f}/s); CRC errors {stats.crc_errors}, gaps "
        f"{stats.sample_gaps}, overflows {stats.buffer_overflows}{lost}",
        file=sys.stderr,
    )
    return ExitCode.OK if count == 0 or printed >= count else ExitCode.FAILURE


def _cell(value: Any) -> object:
    return f"{value:.3f}" if isinstance(value, float) else value


def _estimate_cells(row: Any) -> list[Any]:
    if row is None:  # lost on the link: the sample stands alone
        return [float("nan")] * 6 + [0, "-"]
    return [
        *(float(v) for v in row["force"]),
        *(float(v) for v in row["torque"]),
        int(row["region"]),
        f"{int(row['flags']):x}",
    ]


def _rows(sensor: Any, mode: str, columns: list[str]) -> Iterator[tuple[list[Any], dict]]:
    """(cells, JSON record) per printed row."""
    first: list[float] = []  # the first row's host time: host_ms counts from it

    def host_ms(t: float) -> float:
        first[:] = first or [t]
        return round((t - first[0]) * 1000, 3)

    if mode == "instead":
        while True:
            for row in sensor.read_estimates(64, timeout=PAIRING_WAIT_S):
                cells: list[Any] = [int(row["sequence"]), int(row["device_time_us"]) // 1000]
                cells.append(host_ms(float(row["host_time"])))
                cells += _estimate_cells(row)
                yield cells, dict(zip(columns, cells, strict=True))
    for sample, estimate in _samples(sensor, mode == "beside"):
        values = [
            sample.sequence,
            sample.device_time_us // 1000,
            host_ms(sample.host_time),
            sample.step,
            *(v for counts in sample.counts for v in counts),
        ]
        status = "".join(f"{s:x}" for s in sample.status)
        extra = _estimate_cells(estimate) if mode == "beside" else []
        record = dict(zip(columns, [*values, list(sample.status), *extra], strict=True))
        yield [*values, status, *extra], record


def _samples(sensor: Any, paired: bool) -> Iterator[tuple[Any, Any]]:
    """Samples, each with the device's estimate of the same sample_seq when `paired`."""
    pending: dict[tuple[int, int], Any] = {}
    for sample in sensor:
        key = (sample.epoch, sample.sequence)
        deadline = time.monotonic() + PAIRING_WAIT_S
        while paired and key not in pending and time.monotonic() < deadline:
            rows = sensor.read_estimates(1, timeout=deadline - time.monotonic())
            for row in rows:
                pending[(int(row["epoch"]), int(row["sequence"]))] = row
            if len(rows) and int(rows["sequence"][-1]) > sample.sequence:
                break  # this sample's estimate was lost
        estimate = pending.pop(key, None)
        for old in [k for k in pending if k < key]:
            del pending[old]
        yield sample, estimate
