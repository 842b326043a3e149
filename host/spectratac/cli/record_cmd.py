"""`spectratac record URL -o session.mcap`: record a session (optical + reference F/T) to MCAP.

spectratac record sim://?scene=tour&seed=1&speed=10&ft=bota -o s.mcap --duration 30
spectratac record /dev/ttyACM0 --ft netft://192.168.1.1 -o s.mcap --guided 27

A new file is recorded under its own name (the MCAP is crash-safe as it grows). With --force
over an existing recording, the new one grows under a hidden name beside it (equally
crash-safe) and replaces the old one only once finished, so a crash or kill keeps the old
recording whole and the new one readable under the hidden name. A session that could not
start leaves no file behind.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import signal
import sys
from pathlib import Path
from typing import Any

from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.options import (
    add_count,
    add_device_url,
    add_duration,
    add_output,
    refuse_overwrite,
    warn,
)
from spectratac.cli.outputs import is_mcap, temporary_name, url_input, writing
from spectratac.errors import SpectraTacError
from spectratac.hardware.generated.veml3328 import GAINS, INTEGRATION_MS

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "record",
        help="record a session (device frames, reference F/T, labels) to an MCAP file",
        description="Record raw device frames, reference F/T samples, clock-sync exchanges, "
        "configuration and region labels into a crash-safe MCAP file. Ctrl-C stops cleanly.",
    )
    add_device_url(
        p,
        "serial port, socket://host:port, or sim://?scene=…&ft=bota",
        waits_for="the device and for the reference F/T sensor, each",
        stalls=True,
    )
    p.add_argument(
        "--ft",
        metavar="FT_URL",
        help="reference F/T: netft://HOST, bota:///dev/ttyUSB1, csv://path, "
        "rosbag://BAG?topic=/ft_sensor/wrench (a ROS 2 bag), sim://… "
        "(default for sim:// URLs with ft=…: the same URL)",
    )
    add_output(p, required=True, help="the .mcap file to write")
    until = p.add_mutually_exclusive_group()
    add_duration(
        until,
        None,
        "stop after S seconds of the sensor's clock (sim://…&speed=10 records them in S/10 "
        "wall seconds)",
    )
    add_count(until, None, "stop after N optical samples")
    p.add_argument("--integration-ms", type=int, default=50, choices=INTEGRATION_MS)
    p.add_argument("--gain", type=float, default=1.0, choices=sorted(GAINS))
    p.add_argument("--sensitivity", default="high", choices=("high", "low"))
    p.add_argument(
        "--leds",
        default="500",
        metavar="SPEC",
        help="LED steps separated by '/': each one duty for all nine channels (500), three "
        "(R,G,B for every LED) or nine (LED0 RGB, LED1 RGB, LED2 RGB), permille; "
        "e.g. 1000,0,0/0,1000,0/0,0,1000",
    )
    p.add_argument("--guided", type=int, metavar="N", help="guided labelling: N prompted presses")
    p.add_argument("--guided-hold", type=float, default=3.0, metavar="S", help="hold time")
    p.add_argument("--guided-rest", type=float, default=2.0, metavar="S", help="rest time")
    p.add_argument(
        "--guided-seed",
        type=int,
        default=None,
        help="seed of the prompt order (default: the published order every session uses, "
        "which sim://?scene=guided's simulated person follows)",
    )
    p.add_argument(
        "--estimates",
        action="store_true",
        help="keep the device's own estimates on /spectratac/estimates (a device that decodes "
        "on board: see `spectratac model upload`)",
    )
    p.add_argument("--sync-every", type=float, default=5.0, metavar="S", help="clock sync period")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.add_argument("--no-progress", action="store_true", help="no live progress display")
    p.set_defaults(func=_record)


def parse_leds(spec: str) -> list[list[list[int]]]:
    """--leds SPEC to steps x 3 LEDs x (R, G, B) permille.

    >>> parse_leds("500")[0][2], parse_leds("1000,0,0/0,0,1000")[1][0]
    ([500, 500, 500], [0, 0, 1000])
    """
    steps = []
    for part in spec.split("/"):
        try:
            values = [int(v) for v in part.split(",")]
        except ValueError:
            raise SpectraTacError(f"--leds {spec!r}: duties are integers in permille") from None
        if len(values) == 1:
            values *= 9
        elif len(values) == 3:
            values *= 3
        if len(values) != 9 or not all(0 <= v <= 1000 for v in values):
            raise SpectraTacError(
                f"--leds {spec!r}: each step gives 1, 3 or 9 duties in 0..1000, e.g. 500 or "
                f"1000,0,0/0,1000,0"
            )
        steps.append([values[0:3], values[3:6], values[6:9]])
    if not 1 <= len(steps) <= 8:
        raise SpectraTacError(f"--leds {spec!r}: give 1..8 steps")
    return steps


def _record(args: argparse.Namespace) -> int:
    from spectratac.record import (
        DEFAULT_SEED,
        GuidedProtocol,
        RecordOptions,
        StopRequest,
        record_url,
        stopping_on,
    )

    options = RecordOptions(
        duration_s=args.duration,
        samples=args.count,
        integration_ms=args.integration_ms,
        gain=args.gain,
        sensitivity=args.sensitivity,
        leds=parse_leds(args.leds),
        sync_every_s=args.sync_every,
        estimates=args.estimates,
    )
    options.validate()
    out = Path(args.output)
    refuse_overwrite(
        out, args.force, verb="record", inputs=(url_input(args.ft), args.url), kind=is_mcap
    )
    # an existing recording (--force) is replaced once the new one is finished
    target = temporary_name(out, "recording") if out.exists() else out
    guided = None
    if args.guided is not None:
        guided = GuidedProtocol(
            args.guided,
            hold_s=args.guided_hold,
            rest_s=args.guided_rest,
            seed=DEFAULT_SEED if args.guided_seed is None else args.guided_seed,
            out=sys.stderr,
        )

    estimate: dict[str, Any] = {}

    def note(link: Any, ft_url: str | None) -> None:
        from spectratac.apps.estimates import recording_estimate
        from spectratac.cli.eta import announce

        if ft_url is None and not args.json:
            also = (
                "; the prompts label the regions, which adapt a model to this unit (spectratac "
                "train G.npz --finetune MODEL.stac)"
                if guided
                else ""
            )
            print(
                f"note: no reference F/T sensor (--ft): the dataset's targets will be empty{also}",
                file=sys.stderr,
            )
        found = recording_estimate(options.duration_s, link.clock_scale)
        if found is not None:
            estimate.update(found.as_dict())
            if not args.json:
                announce(f"recording {options.duration_s:g} s of sensor time", found)

    progress, bar = (None, None) if args.no_progress or guided else _progress_bar(options)
    # SIGINT/SIGTERM ask the recorder to stop: it finishes the file, then the CLI returns.
    # StopRequest, not threading.Event: a handler must not take the lock the loop waits on.
    try:
        with (
            StopRequest() as stop,
            stopping_on(stop, STOP_SIGNALS, "\nstopping: finishing the file…\n"),
        ):
            summary = _record_into(
                target,
                out,
                lambda path: record_url(
                    args.url,
                    path,
                    options,
                    ft_url=args.ft,
                    guided=guided,
                    stop=stop,
                    progress=progress,
                    sensor_options={"timeout": args.timeout, "stall_timeout": args.stall_timeout},
                    on_open=note,
                ),
            )
    finally:
        if bar is not None:
            bar.close()
    if args.json:
        print(json.dumps(summary.as_dict() | ({"estimate": estimate} if estimate else {})))
    else:
        s = summary
        print(
            f"recorded {s.path}: {s.samples} samples ({s.lost} lost, {s.crc_errors} CRC "
            f"errors), {s.ft_samples} F/T samples ({ft_loss_note(s.ft_lost, s.ft_simulated_loss)}"
            f"), {s.labels} labels, {s.sensor_s:.1f} s of sensor time in {s.duration_s:.1f} s, "
            f"{s.file_bytes / 1e6:.2f} MB; stopped by {s.stopped_by}"
        )
        if s.ft_stalls:
            print(f"the reference F/T went quiet {s.ft_stalls} time(s): the file has no F/T "
                  "rows while it was quiet", file=sys.stderr)  # fmt: skip
        if s.error:
            print(f"the session ended early: {s.error}", file=sys.stderr)
    return ExitCode.ERROR if summary.stopped_by == "error" else ExitCode.OK


def _record_into(target: Path, out: Path, record: Any) -> Any:
    """record(target), then `target` renamed onto `out` when they differ (unless it holds no
    sample: the old recording is kept); a session that could not start (RecordingError:
    nothing recorded) leaves no file of its own behind."""
    from spectratac.record import RecordingError

    try:
        summary = record(target)
    except RecordingError:
        with contextlib.suppress(OSError):
            target.unlink()
        raise
    except BaseException:  # Ctrl-C and the like: the recorder finished the file; keep it
        if target != out and target.exists():
            with writing(out):
                os.replace(target, out)
        raise
    if target != out and summary.samples == 0:  # stopped before any sample: keep the old one
        with contextlib.suppress(OSError):
            target.unlink()
        warn(f"no sample was recorded: {out} is left as it was")
        summary.path = out
        return summary
    if target != out:
        with writing(out):
            os.replace(target, out)
        summary.path = out
    return summary


class _LazyBar:
    """A tqdm bar made on first use: it appears once the device is open (after the estimate
    line), and closing one never made is a no-op."""

    def __init__(self, **kwargs: Any) -> None:
        self.kwargs = kwargs
        self.bar: Any = None

    def get(self) -> Any:
        if self.bar is None:
            from spectratac.progress import bar

            self.bar = bar(**self.kwargs)
        return self.bar

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _progress_bar(options: Any) -> tuple[Any, Any]:
    by_samples = options.samples is not None
    total = options.samples if by_samples else options.duration_s
    bar = _LazyBar(
        total=total,
        unit="samples" if by_samples or total is None else "sensor s",
        desc="recording",
        file=sys.stderr,
        dynamic_ncols=True,
        bar_format=None if total else "{desc}: {n_fmt} {unit} [{elapsed}{postfix}]",
    )

    def update(status: Any) -> None:
        shown = bar.get()
        shown.n = status.samples if by_samples or total is None else round(status.sensor_s, 1)
        shown.set_postfix_str(
            f"{status.samples} samples, F/T {status.ft_rate_hz:.0f} Hz, lost {status.lost}"
            f"+{status.ft_lost} F/T, CRC {status.crc_errors}, {status.file_bytes / 1e6:.1f} MB",
            refresh=True,
        )

    return update, bar


def ft_loss_note(lost: int, simulated_loss: float | None) -> str:
    """How a summary names the F/T samples lost: a simulated sensor's are its deliberate
    ft_loss (a sim URL parameter), not a fault of the link.

    >>> ft_loss_note(3, None), ft_loss_note(3, 0.001)
    ('3 lost', '3 lost on purpose: simulated ft_loss=0.001')
    """
    if simulated_loss is None:
        return f"{lost} lost"
    return f"{lost} lost on purpose: simulated ft_loss={simulated_loss:g}"
