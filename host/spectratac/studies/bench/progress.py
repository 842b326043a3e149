"""Run a decoder benchmark with a progress bar on stderr, one step per trained model.

>>> from spectratac.studies.bench.decoder import BenchConfig
>>> planned_points(BenchConfig.quick(models=("resmlp",), sequences=("white",)))
[(50, 'white', 'resmlp'), (200, 'white', 'resmlp')]
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from spectratac.studies.bench.decoder import BenchConfig, speed_bench, variants_bench
from spectratac.studies.bench.speed import HEAVY


def planned_points(cfg: BenchConfig) -> list[tuple[int, str, str]]:
    """(integration, sequence, model) triples the speed benchmark will train."""
    return [
        (i, s, m)
        for i in cfg.integrations
        for s in cfg.sequences
        for m in cfg.models
        if cfg.full_grid or m not in HEAVY or s == "white"
    ]


def run_with_progress(
    cfg: BenchConfig, out: Path, variants: bool, show: bool = True
) -> dict[str, Any]:
    """`speed_bench` (or, with `variants`, `variants_bench`) writing into `out`, with a tqdm
    bar on stderr unless `show` is False; returns the benchmark's JSON dict."""
    from spectratac.progress import bar as progress_bar

    points = len({"paper", *cfg.variants}) if variants else len(planned_points(cfg))
    bar = progress_bar(
        total=points + 1,  # + the latency / oracle stage
        desc="decoder bench",
        unit="model",
        leave=False,
        enabled=show,
    )

    def tick(stage: str) -> None:
        bar.set_postfix_str(stage)
        bar.update(1)

    try:
        return (variants_bench if variants else speed_bench)(cfg, out, tick)
    finally:
        bar.close()
