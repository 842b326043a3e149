"""`spectratac model info|upload|clear URL`: the decoder a device runs on board (protocol 1.1).

spectratac model info sim://
spectratac model info /dev/ttyACM0 --file press.stac   # exit 1 unless the device runs it
spectratac model upload /dev/ttyACM0 press.stac --weights f16
spectratac model clear /dev/ttyACM0 --json
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.options import (
    DEVICE_URL_HELP,
    add_device_url,
    add_unit_checks,
    given_unit_differs,
)

WEIGHTS = ("f32", "f16", "i8")
URL_HELP = (
    f"{DEVICE_URL_HELP}; a simulated device keeps its model between runs only with "
    "sim://?model_store=PATH (the file that plays its flash)"
)


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "model", help="show, upload or erase the decoder a device runs on board"
    )
    sub = p.add_subparsers(dest="model_verb", metavar="<model verb>")
    p.set_defaults(func=lambda args: (p.print_help(), ExitCode.USAGE)[1])
    info = sub.add_parser("info", help="which model the device decodes with, and its limits")
    add_device_url(info, URL_HELP)
    info.add_argument(
        "-f",
        "--file",
        help="decoder file (.stac): say whether the device runs this model (in which weight "
        "format), by the image CRC the device reports; exit code 1 if it does not",
    )
    info.add_argument("--json", action="store_true", help="machine-readable output")
    info.set_defaults(func=_info)
    up = sub.add_parser("upload", help="export a .stac decoder and upload it into flash")
    add_device_url(up, URL_HELP)
    up.add_argument("model", help="decoder file (.stac) written by `spectratac train`")
    up.add_argument(
        "--weights",
        choices=WEIGHTS,
        default="f32",
        help="weight precision on the device (f16 and i8 take a half and a quarter of the "
        "flash; default f32)",
    )
    up.add_argument(
        "--data",
        help="data file (any format `train` reads): measure what --weights f16/i8 cost in "
        "accuracy against f32 on it before uploading",
    )
    add_unit_checks(up)
    up.add_argument("--json", action="store_true", help="machine-readable output")
    up.set_defaults(func=_upload)
    clear = sub.add_parser("clear", help="erase the uploaded model (a built-in one takes over)")
    add_device_url(clear, URL_HELP)
    clear.add_argument("--json", action="store_true", help="machine-readable output")
    clear.set_defaults(func=_clear)


def _describe(info: Any) -> str:
    if not info.has_model:
        return "no model"
    return (
        f"{info.present} model 0x{info.model_id:08X}: {info.size} B, {info.weight_format} "
        f"weights, {info.led_steps} LED step(s), {info.n_inputs} inputs, "
        + (
            f"image CRC 0x{info.image_crc:08X}"
            if info.image_crc is not None
            else "image CRC not reported (firmware older than protocol 1.2)"
        )
    )


def store_note(url: str) -> str | None:
    """What to say about a sim:// URL whose model store lasts only one run: each
    `spectratac` process gives it a new, empty store unless the URL names one."""
    if not url.startswith("sim:"):
        return None
    from spectratac.sim.url import parse_sim_url

    try:
        if parse_sim_url(url).model_store is not None:
            return None
    except ValueError:
        return None
    return (
        "this simulated device's model store lives only as long as this run (each run of "
        "spectratac starts it empty); add model_store=PATH to the URL, e.g. "
        '"sim://?model_store=/tmp/dev.flash", to keep an uploaded model between runs'
    )


def _print_info(url: str, info: Any) -> None:
    print(f"{url}: {_describe(info)}")
    note = store_note(url)
    if note is not None:
        print(f"note: {note}", file=sys.stderr)
    print(
        f"  model store  {info.capacity} B; firmware limits {info.max_inputs} inputs, "
        f"{info.max_hidden} hidden units"
    )


def _info(args: argparse.Namespace) -> int:
    from spectratac.device import Sensor

    match = _file_images(args.file) if args.file else None
    with Sensor.open(args.url, timeout=args.timeout) as sensor:
        info = sensor.model_info()
    runs = _runs(info, match) if match is not None else None
    if args.json:
        extra = {} if match is None else {"file": args.file, "runs_file": runs is not None,
                                          "file_weights": runs}  # fmt: skip
        print(json.dumps({"url": args.url} | info.as_dict() | extra))
    else:
        _print_info(args.url, info)
        if match is not None:
            print(
                f"  {args.file}: "
                + (f"this is the device's model ({runs} weights)" if runs else _differs(info))
            )
    return ExitCode.FAILURE if match is not None and runs is None else ExitCode.OK


def _file_images(path: str) -> dict[str, tuple[int, int]]:
    """Weight format -> (image CRC, model_id) of the file's decoder in each format the
    firmware runs (a format the decoder cannot take is left out)."""
    from spectratac.decode import Decoder
    from spectratac.decode.export import model_image

    dec = Decoder.load(path)
    out = {}
    for weights in WEIGHTS:
        try:
            image = model_image.encode(dec, weights=weights)
        except model_image.ModelImageError:
            continue
        out[weights] = (model_image.image_crc(image), model_image.model_id(image))
    return out


def _runs(info: Any, images: dict[str, tuple[int, int]]) -> str | None:
    """The weight format in which the device runs the file's model, else None. By image CRC;
    a device older than protocol 1.2 reports none, so its model_id decides."""
    if not info.has_model:
        return None
    for weights, (crc, model_id) in images.items():
        if (info.image_crc == crc) if info.image_crc is not None else info.model_id == model_id:
            return weights
    return None


def _differs(info: Any) -> str:
    if not info.has_model:
        return "not on the device (it has no model); upload it with `spectratac model upload`"
    return "not the device's model; upload it with `spectratac model upload`"


def _upload(args: argparse.Namespace) -> int:
    from spectratac.decode import Decoder
    from spectratac.decode.export import model_image
    from spectratac.decode.unit_check import check_sensor_unit
    from spectratac.device import Sensor

    dec = Decoder.load(args.model)
    said = given_unit_differs(dec.unit_id, args)
    image = model_image.encode(dec, weights=args.weights)
    model_id = model_image.model_id(image)
    error = _weight_error(dec, args) if args.data else None
    if not args.json:
        if error is not None:
            from spectratac.evaluate.weight_formats import render

            print(render(error))
        elif args.weights != "f32":
            print(f"  {args.weights} weights round the network's weights; add --data FILE to "
                  "measure what that costs against f32", file=sys.stderr)  # fmt: skip

    from spectratac.progress import bar as progress_bar

    bar = progress_bar(total=len(image), desc="uploading", unit="B", enabled=not args.json)

    def progress(done: int, total: int) -> None:
        bar.update(done - bar.n)

    with Sensor.open(args.url, timeout=args.timeout) as sensor:
        # as decode does on open: another unit's model warns, or is refused before any write
        policy = "strict" if args.strict_unit else "off" if said else "warn"
        check_sensor_unit(dec.unit_id, sensor, policy)
        try:
            info = sensor.upload_model(image, model_id, progress=progress)
        finally:
            bar.close()
        retries = sensor.stats.model_upload_retries
    if args.json:
        print(
            json.dumps({"url": args.url, "model": args.model, "retries": retries}
                       | info.as_dict() | ({"weight_error": error} if error else {}))
        )  # fmt: skip
    else:
        print(f"{args.url}: uploaded {args.model} ({args.weights} weights)")
        _print_info(args.url, info)
    return ExitCode.OK


def _weight_error(dec: Any, args: argparse.Namespace) -> dict[str, Any]:
    from spectratac.dataset.generic_io import load_data
    from spectratac.evaluate.run import with_model_classes
    from spectratac.evaluate.weight_formats import weight_format_error

    data, _ = with_model_classes(load_data([args.data], list(dec.layout.channels)), dec)
    return weight_format_error(dec, data, args.weights)


def _clear(args: argparse.Namespace) -> int:
    from spectratac.device import Sensor

    with Sensor.open(args.url, timeout=args.timeout) as sensor:
        sensor.clear_model()
        info = sensor.model_info()
    if args.json:
        print(json.dumps({"url": args.url} | info.as_dict()))
    else:
        print(f"{args.url}: model erased; now {_describe(info)}")
    return ExitCode.OK
