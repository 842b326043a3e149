"""Shared helpers of the benchmarks in tools/bench/ (the runner: `python -m tools.bench`).

House rule: this machine is shared and noisy, so every figure is reported as a ratio to a
reference measured side by side in the same run, alternating the two so that load spikes hit
both; each benchmark prints a human table and, with --json, one JSON line per figure.
`--busy N` (where a benchmark offers it) measures again beside N busy-loop processes started
and stopped by `busy_loops`, in the same run, so a figure's quiet and loaded values sit side by
side. Every benchmark runs under the toolkit's thread policy (spectratac.threads).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field
from typing import Any


@dataclass
class Figure:
    name: str
    value: float
    unit: str
    reference_name: str
    reference_value: float
    ratio: float  # value / reference_value
    extra: dict[str, Any] = field(default_factory=dict)


def best_rate(fn: Callable[[], int], repeats: int = 5) -> float:
    """Items per second of the fastest of `repeats` calls; `fn` returns how many items it did."""
    rates = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        n = fn()
        rates.append(n / (time.perf_counter() - t0))
    return max(rates)


def side_by_side(
    subject: Callable[[], int], reference: Callable[[], int], rounds: int = 5
) -> tuple[float, float]:
    """Alternate subject and reference `rounds` times; return the median rate of each."""
    s_rates, r_rates = [], []
    for _ in range(rounds):
        s_rates.append(best_rate(subject, 1))
        r_rates.append(best_rate(reference, 1))
    return statistics.median(s_rates), statistics.median(r_rates)


def gemm_seconds(flops: float, batch: int, threads: int, width: int = 128) -> float:
    """Seconds torch takes for `flops` of (batch x width) @ (width x width) products on
    `threads` threads: raw arithmetic of a training's size, the reference of training times."""
    import torch

    torch.set_num_threads(threads)
    a, b = torch.randn(batch, width), torch.randn(width, width)
    reps = max(1, int(flops / (2 * batch * width * width)))
    t0 = time.perf_counter()
    for _ in range(reps):
        torch.mm(a, b)
    return time.perf_counter() - t0


def parser(description: str, busy: bool = False) -> argparse.ArgumentParser:
    """The common options; applies the thread policy first, as every toolkit process does."""
    from spectratac import threads

    threads.apply()
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--json", action="store_true", help="print one JSON line per figure")
    if busy:
        p.add_argument(
            "--busy",
            type=int,
            default=0,
            metavar="N",
            help="also measure beside N busy-loop processes (the issue's 'under load': 2)",
        )
    return p


@contextlib.contextmanager
def busy_loops(n: int) -> Iterator[list[subprocess.Popen[bytes]]]:
    """N processes that each spin one core (`while True: pass`) for the duration, then are
    killed; they run at normal priority like a user's other work."""
    procs = [
        subprocess.Popen([sys.executable, "-c", "while True: pass"], env=dict(os.environ))
        for _ in range(max(0, n))
    ]
    try:
        time.sleep(0.2 if procs else 0.0)  # let them reach the run queue
        yield procs
    finally:
        for proc in procs:
            proc.kill()
        for proc in procs:
            proc.wait()


def load_label(n: int) -> str:
    return "quiet" if n == 0 else f"{n} busy loops"


def loadavg() -> float:
    """The 1-minute load average at measurement time, reported beside each figure."""
    return round(os.getloadavg()[0], 2)


def report(figures: list[Figure], as_json: bool) -> None:
    if as_json:
        for f in figures:
            print(json.dumps(asdict(f)))
        return
    width = max(len(f.name) for f in figures)
    for f in figures:
        print(
            f"{f.name:<{width}}  {f.value:>14,.1f} {f.unit:<10} "
            f"= {f.ratio:8.3f} x {f.reference_name} ({f.reference_value:,.1f})"
        )
