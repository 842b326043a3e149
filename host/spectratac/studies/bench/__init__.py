"""The decoder benchmarks as a library, which `tools/bench/decoder.py` (the `decoder-speed` and
`decoder-variants` entries of `make bench`) calls.

- `speed_bench(cfg, out)`: integration time x LED sequence x model size, error against
  observation rate, latency and training time (`speed`, `acquisition`).
- `variants_bench(cfg, out)`: the paper's recipe against each improvement beyond it, same
  data and splits (`variants`).

Both write ``<name>.md`` and ``<name>.json`` (the speed bench also its Pareto PNG) into `out`
and return the JSON dict; `run_with_progress` adds a progress bar. `add_options` and
`config_from_args` give every entry point the same options and the same `BenchConfig`.

    from spectratac.studies.bench import BenchConfig, speed_bench
    result = speed_bench(BenchConfig.quick(), Path("build/bench-decoder"))

>>> BenchConfig.quick().models
('linear', 'resmlp')
"""

from __future__ import annotations

from spectratac.studies.bench.decoder import BenchConfig, speed_bench, variants_bench
from spectratac.studies.bench.options import add_options, config_from_args
from spectratac.studies.bench.progress import planned_points, run_with_progress

__all__ = [
    "BenchConfig",
    "add_options",
    "config_from_args",
    "planned_points",
    "run_with_progress",
    "speed_bench",
    "variants_bench",
]
