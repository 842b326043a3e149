"""`spectratac decode MODEL URL`: run a trained decoder live on a sensor.

Loads the model file (NumPy only: torch is never imported), configures the sensor as the
model was trained (integration time, gain, LED sequence; `--keep-config` uses the device's
own and refuses to decode if it differs), streams and prints one estimate per sample:
force (N), torque (N·m), contact region and its probability, contact and out-of-distribution
flags, and no_rest: the model's drift baseline has not yet seen the skin at rest (it finds
rest by itself after a press and release; --tare zeroes it on the first sample instead).
The sensor's unique id is compared with the model's unit on open: another unit is a warning
(--strict-unit: an error, exit code 3) that points to `train --finetune`. Samples the decoder
cannot use (LED sequence not complete yet, non-finite counts) are printed as invalid, not
dropped.

    spectratac decode model.stac "sim://?scene=tour&speed=1" --count 40
    spectratac decode model.stac /dev/ttyACM0 --duration 60 --format jsonl > live.jsonl
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from typing import Any

from spectratac.apps.sensor_setup import sensor_settings
from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.options import (
    add_count,
    add_decoding_checks,
    add_device_url,
    add_duration,
    add_row_format,
    load_decoder,
)
from spectratac.cli.output import RowWriter, reader_gone
from spectratac.errors import SpectraTacError
from spectratac.hardware.generated import vocabulary as vocab

# t_s: seconds of the sensor's clock since the first sample (a window's end; a simulation at
#   speed=10 covers 10 s of it per host second); host_s: the host's arrival time beside it
# no_rest: the drift baseline has not yet seen the skin at rest (forces may be offset; --tare)
COLUMNS = ("t_s", "host_s", *vocab.FT_AXES, "region", "p", "contact", "ood", "invalid", "no_rest")


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "decode",
        help="run a trained decoder live on a sensor: force, torque, region, flags",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("model", help="decoder file (.stac)")
    add_device_url(p, stalls=True)
    add_count(p, 0, "estimates to print (0: no limit)")
    add_duration(p, 0.0, "stop after S seconds of the sensor's clock (0: never)")
    add_row_format(p)
    add_decoding_checks(p)
    p.set_defaults(func=run)


class SensorSpan:
    """Seconds of the sensor's clock the estimates so far cover: from the first window's start
    to the last window's end, summed over connection epochs (a reconnect may restart the
    device clock). Counted on the device's timestamps, never on host arrival times: a loaded
    host receives samples late and in bursts, so host seconds times the link's clock scale
    stopped `--duration` a few samples early or late.

    >>> span = SensorSpan(0.05)
    >>> [span.covered(t, 0) for t in (1_050_000, 1_100_000, 1_150_000)]
    [0.05, 0.1, 0.15]
    >>> span.covered(50_000, 1)  # a new epoch: its first window adds on
    0.2
    """

    def __init__(self, period_s: float) -> None:
        self.period_us = round(period_s * 1e6)
        self._done_us = 0  # span of closed epochs
        self._epoch: int | None = None
        self._first_us = 0  # this epoch's first window end
        self._span_us = 0

    def covered(self, device_time_us: int, epoch: int) -> float:
        if epoch != self._epoch:
            self._done_us = self._span_us
            self._epoch, self._first_us = epoch, device_time_us
        self._span_us = self._done_us + device_time_us - self._first_us + self.period_us
        return self._span_us / 1e6


class SensorClock:
    """Seconds of the sensor's clock since the first estimate, across reconnects (a new epoch
    may restart the device clock: its time goes on from where the last epoch's ended)."""

    def __init__(self) -> None:
        self._epoch: int | None = None
        self._base_us = 0  # device µs at the epoch's first estimate
        self._done_s = 0.0  # seconds of the epochs before
        self._last_s = 0.0

    def __call__(self, device_time_us: int, epoch: int) -> float:
        if epoch != self._epoch:
            self._epoch, self._base_us, self._done_s = epoch, device_time_us, self._last_s
        self._last_s = self._done_s + (device_time_us - self._base_us) / 1e6
        return self._last_s


def _cells(e: Any, t0: float, t_s: float) -> list[Any]:
    def num(v: float, fmt: str) -> str:
        return "nan" if math.isnan(v) else format(v, fmt)

    return [
        f"{t_s:.3f}",
        f"{e.time - t0:.3f}",
        *(num(float(v), ".3f") for v in e.force),
        *(num(float(v), ".4f") for v in e.torque),
        e.region,
        num(e.region_prob, ".2f"),
        int(e.contact),
        int(e.ood),
        int(e.invalid),
        int(e.no_rest),
    ]


def _record(e: Any, t0: float, t_s: float) -> dict[str, Any]:
    def clean(v: float) -> float | None:
        return None if math.isnan(v) else round(float(v), 6)

    return {
        "t_s": round(t_s, 6),
        "host_s": round(e.time - t0, 6),
        "force": [clean(v) for v in e.force],
        "torque": [clean(v) for v in e.torque],
        "region": e.region,
        "region_prob": clean(e.region_prob),
        "contact": bool(e.contact),
        "contact_prob": clean(e.contact_prob),
        "ood": bool(e.ood),
        "invalid": bool(e.invalid),
        "no_rest": bool(e.no_rest),
        "std": None if e.std is None else [clean(v) for v in e.std],
    }


def run(args: argparse.Namespace) -> int:
    from spectratac.device import Sensor

    if args.count < 0 or args.duration < 0:
        raise SpectraTacError("--count and --duration must be >= 0 (0: no limit)")
    decoder = load_decoder(args)
    settings = None if args.keep_config else sensor_settings(decoder.config)
    counts = {"estimates": 0, "invalid": 0, "ood": 0, "contact": 0, "no_rest": 0}
    t0 = time.monotonic()
    with Sensor.open(args.url, timeout=args.timeout, stall_timeout=args.stall_timeout) as sensor:
        if settings is not None:
            sensor.configure(**settings)
        writer = RowWriter(COLUMNS, args.format, width=8)
        span = SensorSpan(sensor.get_config().integration_ms / 1000.0)
        sensor.start()
        try:
            first: float | None = None  # host time of the first sample: host_s counts from it
            clock = SensorClock()
            for e in decoder.stream(sensor):
                first = e.time if first is None else first
                t_s = clock(e.device_time_us, e.epoch)
                writer.row(_cells(e, first, t_s), _record(e, first, t_s))
                counts["estimates"] += 1
                counts["invalid"] += int(e.invalid)
                counts["ood"] += int(e.ood)
                counts["contact"] += int(e.contact)
                counts["no_rest"] += int(e.no_rest)
                if (args.count and counts["estimates"] >= args.count) or (
                    args.duration
                    and span.covered(e.device_time_us, e.epoch) >= args.duration - 1e-9
                ):
                    break
        except BrokenPipeError:
            reader_gone()
            return ExitCode.OK
        finally:
            if not sensor.stats.reconnects:
                sensor.stop()
    rate = counts["estimates"] / max(time.monotonic() - t0, 1e-9)
    print(
        f"{counts['estimates']} estimates ({rate:.1f}/s): {counts['contact']} in contact, "
        f"{counts['ood']} out of distribution, {counts['invalid']} invalid"
        + (
            f", {counts['no_rest']} before the baseline saw rest (--tare zeroes it at once)"
            if counts["no_rest"]
            else ""
        ),
        file=sys.stderr,
    )
    return ExitCode.OK
