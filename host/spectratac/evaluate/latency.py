"""Single-sample inference latency of decoders, measured side by side (alternating rounds,
so that load spikes on this shared machine hit every decoder alike), without torch.

A decoder is timed on its stateless part (assembled vector -> outputs, `Runtime.run1`, what
a live stream calls per sample); the assembly itself is a few copies and is the same for
every model with the same layout.

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

F64 = NDArray[np.float64]


def single_sample_fn(decoder: Any, dataset: Any) -> tuple[Callable[[F64], Any], F64]:
    """(per-sample function, assembled input vectors of valid rows) for a `Decoder`."""
    from spectratac.decode.assemble import assemble

    a = dataset.arrays
    u, valid = assemble(decoder.layout, a["inputs"], a["step"], a["session"], a["t_end"])
    u = u[valid]
    run1 = getattr(decoder.runtime, "run1", None)
    if run1 is None:  # older runtime: the batch path on one row
        return (lambda v: decoder.runtime.run(v[None, :])), u
    return run1, u


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
