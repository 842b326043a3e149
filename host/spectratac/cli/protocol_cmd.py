"""`spectratac protocol`: inspect the wire protocol and decode captured bytes.

spectratac protocol show [--json]              version, definition hash, message types
spectratac protocol decode HEX|-f FILE [--json] decode frames; exit 1 if any were dropped
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from spectratac.cli.exit_codes import ExitCode
from spectratac.errors import SpectraTacError


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("protocol", help="inspect the wire protocol, decode bytes")
    verbs = parser.add_subparsers(dest="protocol_verb", metavar="<protocol verb>", required=True)
    show = verbs.add_parser("show", help="protocol version, definition hash and message types")
    show.add_argument("--json", action="store_true", help="machine-readable output")
    show.set_defaults(func=_show)
    decode = verbs.add_parser("decode", help="decode captured frames (hex or a binary file)")
    decode.add_argument("hex", nargs="?", help="frame bytes as hex (spaces allowed)")
    decode.add_argument("-f", "--file", type=Path, help="binary capture; '-' reads stdin")
    decode.add_argument("--json", action="store_true", help="one JSON object per frame")
    decode.set_defaults(func=_decode)


def _show(args: argparse.Namespace) -> int:
    from spectratac.protocol.generated import messages as m

    table = [
        {"id": c.TYPE_ID, "name": c.NAME, "direction": c.DIRECTION, "payload": c.PAYLOAD_SIZE}
        for c in m.MESSAGES
    ]
    if args.json:
        print(
            json.dumps(
                {
                    "version": f"{m.PROTOCOL_MAJOR}.{m.PROTOCOL_MINOR}",
                    "definition_hash": f"0x{m.DEFINITION_HASH:08X}",
                    "messages": table,
                }
            )
        )
        return ExitCode.OK
    print(
        f"SpectraTac protocol {m.PROTOCOL_MAJOR}.{m.PROTOCOL_MINOR}, "
        f"definition hash 0x{m.DEFINITION_HASH:08X}"
    )
    for row in table:
        arrow = "host -> device" if row["direction"] == "host_to_device" else "device -> host"
        print(f"  0x{row['id']:02X}  {row['name']:<18} {arrow}  {row['payload']:>3} B")
    return ExitCode.OK


def _read_input(args: argparse.Namespace) -> bytes:
    if args.file is not None:
        if str(args.file) == "-":
            return sys.stdin.buffer.read()
        try:
            return args.file.read_bytes()
        except OSError as exc:
            raise SpectraTacError(f"cannot read {args.file}: {exc.strerror}") from None
    if args.hex is None:
        raise SpectraTacError("give frame bytes as hex, or a capture file with -f FILE")
    try:
        return bytes.fromhex(args.hex)
    except ValueError:
        raise SpectraTacError(
            f"{args.hex[:40]!r} is not hex; give bytes like '03 01 ... 00' or use -f FILE"
        ) from None


def _decode(args: argparse.Namespace) -> int:
    from spectratac.protocol import StreamDecoder

    data = _read_input(args)
    decoder = StreamDecoder()
    frames = decoder.feed(data if data.endswith(b"\x00") else data + b"\x00")
    for frame in frames:
        row = {"seq": frame.seq, "version": list(frame.version)} | frame.message.to_dict()
        if args.json:
            print(json.dumps(row))
        else:
            fields = ", ".join(f"{k}={v}" for k, v in row.items() if k not in ("type", "seq"))
            print(f"#{frame.seq:<5} {frame.message.NAME:<16} {fields}")
    stats = decoder.stats.as_dict()
    if args.json:
        print(json.dumps({"stats": stats}))
    else:
        drops = {
            k: v
            for k, v in stats.items()
            if isinstance(v, int) and v and k not in ("bytes_in", "frames_ok", "dropped")
        }
        print(f"{len(frames)} frame(s) decoded" + (f"; dropped: {drops}" if drops else ""))
    return ExitCode.OK if decoder.stats.dropped == 0 else ExitCode.FAILURE
