"""`spectratac dataset build|info`: recorded sessions to a dataset file, and what one holds.

spectratac dataset build s1.mcap s2.mcap -o data.npz [--split] [--max-gap-ms 5] [--ft FT_URL]
spectratac dataset info data.npz [--json]

A truncated recording (the recorder was killed) contributes its readable prefix: a warning,
exit code 0. A damaged recording (chunks whose CRC fails) contributes every intact chunk; the
dataset is still written, but the damage is reported as an error line per recording (and
under "corrupted" with --json) and the exit code is 1, so that scripts notice the loss. So is
a reference F/T that gives fewer than 95 % of the rows a target, or far more F/T samples per
window than its rate implies (a warning says why); one that covers no row is an error, exit
code 3: it is not this session's reference (`spectratac.dataset.coverage`).
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.options import add_output, npz_name, refuse_overwrite
from spectratac.cli.outputs import is_npz, new_file, url_input
from spectratac.errors import printable

#: Recordings at least this large (about two minutes of a session with F/T) get an estimate:
#: its probe builds a fifth of this (`spectratac.apps.estimates.BUILD_PROBE_BYTES`).
LONG_BUILD_BYTES = 5_000_000


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("dataset", help="build datasets from recordings; describe one")
    sub = p.add_subparsers(dest="dataset_verb", metavar="<sub-verb>")
    b = sub.add_parser(
        "build",
        help="align recorded sessions (.mcap) into one dataset file (.npz)",
        description="Decode the frames, align device and F/T clocks to the host, average the "
        "F/T over each integration window (NaN over dropouts), label regions and presses. "
        "Sessions under different sensor configurations need --split.",
    )
    b.add_argument("recordings", nargs="+", help="session .mcap files")
    add_output(b, required=True, help="the .npz file to write")
    b.add_argument(
        "--split",
        action="store_true",
        help="one output per configuration (OUTPUT's stem + a configuration tag)",
    )
    b.add_argument(
        "--max-gap-ms",
        type=float,
        default=None,
        help="longest F/T gap a window may straddle (default: 3 F/T sample periods)",
    )
    b.add_argument(
        "--ft",
        metavar="FT_URL",
        help="the reference F/T recorded apart, replacing the recordings' own: "
        "rosbag://BAG?topic=/ft_sensor/wrench (ros2 bag record beside spectratac record) "
        "or csv://FILE with a host_time column",
    )
    b.add_argument("--json", action="store_true", help="print one JSON object")
    b.add_argument("--no-progress", action="store_true")
    b.set_defaults(func=_build)
    i = sub.add_parser("info", help="describe a dataset file")
    i.add_argument("dataset", help="a .npz dataset")
    i.add_argument("--json", action="store_true", help="print one JSON object")
    i.set_defaults(func=_info)
    p.set_defaults(func=lambda args: (p.print_help(), ExitCode.USAGE)[1])


VERB = "dataset build"


def _build(args: argparse.Namespace) -> int:
    from spectratac.cli.eta import ClockBar, announce
    from spectratac.dataset.build import BuildOptions, build_datasets, split_paths
    from spectratac.dataset.coverage import CoverageWarning
    from spectratac.errors import SpectraTacError
    from spectratac.record.errors import CorruptedRecordingWarning

    if args.max_gap_ms is not None and not args.max_gap_ms > 0:
        raise SpectraTacError("--max-gap-ms must be > 0")
    inputs = [*args.recordings, url_input(args.ft)]
    if not args.split:  # refuse before the work; --split's names are known only after it
        refuse_overwrite(npz_name(args.output), args.force, verb=VERB, inputs=inputs, kind=is_npz)
    external = None
    loading: list[warnings.WarningMessage] = []
    if args.ft:
        from spectratac.dataset.external_ft import load_external_ft

        with warnings.catch_warnings(record=True) as loading:
            warnings.simplefilter("always")
            external = load_external_ft(args.ft)
    paths = [Path(p) for p in args.recordings]
    options = BuildOptions(max_gap_ms=args.max_gap_ms, ft=external)
    estimate = _estimate(paths, options)
    if estimate is not None and not args.json:
        announce(f"dataset build of {len(paths)} recording(s)", estimate)
    bar = None
    quiet = args.no_progress or args.json
    if not quiet and len(args.recordings) > 1:
        from spectratac.progress import bar as progress_bar

        bar = progress_bar(total=len(args.recordings), desc="sessions", unit="file")

    def progress(path: str) -> None:
        if bar is not None:
            bar.set_postfix_str(Path(path).name)
            bar.update(1)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        one = len(args.recordings) == 1  # several: the bar per file says the time left
        try:
            with ClockBar(
                estimate.total_s if estimate else 0.0,
                "building",
                enabled=one and not quiet and estimate is not None,
            ):
                datasets = build_datasets(
                    args.recordings,
                    split=args.split,
                    options=options,
                    progress=progress,
                )
        finally:
            if bar is not None:
                bar.close()
    caught = [*loading, *caught]
    notes = [str(w.message) for w in caught]
    for note in notes:
        if not args.json:
            print(f"warning: {note}", file=sys.stderr)
    paths = split_paths(args.output, datasets)
    refuse_overwrite(
        [npz_name(p) for p in paths], args.force, verb=VERB, inputs=inputs, kind=is_npz
    )
    written = []
    for ds, path in zip(datasets, paths, strict=True):
        with new_file(npz_name(path)) as tmp:
            ds.save(tmp)
        written.append({"path": str(path), **summary(ds)})
    damaged = [
        {"path": w.message.path, "chunks": w.message.chunks, "lost": w.message.lost}
        for w in caught
        if isinstance(w.message, CorruptedRecordingWarning)
    ]
    if args.json:
        print(
            json.dumps(
                {
                    "outputs": written,
                    "warnings": notes,
                    "corrupted": damaged,
                    "estimate": estimate.as_dict() if estimate else None,
                }
            )
        )
    else:
        for w in written:
            print(
                f"wrote {w['path']}: {w['n']} samples from {w['sessions']} session(s), "
                f"{w['target_valid'] * 100:.1f} % with F/T targets, {w['presses']} presses, "
                f"labels {w['labels']}"
            )
            if not w["force_targets"]:
                print(
                    f"  no force targets: recorded without a reference F/T (targets NaN, "
                    f"target_valid false); region labels {w['labels']}. Adapt a model to this "
                    f"unit with them: spectratac train {w['path']} --finetune MODEL.stac -o "
                    "unit.stac"
                )
        for d in damaged:
            lost = ", ".join(f"{k} {t}" for t, k in d["lost"].items()) or "an uncounted number"
            print(
                f"error: {d['path']} is damaged: {d['chunks']} chunk(s) skipped, messages "
                f"lost: {lost}; the dataset holds the rest",
                file=sys.stderr,
            )
    short = [w for w in caught if isinstance(w.message, CoverageWarning)]
    return ExitCode.FAILURE if damaged or short else ExitCode.OK


def summary(ds: Any) -> dict[str, Any]:
    """The figures `dataset info` shows (JSON-friendly)."""
    meta = ds.meta
    regions, counts = np.unique(ds.region, return_counts=True)
    valid = ds.target_valid
    t = ds.targets[valid] if valid.any() else np.zeros((0, ds.targets.shape[1]))
    return {
        "n": ds.n,
        "kind": meta.get("kind"),
        "unit_id": meta.get("unit_id"),
        "firmware_version": meta.get("firmware_version"),
        "protocol_version": meta.get("protocol_version"),
        "definition_hash": meta.get("definition_hash"),
        "config": meta.get("config"),
        "labels": meta.get("labels"),
        "sessions": len(meta.get("sessions", [])),
        "session_sources": [s.get("path") or s.get("source") for s in meta.get("sessions", [])],
        "target_valid": float(valid.mean()) if ds.n else 0.0,
        "force_targets": bool(valid.any()),  # False: no reference F/T, region labels at most
        "in_contact": float(ds.in_contact.mean()) if ds.n else 0.0,
        "presses": ds.press_count(),
        "regions": {int(r): int(c) for r, c in zip(regions, counts, strict=True)},
        "duration_s": ds.span_s() if ds.n else 0.0,  # the sensor's clock
        "target_min": dict(zip(ds.target_names, np.min(t, axis=0).tolist(), strict=True))
        if len(t)
        else {},
        "target_max": dict(zip(ds.target_names, np.max(t, axis=0).tolist(), strict=True))
        if len(t)
        else {},
    }


def _estimate(paths: list[Path], options: Any) -> Any:
    """How long the build will take: the largest recording's first chunks built and timed
    (`spectratac.apps.estimates.build_estimate`), scaled to every recording's bytes; None
    for small recordings (the probe would be a large share of the work) and when the probe
    cannot be built (the build itself then says why)."""
    from spectratac.apps.estimates import build_estimate
    from spectratac.errors import SpectraTacError

    if sum(p.stat().st_size for p in paths if p.exists()) < LONG_BUILD_BYTES:
        return None
    try:
        return build_estimate(paths, options)
    except SpectraTacError as exc:
        print(f"note: no time estimate ({exc})", file=sys.stderr)
        return None


def _info(args: argparse.Namespace) -> int:
    from spectratac.dataset import Dataset

    ds = Dataset.load(args.dataset)
    s = summary(ds)
    if args.json:
        print(json.dumps({"path": args.dataset, **s}))
        return ExitCode.OK

    def say(text: str) -> None:  # the file's own strings (unit, sources): never raw
        print(printable(text))

    cfg = s["config"]
    say(f"{args.dataset}: {s['n']} samples, {s['kind']}, {s['sessions']} session(s)")
    say(f"  unit             {s['unit_id']}")
    say(
        f"  firmware         {s['firmware_version']}, protocol {s['protocol_version']}, "
        f"definitions {s['definition_hash']}"
    )
    if isinstance(cfg, dict):
        say(
            f"  configuration    {cfg['integration_ms']} ms, gain x{cfg['gain']:g}, digital "
            f"x{cfg['digital_gain']}, {cfg['sensitivity']} sensitivity, "
            f"{len(cfg['leds'])} LED step(s)"
        )
    else:
        say(f"  configuration    {cfg}")
    say(
        f"  targets          {s['target_valid'] * 100:.1f} % valid; in contact "
        f"{s['in_contact'] * 100:.1f} %; {s['presses']} presses; "
        f"span {s['duration_s']:.1f} s of sensor time"
    )
    if s["target_min"]:
        ranges = ", ".join(
            f"{k} {s['target_min'][k]:.2f}..{s['target_max'][k]:.2f}" for k in s["target_min"]
        )
        say(f"  target ranges    {ranges}")
    regions = " ".join(f"{r}:{c}" for r, c in s["regions"].items())
    say(f"  regions          {regions}   (labels: {s['labels']})")
    for src in s["session_sources"]:
        say(f"  session          {src}")
    return ExitCode.OK
