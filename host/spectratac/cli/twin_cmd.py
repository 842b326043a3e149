"""`spectratac twin`: generate simulated sessions and report the twin's fidelity.

spectratac twin report [--json] [--check]     train the paper recipe on a simulated session
spectratac twin generate -o OUT.npz [--scene S] write a session (counts, F/T, truth) to .npz
                                               (scenes: sim/named_scenes.py, as in sim:// URLs)
spectratac twin population -o OUT.npz --units 0,1,2,3 --sessions 3 --duration 300
                                               a dataset of several units x sessions each
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import numpy as np

from spectratac.cli.exit_codes import ExitCode, UsageError
from spectratac.cli.options import add_duration, add_output, npz_name, refuse_overwrite
from spectratac.cli.outputs import is_npz, new_file
from spectratac.hardware.generated.veml3328 import DIGITAL_GAINS, GAINS, INTEGRATION_MS
from spectratac.sim.named_scenes import POPULATION_SCENES, SCENES

#: A generated file of a scene without a length of its own (idle) lasts this long (s).
OPEN_ENDED_S = 10.0


def register(subparsers: Any) -> None:
    p = subparsers.add_parser("twin", help="digital twin: simulated sessions, fidelity report")
    sub = p.add_subparsers(dest="twin_verb", metavar="<sub-verb>")

    r = sub.add_parser("report", help="train the paper recipe on a simulated session; compare")
    r.add_argument("--json", action="store_true", help="print one JSON object")
    r.add_argument("--seed", type=int, default=0)
    add_duration(r, 3000.0, "session length in s")
    r.add_argument("--epochs", type=int, default=30)
    r.add_argument("--oracle-samples", type=int, default=1000)
    r.add_argument("--check", action="store_true", help="exit 1 if outside the calibration band")
    r.add_argument("--no-progress", action="store_true")
    r.set_defaults(func=_report)

    g = sub.add_parser("generate", help="simulate a session and write it to an .npz file")
    add_output(g, help="the .npz file to write")
    g.add_argument(
        "--scene",
        default="calibration",
        help=f"one of {', '.join(SCENES)} or a hard case (see --list)",
    )
    g.add_argument("--list", action="store_true", help="list the scenes and exit")
    g.add_argument("--seed", type=int, default=0)
    add_duration(g, None, "session length in s")
    g.add_argument("--integration-ms", type=int, default=50, choices=INTEGRATION_MS)
    g.add_argument("--gain", type=float, default=1.0, choices=sorted(GAINS))
    g.add_argument("--digital-gain", type=int, default=1, choices=DIGITAL_GAINS)
    g.add_argument("--sensitivity", default="high", choices=("high", "low"))
    g.add_argument("--duty", type=float, default=None, help="white LED duty for all channels")
    g.add_argument("--json", action="store_true", help="print a JSON summary")
    g.set_defaults(func=_generate)

    pop = sub.add_parser(
        "population", help="a dataset of several simulated units, several sessions each"
    )
    add_output(pop, help="the dataset .npz file to write", required=True)
    pop.add_argument("--units", required=True, help="comma-separated unit seeds, e.g. 0,1,2,3")
    pop.add_argument("--sessions", type=int, required=True, help="sessions per unit")
    add_duration(pop, 300.0, "length of each session in s")
    pop.add_argument("--seed", type=int, default=0, help="seed of the session conditions")
    pop.add_argument("--scene", default="calibration", choices=POPULATION_SCENES)
    pop.add_argument("--json", action="store_true", help="print a JSON summary")
    pop.add_argument("--no-progress", action="store_true")
    pop.set_defaults(func=_population)
    p.set_defaults(func=lambda args: (p.print_help(), ExitCode.USAGE)[1])


def _report(args: argparse.Namespace) -> int:
    from spectratac.cli.eta import announce
    from spectratac.studies.cost_model import twin_report_estimate
    from spectratac.studies.twin_fidelity import ReportConfig, fidelity_report, format_report
    from spectratac.twin.errors import TwinError

    if args.duration < 60 or args.epochs < 1 or args.oracle_samples < 1:
        raise TwinError("need --duration >= 60 s, --epochs >= 1 and --oracle-samples >= 1")
    cfg = ReportConfig(
        seed=args.seed,
        duration_s=args.duration,
        epochs=args.epochs,
        oracle_samples=args.oracle_samples,
    )
    estimate = twin_report_estimate(cfg)
    if not args.json:
        announce("twin report", estimate)
    bar = None
    if not args.no_progress:
        from spectratac.progress import bar as progress_bar

        bar = progress_bar(
            total=1 + 2 * (cfg.epochs + 1), desc="twin report", unit="step", leave=False
        )

    def progress(stage: str, n: int) -> None:
        if bar is not None:
            bar.set_postfix_str(stage)
            bar.update(n)

    try:
        rep = fidelity_report(cfg, progress)
    finally:
        if bar is not None:
            bar.close()
    rep["estimate"] = estimate.as_dict()
    print(json.dumps(rep) if args.json else format_report(rep))
    return ExitCode.FAILURE if args.check and not rep["pass"] else ExitCode.OK


def _generate(args: argparse.Namespace) -> int:
    from spectratac.cli.eta import ClockBar, announce
    from spectratac.sim.named_scenes import named_scene, scene_names, scene_settings
    from spectratac.studies.cost_model import generation_estimate
    from spectratac.twin import generate_session, white_step

    if args.list:
        for name in scene_names():
            print(name)
        return ExitCode.OK
    if args.output is None:
        raise UsageError("the following arguments are required: -o/--output")
    refuse_overwrite(npz_name(args.output), args.force, verb="twin generate", kind=is_npz)
    duration = args.duration or None  # 0 or none: the scene's own length
    scene = named_scene(args.scene, args.seed, duration, open_ended_s=OPEN_ENDED_S)
    settings = scene_settings(args.scene)
    settings.setdefault("integration_ms", args.integration_ms)
    settings.setdefault("gain", args.gain)
    settings.setdefault("dg", args.digital_gain)
    settings.setdefault("sens_low", args.sensitivity == "low")
    if args.duty is not None:
        settings["led_steps"] = white_step(args.duty)
    estimate = generation_estimate(scene.duration_s, seed=args.seed)
    if not args.json:
        announce(f"twin generate ({scene.duration_s:g} s of '{scene.name}')", estimate)
    t0 = time.perf_counter()
    with ClockBar(estimate.total_s, "generating", enabled=not args.json):
        s = generate_session(scene, seed=args.seed, **settings)
    gen_s = time.perf_counter() - t0
    with new_file(npz_name(args.output)) as tmp:
        s.save_npz(tmp)
    summary = {
        "out": str(args.output),
        "scene": scene.name,
        "samples": len(s),
        "ft_samples": int(s.ft.shape[0]),
        "generation_s": round(gen_s, 3),
        "saturated_fraction": float(s.saturated.mean()),
        "labelled_fraction": float(np.mean(s.region > 0)),
        "clear_mean": [float(v) for v in s.counts[:, :, 3].mean(axis=0)],
        "estimate": estimate.as_dict(),
    }
    if args.json:
        print(json.dumps(summary))
    else:
        print(
            f"wrote {summary['out']}: {summary['samples']} optical samples, "
            f"{summary['ft_samples']} F/T samples of scene '{scene.name}' in {gen_s:.2f} s; "
            f"{100 * summary['saturated_fraction']:.1f} % saturated, "
            f"{100 * summary['labelled_fraction']:.1f} % labelled"
        )
    return ExitCode.OK


def _unit_list(text: str) -> list[int]:
    try:
        units = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise UsageError(f"--units takes comma-separated non-negative ints, got {text!r}") from None
    if not units:
        raise UsageError("--units needs at least one unit seed, e.g. --units 0,1,2")
    return units


def _population(args: argparse.Namespace) -> int:
    from spectratac.cli.eta import announce
    from spectratac.sim.twin_dataset import population
    from spectratac.studies.cost_model import generation_estimate

    units = _unit_list(args.units)
    refuse_overwrite(npz_name(args.output), args.force, verb="twin population", kind=is_npz)
    total = len(units) * max(args.sessions, 0)
    estimate = generation_estimate(total * args.duration, seed=args.seed)
    if not args.json:
        announce(f"twin population ({total} sessions of {args.duration:g} s)", estimate)
    bar = None
    if not args.no_progress:
        from spectratac.progress import bar as progress_bar

        bar = progress_bar(total=total, desc="twin population", unit="session")

    def progress(done: int, total: int) -> None:
        if bar is not None:
            bar.update(done - bar.n)

    t0 = time.perf_counter()
    try:
        ds = population(
            units, args.sessions, args.duration, seed=args.seed, scene=args.scene,
            progress=progress,
        )  # fmt: skip
    finally:
        if bar is not None:
            bar.close()
    gen_s = time.perf_counter() - t0
    path = npz_name(args.output)
    with new_file(path) as tmp:
        ds.save(tmp)
    minutes = len(units) * args.sessions * args.duration / 60.0
    summary = {
        "out": str(path),
        "units": units,
        "sessions": len(ds.meta["sessions"]),
        "samples": ds.n,
        "generation_s": round(gen_s, 3),
        "seconds_per_simulated_minute": round(gen_s / minutes, 4),
        "estimate": estimate.as_dict(),
    }
    if args.json:
        print(json.dumps(summary))
    else:
        print(
            f"wrote {path}: {summary['sessions']} sessions of {len(units)} units, "
            f"{ds.n} samples in {gen_s:.1f} s ({summary['seconds_per_simulated_minute']:.3f} s "
            "per simulated minute)"
        )
    return ExitCode.OK
