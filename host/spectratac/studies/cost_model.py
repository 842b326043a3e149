"""How long a long verb will take on this machine, now: a cost model whose rates are measured
by short probes of the very work the verb does (never constants), so a loaded laptop gets a
longer estimate than an idle one.

Each probe times a small piece of real work and turns it into a rate:

- `twin_rate`: seconds of generation per simulated second (a short calibration scene);
- `build_rate`: seconds per sample of `dataset build` (a synthetic twin recording, built);
- `TrainingCost.measure`: a fixed cost plus seconds per row-epoch of a TrainSpec (one epoch
  on a few rows, then on two batches, so the fixed part and the per-row part come apart);
- `oracle_rate` and `predict_rate`: seconds per row of the twin's inverse and of a decoder.

The estimators (`demo_estimate`, `twin_report_estimate`, ...) multiply the verb's work units
by those rates and return an `Estimate`: the total, its parts, the rates and how long the
probes took. Torch is imported only by training probes.

>>> e = Estimate({"record": 40.0, "train": 80.0}, {"twin s/scene s": 0.002}, 1.5)
>>> e.total_s, e.as_dict()["parts_s"]["train"]
(120.0, 80.0)
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from spectratac import threads
from spectratac.dataset.schema import Dataset

#: Simulated seconds of the probe scene: long enough for every region, short enough to be
#: a small fraction of any verb it estimates.
PROBE_SCENE_S = 240.0
PROBE_ORACLE_ROWS = 6
#: Simulated seconds of the session whose recording `demo_estimate` builds (building has a
#: per-sample rate; writing the probe's recording first costs several times the build).
BUILD_PROBE_SCENE_S = 60.0


@dataclass(frozen=True)
class Estimate:
    """Seconds per part of a verb's work, the measured rates behind them, and the seconds
    the probes themselves took (already spent when the estimate is shown)."""

    parts_s: dict[str, float]
    rates: dict[str, float]
    calibration_s: float

    @property
    def total_s(self) -> float:
        return float(sum(self.parts_s.values()))

    def as_dict(self) -> dict[str, Any]:
        """The --json form."""
        return {
            "total_s": round(self.total_s, 1),
            "parts_s": {k: round(v, 1) for k, v in self.parts_s.items()},
            "rates": {k: float(f"{v:.4g}") for k, v in self.rates.items()},
            "calibration_s": round(self.calibration_s, 2),
        }


#: Timed calls per training probe; their median is kept (TrainingCost.measure).
PROBE_REPEATS = 3


def _timed(fn: Any, *args: Any, **kwargs: Any) -> tuple[Any, float]:
    t0 = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t0


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
    session, seconds = _timed(generate_session, scene, seed=seed)
    return TwinProbe(session, scene, from_twin_session(session, scene), seconds / scene_s)


def build_rate(probe: TwinProbe, per: str = "sample") -> float:
    """Seconds per sample (or per byte of recording, `per="byte"`) of building a dataset
    from a recording of the probe session."""
    from spectratac.dataset.build import build_datasets
    from spectratac.sim.synthetic_recording import write_twin_recording

    with tempfile.TemporaryDirectory() as folder:
        path = write_twin_recording(
            Path(folder) / "probe.mcap", probe.session, probe.scene, "calibration"
        )
        _, seconds = _timed(build_datasets, [path])
        units = Path(path).stat().st_size if per == "byte" else len(probe.session)
    return seconds / max(units, 1)


@dataclass(frozen=True)
class TrainingCost:
    """Training time of one TrainSpec: fixed_s (planning, features, runtime) plus
    row_epoch_s per training row and epoch."""

    fixed_s: float
    row_epoch_s: float

    def seconds(self, rows: int, epochs: int) -> float:
        return self.fixed_s + self.row_epoch_s * rows * epochs

    @classmethod
    def measure(
        cls, dataset: Dataset, spec: Any, batches: int = 4, repeats: int = PROBE_REPEATS
    ) -> TrainingCost:
        """Train `spec` for one epoch on 64 rows (the fixed cost: planning, features, the
        runtime, an almost empty epoch), then for one epoch on the first `batches` batches of
        rows (contiguous, so temporal context works as in the real run); each `repeats`
        times, keeping the median. Why: the per-row cost is multiplied by rows x epochs
        (~400k in the demo), so one scheduler stall of 0.1 s in a single 20-ms probe on a
        busy machine became an estimate of an hour and more for work of three minutes."""
        from spectratac.train import train

        # no validation split: 64 probe rows hold too few groups to hold one out, and an
        # epoch's validation pass is a small share of it
        one = dataclasses.replace(
            spec, epochs=1, val_fraction=0.0, best_val=False, uncertainty=False
        )
        train(dataset, one, rows=np.arange(16), progress=False)  # torch's once-per-process set-up
        small = np.arange(min(64, dataset.n))
        rows = np.arange(min(batches * int(getattr(spec, "batch_size", 256)), dataset.n))
        fixed = _median_s(repeats, train, dataset, one, rows=small, progress=False)
        t1 = _median_s(repeats, train, dataset, one, rows=rows, progress=False)
        per_row = (t1 - fixed) / max(rows.size - small.size, 1)
        return cls(fixed, max(per_row, t1 / rows.size / 10))  # a noisy probe: never ~0


def _median_s(repeats: int, fn: Any, *args: Any, **kwargs: Any) -> float:
    """The median of `repeats` timed calls: a stall in one of them does not count."""
    return float(np.median([_timed(fn, *args, **kwargs)[1] for _ in range(max(repeats, 1))]))


def oracle_rate(dataset: Dataset, rows: int = PROBE_ORACLE_ROWS) -> float:
    """Seconds per row of the twin's inverse (spectratac.studies.oracle_floor)."""
    from spectratac.studies.oracle_floor import OracleFloor

    _, seconds = _timed(OracleFloor(rows), dataset, np.arange(dataset.n), 0)
    return seconds / rows


