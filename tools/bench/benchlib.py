"""Shared helpers for benchmarks in tools/bench/.

House rule: this machine is shared and noisy, so every figure is reported as a ratio to a
reference measured side by side in the same run, alternating the two so that load spikes hit
both; each benchmark prints a human table and, with --json, one JSON line per figure.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from collections.abc import Callable
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


def parser(description: str) -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--json", action="store_true", help="print one JSON line per figure")
    return p


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
