"""How long the twin's verbs will take on this machine, now: `twin report`, `twin generate`,
`twin population` and `demo`, whose work is simulated sessions (and, for the demo, the data
it records, which do not exist before it runs). Rates come from short probes of that very
work: a calibration scene generated (`twin_probe`), its recording built (`twin_build_rate`),
the recipes trained on its rows, the twin's inverse run on a few (`oracle_rate`).

The product's verbs (`record`, `dataset build`, `train`, `evaluate`) probe the user's own
data instead: `spectratac.apps.estimates`, whose `Estimate` and `TrainingCost` this module
shares. `with_oracle` adds the oracle's part to `evaluate`'s estimate on simulated data.
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from spectratac import threads
from spectratac.apps.estimates import Estimate, TrainingCost, timed
from spectratac.dataset.schema import Dataset

#: Simulated seconds of the probe scene: long enough for every region, short enough to be
#: a small fraction of any verb it estimates.
PROBE_SCENE_S = 240.0
PROBE_ORACLE_ROWS = 6
#: Simulated seconds of the session whose recording `demo_estimate` builds (building has a
#: per-sample rate; writing the probe's recording first costs several times the build).
BUILD_PROBE_SCENE_S = 60.0


# ------------------------------------------------------------------ probes
@dataclass(frozen=True)
class TwinProbe:
    """A short twin calibration session, its dataset, and the generation rate it measured."""

    session: Any
    scene: Any
    dataset: Dataset
    seconds_per_scene_s: float


def twin_probe(seed: int = 0, scene_s: float = PROBE_SCENE_S) -> TwinProbe:
    """Generate `scene_s` of the calibration scene and time it."""
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.twin import builtin_scenes, generate_session

    scene = builtin_scenes.calibration_session(seed=seed, duration_s=scene_s)
    session, seconds = timed(generate_session, scene, seed=seed)
    return TwinProbe(session, scene, from_twin_session(session, scene), seconds / scene_s)


def twin_build_rate(probe: TwinProbe) -> float:
    """Seconds per sample of building a dataset from a recording of the probe session (the
    demo's recording, before it exists)."""
    from spectratac.dataset.build import build_datasets
    from spectratac.sim.synthetic_recording import write_twin_recording

    with tempfile.TemporaryDirectory() as folder:
        path = write_twin_recording(
            Path(folder) / "probe.mcap", probe.session, probe.scene, "calibration"
        )
        _, seconds = timed(build_datasets, [path])
    return seconds / max(len(probe.session), 1)


def oracle_rate(dataset: Dataset, rows: int = PROBE_ORACLE_ROWS) -> float:
    """Seconds per row of the twin's inverse (spectratac.studies.oracle_floor)."""
    from spectratac.studies.oracle_floor import OracleFloor

    _, seconds = timed(OracleFloor(rows), dataset, np.arange(dataset.n), 0)
    return seconds / rows


# ------------------------------------------------------------------ estimators
def demo_estimate(
    scene_s: float, speed: float, epochs: int, oracle_samples: int, seed: int = 0
) -> Estimate:
    """`spectratac demo`: the recording is paced (scene_s / speed of wall time); the dataset,
    training (paper recipe and best decoder, each on two splits) and the twin's inverse
    are rates measured on a probe session of the same scene. The four fits run side by side
    (train/parallel.py), each with the threads it has alone, as probed: they take the
    `makespan` of running them in the demo's order on its workers, each slowed by its share
    of the cores (`shared_slowdown`)."""
    from spectratac.train import KINDS, TrainSpec
    from spectratac.train.parallel import fit_threads, workers_for

    t0 = time.perf_counter()
    probe = twin_probe(seed)
    rows = int(scene_s * 20)  # 50 ms samples
    # a shorter session to build: writing the probe recording costs more than building it
    per_build = twin_build_rate(twin_probe(seed, scene_s=BUILD_PROBE_SCENE_S))
    paper = TrainingCost.measure(probe.dataset, TrainSpec.paper(seed=seed))
    best = TrainingCost.measure(probe.dataset, TrainSpec.best(seed=seed))
    fit_rows = int(rows * 0.8)  # each split trains on about four fifths of the rows
    per_fit = [paper.seconds(fit_rows, epochs), best.seconds(fit_rows, epochs)]
    workers = workers_for(2 * len(KINDS))
    slow = shared_slowdown(workers, fit_threads(), threads.usable_cpus())
    train_s = makespan([s * slow for s in per_fit for _ in KINDS], workers)
    per_oracle = oracle_rate(probe.dataset) if oracle_samples > 0 else 0.0
    return Estimate(
        {
            "record": scene_s / speed,
            "dataset": per_build * rows,
            "train + evaluate": train_s + 2 * oracle_samples * per_oracle,
        },
        {
            "dataset s/sample": per_build,
            "paper recipe s/row-epoch": paper.row_epoch_s,
            "best decoder s/row-epoch": best.row_epoch_s,
            "best decoder s/row per fit": best.row_s,
            "twin inverse s/row": per_oracle,
        },
        time.perf_counter() - t0,
    )


#: Speed-up of a small network from a second thread on 2 cores (~1.5x), as the exponent of a
#: power law in the cores a fit gets: 2 ** THREAD_SCALING = 1.5.
THREAD_SCALING = 0.585


def shared_slowdown(workers: int, fit_threads: int, cpus: int) -> float:
    """How much longer a fit probed alone with `fit_threads` threads takes when `workers` such
    fits share `cpus` CPUs: each gets cpus / workers of them, and a fit's speed grows with
    its cores as cores ** THREAD_SCALING (train/parallel.py keeps every fit's threads).

    >>> shared_slowdown(1, 2, 2), round(shared_slowdown(2, 2, 2), 2), shared_slowdown(4, 1, 4)
    (1.0, 1.5, 1.0)
    """
    cores = min(float(fit_threads), cpus / max(1, workers))
    return float((fit_threads / cores) ** THREAD_SCALING) if cores < fit_threads else 1.0


def makespan(seconds: list[float], workers: int) -> float:
    """Wall time of jobs taking `seconds` each, started in this order by `workers` processes
    as each becomes free (as a process pool hands them out).

    >>> makespan([2.0, 2.0, 10.0, 10.0], 2), makespan([2.0, 2.0, 10.0, 10.0], 1)
    (12.0, 24.0)
    >>> makespan([3.0, 1.0, 1.0], 2)
    3.0
    """
    free = [0.0] * max(1, workers)
    for s in seconds:
        i = free.index(min(free))
        free[i] += s
    return max(free)


def twin_report_estimate(cfg: Any) -> Estimate:
    """`spectratac twin report`: generate cfg.duration_s of the calibration scene, train the
    paper's recipe on two splits, decode cfg.oracle_samples rows twice with the oracle."""
    from spectratac.train import TrainSpec

    t0 = time.perf_counter()
    probe = twin_probe(cfg.seed)
    spec = TrainSpec.paper(epochs=cfg.epochs, batch_size=cfg.batch_size, seed=cfg.seed)
    cost = TrainingCost.measure(probe.dataset, spec)
    per_oracle = oracle_rate(probe.dataset)
    rows = int(cfg.duration_s * 20)
    fit_rows = int(rows * (1 - cfg.test_fraction))
    return Estimate(
        {
            "generate": probe.seconds_per_scene_s * cfg.duration_s,
            "train": 2 * cost.seconds(fit_rows, cfg.epochs),
            "oracle": 2 * min(cfg.oracle_samples, rows) * per_oracle,
        },
        {
            "twin s/scene s": probe.seconds_per_scene_s,
            "paper recipe s/row-epoch": cost.row_epoch_s,
            "oracle s/row": per_oracle,
        },
        time.perf_counter() - t0,
    )


def generation_estimate(scene_seconds: float, seed: int = 0) -> Estimate:
    """`twin generate` / `twin population`: `scene_seconds` of simulation in all."""
    t0 = time.perf_counter()
    probe = twin_probe(seed, scene_s=60.0)  # generation alone: a shorter probe will do
    return Estimate(
        {"generate": probe.seconds_per_scene_s * scene_seconds},
        {"twin s/scene s": probe.seconds_per_scene_s},
        time.perf_counter() - t0,
    )


def with_oracle(estimate: Estimate, dataset: Dataset, oracle_rows: int) -> Estimate:
    """`evaluate`'s estimate with the twin's inverse decoding `oracle_rows` rows in all,
    timed on a few of them, when `dataset` comes from the twin (the oracle runs on nothing
    else); `estimate` as it is otherwise."""
    sessions = dataset.meta.get("sessions") or []
    if oracle_rows <= 0 or not any(s.get("source") == "twin" for s in sessions):
        return estimate
    per_row, seconds = timed(oracle_rate, dataset, rows=min(PROBE_ORACLE_ROWS, dataset.n))
    return estimate.with_part("oracle", oracle_rows * per_row, {"oracle s/row": per_row}, seconds)
