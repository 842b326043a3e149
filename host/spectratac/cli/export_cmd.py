"""`spectratac export rosbag RECORDING -o DIR`: a recording for other tools (a ROS 2 bag).

spectratac export rosbag s.mcap -o s_bag [--model m.stac] [--storage sqlite3|mcap] [--json]

Estimates: decoded with --model, else the estimates the recording holds (an on-device model's,
or the live page's in a clip), else none.

Topics, stamps and frames: `spectratac.ros2.export`. An existing non-empty DIR is refused
(exit code 3) unless --force, and --force replaces only a bag folder this verb wrote (marked:
spectratac.cli.outputs), never one holding the recording or anything else; a truncated
recording exports its readable part with a warning.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from datetime import UTC, datetime

from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.options import add_output
from spectratac.cli.outputs import check_output, new_folder

VERB = "export rosbag"

#: Bags of fewer messages are written too fast for a progress bar to help.
PROGRESS_FROM = 100_000


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("export", help="convert a recording for other tools (ROS 2 bag)")
    sub = p.add_subparsers(dest="export_verb", metavar="<sub-verb>")
    r = sub.add_parser(
        "rosbag",
        help="write a recording as a ROS 2 bag (no ROS needed)",
        description="Write the reference F/T (geometry_msgs/msg/WrenchStamped), the raw "
        "counts (std_msgs/msg/UInt16MultiArray per LED step) and the estimates "
        "(WrenchStamped) of a recording as a ROS 2 bag that `ros2 bag play` replays. "
        "Estimates: decoded with --model, else the estimates the recording holds (an "
        "on-device model's, or the live page's in a clip), else none. Stamps: Unix time from "
        "the dataset builder's clock fits; frame spectratac_board.",
    )
    r.add_argument("recording", help="a recording (.mcap) made by spectratac record")
    add_output(r, required=True, help="the bag folder to write")
    r.add_argument(
        "--model",
        metavar="STAC",
        help="decode the samples with this model instead of using the recording's own estimates",
    )
    r.add_argument(
        "--storage",
        choices=("sqlite3", "mcap"),
        default="sqlite3",
        help="bag storage: sqlite3 (what ROS 2 Humble plays out of the box) or mcap "
        "(default: %(default)s)",
    )
    r.add_argument("--json", action="store_true", help="print one JSON object")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    r.set_defaults(func=_rosbag)
    p.set_defaults(func=lambda args: (p.print_help(), ExitCode.USAGE)[1])


def _rosbag(args: argparse.Namespace) -> int:
    from spectratac.ros2 import export_rosbag

    out = check_output(
        args.output, args.force, verb=VERB, inputs=(args.recording, args.model), folder=True
    )
    decoder = None
    if args.model:
        from spectratac.decode import Decoder

        decoder = Decoder.load(args.model)
    bar = None

    def progress(done: int, total: int) -> None:
        nonlocal bar
        if args.no_progress or args.json or total < PROGRESS_FROM:
            return
        if bar is None:
            from spectratac.progress import bar as progress_bar

            bar = progress_bar(total=total, desc="messages", unit="msg")
        bar.update(done - bar.n)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            with new_folder(out, VERB) as staged:
                summary = export_rosbag(
                    args.recording,
                    staged,
                    decoder=decoder,
                    storage=args.storage,
                    progress=progress,
                )
            summary.path = out
        finally:
            if bar is not None:
                bar.close()
    notes = [str(w.message) for w in caught] + summary.notes
    if args.json:
        print(json.dumps({**summary.as_dict(), "warnings": notes}))
        return ExitCode.OK
    for note in notes:
        print(f"warning: {note}", file=sys.stderr)
    span = summary.end_unix - summary.start_unix
    start = datetime.fromtimestamp(summary.start_unix, UTC).strftime("%Y-%m-%d %H:%M:%S UTC")
    print(
        f"wrote {summary.path} ({summary.storage}): {summary.messages} messages over "
        f"{span:.1f} s from {start}"
    )
    for name, t in summary.topics.items():
        print(f"  {name:<34} {t['type']:<32} {t['count']:>8}")
    print(f"play it: ros2 bag play {summary.path}")
    return ExitCode.OK