def predict_rate(decoder: Any, dataset: Dataset, rows: int = 2000) -> float:
    """Seconds per row of `decoder.predict` on `dataset`."""
    sel = np.arange(min(rows, dataset.n))
    _, seconds = _timed(decoder.predict, dataset, rows=sel)
    return seconds / max(sel.size, 1)


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
    per_build = build_rate(twin_probe(seed, scene_s=BUILD_PROBE_SCENE_S))
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


def training_estimate(dataset: Dataset, spec: Any, fits: int = 1) -> Estimate:
    """`spectratac train`: `fits` trainings of `spec` on every row of `dataset`, probed on
    the dataset's own first rows."""
    t0 = time.perf_counter()
    cost = TrainingCost.measure(dataset, spec)
    return Estimate(
        {"train": fits * cost.seconds(dataset.n, spec.epochs)},
        {"s/row-epoch": cost.row_epoch_s, "fixed s": cost.fixed_s},
        time.perf_counter() - t0,
    )


def evaluation_estimate(decoder: Any, dataset: Dataset, models: int, oracle_rows: int) -> Estimate:
    """`spectratac evaluate`: `models` decoders predict every row; on twin data the oracle
    decodes `oracle_rows` rows in all."""
    t0 = time.perf_counter()
    per_row = predict_rate(decoder, dataset)
    per_oracle = 0.0
    if oracle_rows > 0 and _twin_data(dataset):
        per_oracle = oracle_rate(dataset, rows=min(PROBE_ORACLE_ROWS, dataset.n))
    return Estimate(
        {
            "predict": models * per_row * dataset.n,
            "oracle": oracle_rows * per_oracle,
        },
        {"predict s/row": per_row, "oracle s/row": per_oracle},
        time.perf_counter() - t0,
    )


def build_estimate(paths: list[Path]) -> Estimate:
    """`spectratac dataset build`: the recordings' bytes times the build rate per byte of a
    probe recording (a twin session written as the recorder writes one)."""
    t0 = time.perf_counter()
    per_byte = build_rate(twin_probe(scene_s=60.0), per="byte")
    size = sum(p.stat().st_size for p in paths if p.exists())
    return Estimate({"build": per_byte * size}, {"s/MB": per_byte * 1e6}, time.perf_counter() - t0)


def recording_estimate(duration_s: float | None, clock_scale: float | None) -> Estimate | None:
    """`spectratac record --duration S`: S seconds of the sensor's clock take S / scale wall
    seconds (the link's own pace: 1 for hardware, speed for a paced simulation); None when
    the length is not known up front (a count, a guided protocol, Ctrl-C, speed=max)."""
    if duration_s is None or not clock_scale:
        return None
    return Estimate({"record": duration_s / clock_scale}, {"sensor s per s": clock_scale}, 0.0)


def _twin_data(dataset: Dataset) -> bool:
    return any(s.get("source") == "twin" for s in dataset.meta.get("sessions") or [])
