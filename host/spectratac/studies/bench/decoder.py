"""The two decoder benchmarks end to end, run by `tools/bench/decoder.py`: build the data,
train, score, time, write tables and plots.

- `variants_bench`: the paper's recipe against each improvement beyond it.
- `speed_bench`: integration time x LED sequence x model size.

Both write ``<name>.md``, ``<name>.json`` (and the Pareto PNG) into the output folder and
return the JSON dict. `QUICK` settings run in seconds for the test suite; numbers from them
mean nothing.

>>> BenchConfig.quick().duration_s, BenchConfig().resolved('variants').duration_s
(40.0, 3000.0)
"""

from __future__ import annotations

import json
import math
import platform
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from spectratac.studies.bench.acquisition import INTEGRATION_MS, SEQUENCES, grid
from spectratac.studies.bench.speed import MODELS, REFERENCE, add_latency, pareto_front, run_grid
from spectratac.studies.bench.tables import (
    grid_markdown,
    latency_front,
    pareto_plot,
    variants_markdown,
)
from spectratac.studies.bench.variants import VARIANTS, run_variants, target_check

Progress = Callable[[str], None]
# Scene lengths of the full runs (s of the calibration protocol; the paper's is 3000 s):
# variants train 12 ResMLPs on one session; the speed grid 40 models on 12 sessions.
# The variants use the paper's whole protocol (50 min, 30 epochs): the target is about it.
DEFAULT_DURATION_S = {"variants": 3000.0, "speed": 400.0}
DEFAULT_EPOCHS = {"variants": 30, "speed": 20}


@dataclass(frozen=True)
class BenchConfig:
    """Scene length (s of the calibration protocol), seed, epochs and what to cover."""

    duration_s: float | None = None  # None: DEFAULT_DURATION_S of the benchmark
    seed: int = 0
    epochs: int | None = None  # None: DEFAULT_EPOCHS of the benchmark
    integrations: tuple[int, ...] = INTEGRATION_MS
    sequences: tuple[str, ...] = SEQUENCES
    models: tuple[str, ...] = tuple(MODELS)
    variants: tuple[str, ...] = tuple(VARIANTS)
    train_seeds: tuple[int, ...] = (0, 1, 2)  # variants: blocked split repeated per seed
    latency_calls: int = 1000
    latency_rounds: int = 3
    oracle_samples: int = 500
    full_grid: bool = False  # also train the heavy models on every LED sequence
    extra: dict[str, Any] = field(default_factory=dict)

    def resolved(self, bench: str) -> BenchConfig:
        """This config with the benchmark's default scene length filled in."""
        return replace(
            self,
            duration_s=self.duration_s or DEFAULT_DURATION_S[bench],
            epochs=self.epochs or DEFAULT_EPOCHS[bench],
        )

    @classmethod
    def quick(cls, **changes: Any) -> BenchConfig:
        """Seconds, not minutes: for tests only."""
        base = cls(
            duration_s=40.0,
            epochs=2,
            integrations=(50, 200),
            sequences=("white", "rgb"),
            models=("linear", "resmlp"),
            latency_calls=50,
            latency_rounds=1,
            oracle_samples=20,
            train_seeds=(0,),
        )
        return replace(base, **changes)


def _warm_torch() -> None:
    """Import torch up front so the first model's training time does not include it."""
    import torch  # noqa: F401


def _calibration(cfg: BenchConfig) -> Any:
    from spectratac.twin import builtin_scenes as scenes

    return scenes.calibration_session(seed=cfg.seed, duration_s=float(cfg.duration_s or 0))


def _header(cfg: BenchConfig, started: float) -> dict[str, Any]:
    return {
        "config": {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(cfg).items()},
        "machine": {"python": platform.python_version(), "processor": platform.machine()},
        "elapsed_s": time.perf_counter() - started,
    }


def _write(out: Path, name: str, result: dict[str, Any], markdown: str) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{name}.json").write_text(json.dumps(_clean(result), indent=1) + "\n")
    (out / f"{name}.md").write_text(markdown + "\n")


