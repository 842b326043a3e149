"""Speed against error: integration time x LED sequencing x model size on one scene.

Every acquisition setting (`studies.bench.acquisition`) records the same calibration scene (same
presses, same unit), so the settings differ only in how they sample it. Each model is trained
on the blocked split's training rows and scored on its test rows. Training budget: the same
epochs and the same optimiser steps per epoch everywhere (the batch shrinks with the number
of samples a longer integration leaves), so slow settings are not under-trained.

Per point: full observations per second (one integration per LED step), single-sample
inference latency (measured side by side afterwards), training time, MAE per force axis,
R² and region accuracy. `pareto_front` picks the points no other point beats on both rate
and error.

>>> MODELS["mlp"], batch_for(400)
({'model': 'mlp', 'hidden': 64, 'blocks': 2}, 128)
>>> pareto_front([(20.0, 0.3), (10.0, 0.2), (10.0, 0.4), (5.0, 0.25)])
[0, 1]
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from spectratac.dataset.schema import Dataset
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.studies.bench.acquisition import Acquisition

MODELS: dict[str, dict[str, Any]] = {
    "linear": {"model": "linear"},
    "mlp": {"model": "mlp", "hidden": 64, "blocks": 2},
    "resmlp": {},  # the paper's: hidden 128, 3 blocks
    "resmlp-large": {"model": "resmlp-large"},  # hidden 256, 6 blocks
}
HEAVY = ("resmlp-large",)  # ~8x the paper's flops: trained where it is informative
REFERENCE = ("50ms-white", "resmlp")  # the paper's acquisition and model
BASE_BATCH = 1024  # the paper's batch at 50 ms


def batch_for(integration_ms: int) -> int:
    """Batch size that keeps optimiser steps per epoch equal across integration times."""
    return max(32, round(BASE_BATCH * 50 / integration_ms))


def make_dataset(scene: Any, acq: Acquisition, seed: int) -> Any:
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.twin import generate_session

    return from_twin_session(generate_session(scene, seed=seed, **acq.settings()), scene)


def grid_point(
    dataset: Dataset,
    acq: Acquisition,
    model_name: str,
    epochs: int,
    seed: int,
    split: Any,
) -> tuple[dict[str, Any], Any]:
    """Train one model on one acquisition's dataset; its table row and the decoder."""
    from spectratac.evaluate.predictions import predict
    from spectratac.evaluate.scoring import score
    from spectratac.train import TrainSpec, train

    spec = TrainSpec.paper(
        epochs=epochs, batch_size=batch_for(acq.integration_ms), seed=seed, **MODELS[model_name]
    )
    dec = train(dataset, spec, rows=split.train, progress=False)
    s = score(dataset, split.test, predict(dec, dataset, split.test)).scores
    comp = s["components"]
    r2 = [m["r2"] for m in comp.values() if np.isfinite(m["r2"])]
    force = [comp[a]["mae"] for a in vocab.FORCE_AXES if a in comp]
    row = {
        "acquisition": acq.name,
        "integration_ms": acq.integration_ms,
        "sequence": acq.sequence,
        "steps": acq.steps,
        "observations_per_s": acq.observations_per_s,
        "model": model_name,
        "params": int(dec.n_params),
        "flops": int(dec.flops_per_sample),
        "train_s": float(dec.meta.get("train_seconds", float("nan"))),
        "n_train": split.n_train,
        "n_test": split.n_test,
        "mae": {k: m["mae"] for k, m in comp.items()},
        "force_mae_mean": float(np.mean(force)) if force else float("nan"),
        "r2_mean": float(np.mean(r2)) if r2 else float("nan"),
        "region_accuracy": s.get("region", {}).get("accuracy", float("nan")),
        "saturated_fraction": float(np.mean(dataset.arrays["status"] != 0))
        if "status" in dataset.arrays
        else 0.0,
    }
    return row, dec


def run_grid(
    scene: Any,
    acquisitions: Sequence[Acquisition],
    models: Sequence[str],
    *,
    epochs: int,
    seed: int = 0,
    full_grid: bool = False,
    on_done: Callable[[dict[str, Any]], None] | None = None,
) -> tuple[list[dict[str, Any]], dict[tuple[str, str], tuple[Any, Any]]]:
    """All points; also (decoder, dataset) per (acquisition, model) for latency timing.

    HEAVY models train on the white sequence only (every integration time) unless
    `full_grid`: the LED sequence's effect is measured with the other models."""
    from spectratac.train.groups import SplitSpec, split_dataset

    rows: list[dict[str, Any]] = []
    trained: dict[tuple[str, str], tuple[Any, Any]] = {}
    for acq in acquisitions:
        ds = make_dataset(scene, acq, seed)
        split = split_dataset(ds, SplitSpec("blocked", seed=seed))
        for m in models:
            if m in HEAVY and acq.sequence != "white" and not full_grid:
                continue
            row, dec = grid_point(ds, acq, m, epochs, seed, split)
            rows.append(row)
            trained[(acq.name, m)] = (dec, ds)
            if on_done is not None:
                on_done(row)
    return rows, trained


def add_latency(
    rows: list[dict[str, Any]],
    trained: dict[tuple[str, str], tuple[Any, Any]],
    calls: int = 1000,
    rounds: int = 3,
) -> None:
    """Single-sample latency of every decoder, timed side by side; ratios to the reference
    (the paper's model at 50 ms white, or the first point if that was not run). In place."""
    from spectratac.studies.bench.latency import side_by_side_latency, single_sample_fn

    fns, inputs = {}, {}
    for key, (dec, ds) in trained.items():
        name = f"{key[0]}/{key[1]}"
        fns[name], inputs[name] = single_sample_fn(dec, ds)
    lat = side_by_side_latency(fns, inputs, calls=calls, rounds=rounds)
    ref_key = f"{REFERENCE[0]}/{REFERENCE[1]}"
    ref_key = ref_key if ref_key in lat else next(iter(lat))
    ref_row = next(r for r in rows if f"{r['acquisition']}/{r['model']}" == ref_key)
    for r in rows:
        t = lat[f"{r['acquisition']}/{r['model']}"]
        r["latency_us"] = t["median_us"]
        r["latency_p99_us"] = t["p99_us"]
        r["latency_ratio"] = t["median_us"] / lat[ref_key]["median_us"]
        r["train_ratio"] = r["train_s"] / ref_row["train_s"] if ref_row["train_s"] else float("nan")
    for r in rows:
        r["reference"] = ref_key


def pareto_front(points: Sequence[tuple[float, float]]) -> list[int]:
    """Indices of (rate, error) points that no other point beats on both (higher rate and
    lower error, at least one strictly), in input order."""
    out = []
    for i, (ri, ei) in enumerate(points):
        dominated = any(
            (rj >= ri and ej <= ei) and (rj > ri or ej < ei)
            for j, (rj, ej) in enumerate(points)
            if j != i
        )
        if not dominated and np.isfinite(ei):
            out.append(i)
    return out
