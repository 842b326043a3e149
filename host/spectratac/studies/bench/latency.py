"""Single-sample inference latency of decoders, measured side by side (alternating rounds,
so that load spikes on this shared machine hit every decoder alike), without torch.

A decoder is timed on its live path, what `Decoder.stream` does per sample: the assembly
(latest sample of each LED step, context lags, moving averages, baseline; its cost grows
with the temporal context) and then the stateless network (`Runtime.run1`).

>>> import numpy as np
>>> fns = {"a": lambda u: u * 2, "b": lambda u: u + 1}
>>> r = side_by_side_latency(fns, np.ones((4, 3)), calls=50, rounds=2)
>>> sorted(r), sorted(r["a"])
(['a', 'b'], ['calls', 'median_us', 'p99_us'])
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.dataset.schema import Dataset

F64 = NDArray[np.float64]


def single_sample_fn(decoder: Any, dataset: Dataset) -> tuple[Callable[[F64], Any], F64]:
    """(per-sample live function, its inputs) for a `Decoder`: the inputs are rows
    ``[step, channels...]`` of the dataset's first session in time order, and the function
    assembles one row and runs the network on it."""
    from spectratac.decode.assemble import Assembler, session_order

    a = dataset.arrays
    order = session_order(a["session"], a["t_end"])[0]
    feed = np.column_stack([a["step"][order], a["inputs"][order]]).astype(np.float64)
    feed = feed[np.all(np.isfinite(feed), axis=1)]
    push = Assembler(decoder.layout).push
    run1 = decoder.runtime.run1

    def live(row: F64) -> Any:
        return run1(push(int(row[0]), row[1:])[0])

    return live, feed


def side_by_side_latency(
    fns: dict[str, Callable[[F64], Any]],
    inputs: F64 | dict[str, F64],
    calls: int = 2000,
    rounds: int = 5,
) -> dict[str, dict[str, float]]:
    """Median and p99 latency (µs) per function over `rounds` alternating rounds of `calls`
    single-row calls each (inputs cycle through the given rows)."""
    times: dict[str, list[float]] = {k: [] for k in fns}
    per = {k: (inputs[k] if isinstance(inputs, dict) else inputs) for k in fns}
    clock = time.perf_counter_ns
    for _ in range(rounds):
        for name, fn in fns.items():
            rows = per[name]
            fn(rows[0])  # warm the code path (allocations, caches)
            buf = times[name]
            for i in range(calls):
                v = rows[i % rows.shape[0]]
                t0 = clock()
                fn(v)
                buf.append((clock() - t0) / 1000.0)
    return {
        k: {
            "median_us": float(np.median(v)),
            "p99_us": float(np.percentile(v, 99)),
            "calls": len(v),
        }
        for k, v in times.items()
    }