def _clean(v: Any) -> Any:
    if isinstance(v, dict):
        return {str(k): _clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def variants_bench(cfg: BenchConfig, out: Path, progress: Progress | None = None) -> dict:
    """Every variant and the paper's recipe on the same data and splits."""
    from spectratac.evaluate.scoring import score
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.studies.bench.latency import side_by_side_latency, single_sample_fn
    from spectratac.studies.oracle_floor import oracle_predictions
    from spectratac.train.groups import SplitSpec, split_dataset
    from spectratac.twin import generate_session

    tick = progress or (lambda s: None)
    t0 = time.perf_counter()
    cfg = cfg.resolved("variants")
    _warm_torch()
    scene = _calibration(cfg)
    ds = from_twin_session(generate_session(scene, seed=cfg.seed), scene)
    names = ("paper", *[v for v in cfg.variants if v != "paper"])
    base = {"epochs": cfg.epochs}
    rows, models = run_variants(
        ds, names, base, seed=cfg.seed, train_seeds=cfg.train_seeds, on_done=tick
    )
    # Inference cost measured side by side, as ratios to the paper's recipe.
    fns, inputs = {}, {}
    for name, dec in models.items():
        fns[name], inputs[name] = single_sample_fn(dec, ds)
    lat = side_by_side_latency(fns, inputs, cfg.latency_calls, cfg.latency_rounds)
    for r in rows:
        r["latency_us"] = lat[r["name"]]["median_us"]
        r["latency_p99_us"] = lat[r["name"]]["p99_us"]
        r["latency_ratio"] = lat[r["name"]]["median_us"] / lat["paper"]["median_us"]
    oracle: dict[str, Any] = {}
    for kind in ("random", "blocked"):
        split = split_dataset(ds, SplitSpec(kind, seed=cfg.seed))
        o_rows, pred, note = oracle_predictions(ds, split.test, scene, cfg.oracle_samples, cfg.seed)
        if pred is not None:
            comp = score(ds, o_rows, pred).scores["components"]
            oracle[kind] = {"mae": {k: m["mae"] for k, m in comp.items()}, "note": note}
    tick("oracle")
    check = target_check(rows)
    result = {
        **_header(cfg, t0),
        "dataset": {"rows": ds.n, "scene": "calibration", "duration_s": cfg.duration_s},
        "rows": rows,
        "oracle": oracle,
        "target": check,
    }
    _write(out, "decoder_variants", result, variants_report(result))
    return _clean(result)


def _cells(d: dict[str, float]) -> str:
    return ", ".join(f"{a} {v:+.1f} %" for a, v in d.items())


def variants_report(result: dict[str, Any]) -> str:
    """Markdown for `variants_bench`."""
    cfg = result["config"]
    chk = result["target"]
    lines = [
        "# Decoder variants against the paper's recipe",
        "",
        f"Twin calibration session: {cfg['duration_s']:g} s, {result['dataset']['rows']} "
        f"samples at 20 Hz, seed {cfg['seed']}; every variant trained {cfg['epochs']} epochs "
        "(batch 1024, One-Cycle AdamW) on each split's training rows. Blocked split: mean "
        f"over training seeds {', '.join(map(str, cfg['train_seeds']))} (± the MAE's "
        "standard deviation over them); random split: the first seed. MAE cells: value "
        "(change of the mean against the paper's recipe; + is better).",
        "",
    ]
    for kind, title in (
        ("blocked", "Blocked split (whole presses held out, 0.5 s guard)"),
        ("random", "Random split (the paper's protocol)"),
    ):
        lines += [f"## {title}", "", variants_markdown(result["rows"], kind), ""]
        orc = result["oracle"].get(kind)
        if orc:
            m = orc["mae"]
            lines.append(
                f"Oracle floor: Fx {m['Fx']:.3f}, Fy {m['Fy']:.3f}, Fz {m['Fz']:.3f} N "
                f"({orc['note']})."
            )
            ref = next((r for r in result["rows"] if r["name"] == "paper"), None)
            if ref and kind in ref and m["Fz"] > ref[kind]["mae"]["Fz"]:
                lines.append(
                    "The oracle is above the learned decoders here: a per-sample inversion "
                    "cannot see the elastomer's creep (time constants 0.5 s and 8 s in the "
                    "twin), which the decoders learn on average; it is no lower bound."
                )
            lines.append("")
    verdict = "MET" if chk.get("met") else "NOT MET"
    lines += [
        "## Target: >= 25 % lower blocked-split MAE per force axis at no more inference cost",
        "",
        f"**{verdict}**. Cost limit: {chk.get('cost_limit_flops', 0):,} flops/sample (the "
        f"paper's {chk.get('paper_flops', 0):,} + 2 %). Best within it: "
        + (
            f"`{chk['best']}` ({_cells(chk['improvement_pct'])}; {chk['flops']:,} flops)"
            if chk.get("best")
            else "none"
        )
        + f". Best overall: `{chk.get('best_overall')}` "
        f"({_cells(chk.get('best_overall_improvement_pct', {}))}; "
        f"{chk.get('best_overall_flops', 0):,} flops).",
        "",
        f"Elapsed {result['elapsed_s']:.0f} s.",
    ]
    return "\n".join(lines)


def speed_bench(cfg: BenchConfig, out: Path, progress: Progress | None = None) -> dict:
    """Error against observation rate, latency and training time, per grid point."""
    tick = progress or (lambda s: None)
    t0 = time.perf_counter()
    cfg = cfg.resolved("speed")
    _warm_torch()
    scene = _calibration(cfg)
    acqs = grid(cfg.integrations, cfg.sequences)
    rows, trained = run_grid(
        scene,
        acqs,
        cfg.models,
        epochs=cfg.epochs,
        seed=cfg.seed,
        full_grid=cfg.full_grid,
        on_done=lambda r: tick(f"{r['acquisition']}/{r['model']}"),
    )
    add_latency(rows, trained, cfg.latency_calls, cfg.latency_rounds)
    tick("latency")
    mark_pareto(rows)
    result = {**_header(cfg, t0), "reference": "/".join(REFERENCE), "rows": rows}
    render_speed(result, out)
    return _clean(result)


def mark_pareto(rows: list[dict[str, Any]]) -> None:
    """Flag the rate/error and latency/error Pareto points, in place."""
    rate = pareto_front([(r["observations_per_s"], r["force_mae_mean"]) for r in rows])
    fast = latency_front(rows)
    for i, r in enumerate(rows):
        r["pareto"] = i in rate
        r["pareto_latency"] = i in fast


def render_speed(result: dict[str, Any], out: Path) -> None:
    """(Re)write the speed table and plot from a result (e.g. a saved decoder_speed.json)."""
    mark_pareto(result["rows"])
    pareto_plot(result["rows"], out / "decoder_speed_pareto.png")
    _write(out, "decoder_speed", result, speed_report(result))


def speed_report(result: dict[str, Any]) -> str:
    """Markdown for `speed_bench`."""
    cfg = result["config"]
    ref = result["rows"][0].get("reference", result["reference"]) if result["rows"] else ""
    return "\n".join(
        [
            "# Speed against error",
            "",
            f"One twin calibration scene ({cfg['duration_s']:g} s, seed {cfg['seed']}) "
            "recorded under each acquisition setting at fair exposure (clear channel near "
            "41 % of full scale: lower gain / SENS low for long windows, LED duty for the "
            "rest); each model trained "
            f"{cfg['epochs']} epochs with equal optimiser steps per epoch, scored on the "
            "blocked split. obs/s = full observations per second (one integration per LED "
            f"step). Latency: single-sample NumPy inference, timed side by side; x ref = "
            f"ratio to {ref}. Pareto * = no other point has both a higher rate (or a lower "
            "latency) and a lower mean force MAE."
            + (
                ""
                if cfg.get("full_grid")
                else " resmlp-large runs on white LEDs only (the sequence's effect is measured "
                "with the other models)."
            ),
            "",
            grid_markdown(result["rows"]),
            "",
            "![Pareto](decoder_speed_pareto.png)",
            "",
            f"Elapsed {result['elapsed_s']:.0f} s.",
        ]
    )
