"""`spectratac demo` end to end, quiet and beside N busy-loop processes, in the same run.

    python -m tools.bench.demo [--json] [--busy 2] [--epochs 40] [--duration 600]

Runs the demo as `make demo` does (a fresh process, after set-up: the venv exists) into a
temporary folder and reads its own stage timings (estimate, record, dataset, train +
evaluate) and the CPU time it used. The quiet total is set against the demo's budget
(120 s); the loaded total against the quiet total of this run (target <= 2.5x). The two runs'
results tables must be the same (issue 22: the table is a function of the scene), and the
bench fails if they are not. To see where the time goes inside a stage, run the same command
under `python -m cProfile -s cumtime -m spectratac demo ...`.
"""

from __future__ import annotations

import json
import resource
import subprocess
import sys
import tempfile
import time

from tools.bench import benchlib

BUDGET_S = 120.0  # issue 26's budget for make demo on a quiet machine after set-up
LOADED_RATIO = 2.5  # the bound beside two busy loops


def run_demo(epochs: int, duration: float) -> tuple[dict[str, float], list[str]]:
    """One `spectratac demo --json` in its own process: its stage timings, wall and CPU
    time (the process and its children), and its results table."""
    from spectratac.apps.calibration_demo import results_table

    with tempfile.TemporaryDirectory(prefix="stac-bench-demo-") as tmp:
        cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.monotonic()
        out = subprocess.run(
            [sys.executable, "-m", "spectratac", "demo", "-o", f"{tmp}/out", "--json",
             "--epochs", str(epochs), "--duration", f"{duration:g}"],
            capture_output=True, text=True, check=False,
        )  # fmt: skip
        wall = time.monotonic() - t0
        cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if out.returncode != 0:
        raise SystemExit(f"spectratac demo failed ({out.returncode}):\n{out.stderr[-2000:]}")
    summary = json.loads(out.stdout.splitlines()[-1])
    cpu = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
    estimate_s = summary["estimate"]["calibration_s"]
    timings = {**summary["timings_s"], "estimate_s": round(estimate_s, 1)}
    figures = {**timings, "wall_s": round(wall, 1), "cpu_s": round(cpu, 1)}
    return figures, results_table(summary["results"])


def main() -> None:
    p = benchlib.parser(__doc__.splitlines()[0], busy=True)
    p.add_argument("--epochs", type=int, default=40, help="as the demo's default")
    p.add_argument("--duration", type=float, default=600.0, help="scene s, as the demo's")
    args = p.parse_args()
    quiet, table = run_demo(args.epochs, args.duration)
    loaded_table = table
    figures = [
        benchlib.Figure("make demo, quiet", quiet["wall_s"], "s", "budget", BUDGET_S,
                        quiet["wall_s"] / BUDGET_S, {**quiet, "loadavg": benchlib.loadavg()})
    ]  # fmt: skip
    if args.busy:
        with benchlib.busy_loops(args.busy):
            loaded, loaded_table = run_demo(args.epochs, args.duration)
            load = benchlib.loadavg()
        figures.append(
            benchlib.Figure(
                f"make demo, {benchlib.load_label(args.busy)}",
                loaded["wall_s"],
                "s",
                "quiet",
                quiet["wall_s"],
                loaded["wall_s"] / quiet["wall_s"],
                {**loaded, "target_ratio": LOADED_RATIO, "loadavg": load},
            )
        )
    benchlib.report(figures, args.json)
    if not args.json:
        print("\n".join(table))
    if loaded_table != table:
        diff = [
            f"  quiet: {a}\n  busy:  {b}"
            for a, b in zip(table, loaded_table, strict=False)
            if a != b
        ]
        raise SystemExit("the table differs beside the busy loops:\n" + "\n".join(diff))


if __name__ == "__main__":
    main()
