"""The benchmark suite: `python -m tools.bench` (`make bench`; `make bench-quick` is --quick).

    python -m tools.bench --list                 # the registry (tools/bench/registry.py)
    python -m tools.bench [NAME ...] [--quick] [--json] [--log]
    python -m tools.bench compare A B [--quick]  # two commits' kept results, figure by figure

Each benchmark runs in a process of its own from the repository root and prints figures that
are ratios to a reference measured beside them in the same run (this machine is shared: the
ratio survives the load, an absolute time does not); per benchmark the runner prints them,
headline first, and one JSON line (the headline; with --json, only JSON lines, each with all
of its benchmark's figures). Results are kept per commit in build/bench/results/
(results.py); --log appends one row per figure to the measurements log,
tools/bench/MEASUREMENTS.md (--log-file or $SPECTRATAC_MEASUREMENTS: another file).

A small runner of our own rather than pytest-benchmark or asv: both time a function and keep
its absolute figures per commit, to be compared across runs; here a figure is only meaningful
against the reference measured in the same run, and most benchmarks need processes, servers
and busy loops of their own.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from tools.bench import registry, results
from tools.bench.registry import Benchmark


def run_one(bench: Benchmark, quick: bool) -> dict[str, Any]:
    """Run one benchmark; its entry of the results file."""
    command = bench.command(quick)
    t0 = time.monotonic()
    # Its own session, so that whatever it started goes with it (servers, busy loops).
    proc = subprocess.Popen(
        [sys.executable, *command], cwd=results.REPO, stdout=subprocess.PIPE, text=True,
        start_new_session=True,
    )  # fmt: skip
    try:
        out, _ = proc.communicate()
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    figures = []
    for line in out.splitlines():
        try:
            figure = json.loads(line)
        except ValueError:
            continue
        if isinstance(figure, dict) and {"name", "ratio", "reference_name"} <= set(figure):
            figures.append(figure)
    headline = next((f["name"] for f in figures if bench.is_headline(f["name"])), None)
    return {
        "description": bench.description,
        "figure": bench.figure,
        "headline": headline,
        "command": command,
        "returncode": proc.returncode,
        "seconds": round(time.monotonic() - t0, 1),
        **results.machine(),
        "figures": figures,
    }


def failure(run: dict[str, Any]) -> str | None:
    if run["returncode"] != 0:
        return f"exit code {run['returncode']}"
    if run["headline"] is None:
        return "no headline figure in its output"
    return None


def line(f: dict[str, Any]) -> str:
    return (
        f"  {f['name']}: {results.number(f['value'])} {f['unit']} = {f['ratio']:.3f} x "
        f"{f['reference_name']} ({results.number(f['reference_value'])})"
    )


def show(name: str, run: dict[str, Any], as_json: bool, quick: bool) -> None:
    figures = sorted(run["figures"], key=lambda f: f["name"] != run["headline"])
    if not as_json:
        print(f"{name}: {run['description']} ({run['seconds']:g} s, load {run['loadavg'][0]})")
        for f in figures:
            print(line(f))
        problem = failure(run)
        if problem:
            print(f"  FAILED: {problem}")
    head = figures[0] if figures and figures[0]["name"] == run["headline"] else None
    record = {"bench": name, "quick": quick, "ok": failure(run) is None, "figure": run["figure"]}
    if head:
        record |= {k: head[k] for k in ("name", "value", "unit", "reference_name",
                                        "reference_value", "ratio")}  # fmt: skip
    record |= {"seconds": run["seconds"], "loadavg": run["loadavg"][0]}
    if as_json:  # beside the table, the headline is enough; the results file has them all
        record["figures"] = figures
    print(json.dumps(record), flush=True)


def list_benchmarks(as_json: bool) -> None:
    for b in registry.BENCHMARKS:
        if as_json:
            print(json.dumps({"name": b.name, "description": b.description, "figure": b.figure,
                              "full": ["python", *b.command(False)],
                              "quick": ["python", *b.command(True)], "needs": list(b.needs)}))
            continue
        print(f"{b.name:<17} {b.description}")
        print(f"{'':<17} figure: {b.figure}")
        print(f"{'':<17} full:   python {' '.join(b.command(False))}")
        print(f"{'':<17} quick:  python {' '.join(b.command(True))}")


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m tools.bench",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("names", nargs="*", metavar="NAME", help="benchmarks to run (default: all)")
    p.add_argument("--list", action="store_true", help="list the benchmarks and exit")
    p.add_argument("--quick", action="store_true", help="the few-seconds versions")
    p.add_argument("--json", action="store_true", help="print only JSON lines")
    p.add_argument("--results", type=Path, default=results.RESULTS, help="kept results folder")
    p.add_argument("--log", action="store_true", help="append the figures to the log")
    p.add_argument(
        "--log-file",
        type=Path,
        default=Path(os.environ.get("SPECTRATAC_MEASUREMENTS", results.MEASUREMENTS)),
        help="the measurements log (default tools/bench/MEASUREMENTS.md)",
    )
    return p


def compare_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m tools.bench compare",
        description="Figure by figure, the ratio of B's same-run ratio to A's (above 1: the "
        "figure grew against its reference from A to B).",
    )
    p.add_argument("a", metavar="A", help="a commit with kept results, or a results file")
    p.add_argument("b", metavar="B", help="the same for the other side")
    p.add_argument("--quick", action="store_true", help="compare --quick runs' results")
    p.add_argument("--results", type=Path, default=results.RESULTS, help="kept results folder")
    p.add_argument("--json", action="store_true", help="one JSON line per figure")
    return p


def compare(argv: list[str]) -> int:
    args = compare_parser().parse_args(argv)
    a, b = (
        json.loads(results.find(ref, args.results, args.quick).read_text())
        for ref in (args.a, args.b)
    )
    changes = results.compare(a, b)
    if not changes:
        print("no figure measured in both", file=sys.stderr)
        return 1
    if not args.json:
        print(f"A {a['commit'][:12]}  B {b['commit'][:12]}: ratio to the same-run reference")
    for c in changes:
        if args.json:
            print(json.dumps({"bench": c.bench, "figure": c.figure, "ratio_a": c.ratio_a,
                              "ratio_b": c.ratio_b, "b_over_a": c.change,
                              "headline": c.headline}))  # fmt: skip
        else:
            mark = "*" if c.headline else " "
            print(f"{mark} {c.bench}: {c.figure}: A {c.ratio_a:.4g}  B {c.ratio_b:.4g}  "
                  f"B/A {c.change:.3f}")  # fmt: skip
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["compare"]:
        return compare(argv[1:])
    p = parser()
    args = p.parse_args(argv)
    if args.list:
        list_benchmarks(args.json)
        return 0
    known = registry.by_name()
    unknown = [n for n in args.names if n not in known]
    if unknown:
        p.error(f"unknown benchmark {', '.join(unknown)}: see --list")
    selected = [known[n] for n in args.names] or list(registry.BENCHMARKS)
    commit, dirty = results.head()
    failed, logged = [], 0
    for bench in selected:
        missing = bench.missing()
        if missing:
            print(f"{bench.name}: skipped, needs {', '.join(missing)}", file=sys.stderr)
            continue
        run = run_one(bench, args.quick)
        results.save(args.results, commit, dirty, args.quick, {bench.name: run})
        show(bench.name, run, args.json, args.quick)
        if failure(run):
            failed.append(bench.name)
        elif args.log:
            logged += results.append_log(
                args.log_file, results.log_rows(bench.name, run, commit, dirty)
            )
    kept = results.results_path(args.results, commit, args.quick)
    if not args.json:
        appended = f"; {logged} rows appended to {args.log_file}" if logged else ""
        print(f"results: {kept}{appended}")
    if failed:
        print(f"failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
