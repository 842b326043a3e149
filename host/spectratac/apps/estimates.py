"""How long `record`, `dataset build`, `train` and `evaluate` will take on this machine, now:
rates measured by short probes of the user's own data (the recording's first chunks, the
dataset's first rows, the model on that dataset), never constants and never a simulated
session, so a large file or a loaded laptop gets a longer estimate.

`spectratac.cli.eta` prints them. The twin's verbs (`twin report|generate|population`, and
`demo`, whose data do not exist before it runs) estimate their twin work in
`spectratac.studies.cost_model` with the same `Estimate` and `TrainingCost`.

>>> e = Estimate({"record": 40.0, "train": 80.0}, {"s/row-epoch": 2e-5}, 1.5)
>>> e.total_s, e.as_dict()["parts_s"]["train"]
(120.0, 80.0)
>>> e.with_part("oracle", 5.0, {"oracle s/row": 0.01}, 0.5).as_dict()["total_s"]
125.0
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from spectratac.dataset.schema import Dataset

T = TypeVar("T")

#: Timed calls per training probe; their median is kept (TrainingCost.measure).
PROBE_REPEATS = 3
#: Rows of the training probe at least (TrainingCost.measure).
PROBE_ROWS = 4096
#: Bytes of a recording that `build_estimate` builds as its probe (about 25 s of a session
#: with F/T; tens of milliseconds of building): a fifth of the smallest recording that gets
#: an estimate (`spectratac.cli.dataset_cmd.LONG_BUILD_BYTES`), a few percent of a long one.
BUILD_PROBE_BYTES = 1 << 20


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

    def with_part(
        self, name: str, seconds: float, rates: dict[str, float], calibration_s: float
    ) -> Estimate:
        """This estimate and one more part of the work, probed apart."""
        return Estimate(
            {**self.parts_s, name: seconds},
            {**self.rates, **rates},
            self.calibration_s + calibration_s,
        )

    def as_dict(self) -> dict[str, Any]:
        """The --json form."""
        return {
            # significant digits, not decimals: a build of a small file takes 0.04 s, not 0
            "total_s": float(f"{self.total_s:.3g}"),
            "parts_s": {k: float(f"{v:.3g}") for k, v in self.parts_s.items()},
            "rates": {k: float(f"{v:.4g}") for k, v in self.rates.items()},
            "calibration_s": float(f"{self.calibration_s:.3g}"),
        }


def timed(fn: Callable[..., T], *args: Any, **kwargs: Any) -> tuple[T, float]:
    """`fn(*args, **kwargs)` and the seconds it took."""
    t0 = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t0


def median_s(repeats: int, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> float:
    """The median of `repeats` timed calls: a stall in one of them does not count."""
    return float(np.median([timed(fn, *args, **kwargs)[1] for _ in range(max(repeats, 1))]))


# ------------------------------------------------------------------ train
@dataclass(frozen=True)
class TrainingCost:
    """Training time of one TrainSpec: fixed_s (planning, features, runtime), row_s per
    training row once per fit (assembling its inputs, the skip's least squares, the gain
    view), and row_epoch_s per training row and epoch."""

    fixed_s: float
    row_epoch_s: float
    row_s: float = 0.0

    def seconds(self, rows: int, epochs: int) -> float:
        return self.fixed_s + self.row_s * rows + self.row_epoch_s * rows * epochs

    @classmethod
    def measure(
        cls, dataset: Dataset, spec: Any, batches: int = 4, repeats: int = PROBE_REPEATS
    ) -> TrainingCost:
        """Train `spec` for one epoch on 64 rows (the fixed cost: planning, features, the
        runtime, an almost empty epoch), then for one and for two epochs on the first
        `batches` batches of rows (contiguous, so temporal context works as in the real
        run); each `repeats` times, keeping the median. The two epoch counts part the work
        done once per row of a fit from the work of each epoch: a one-epoch probe counted
        both as per-epoch work, which the run's 40 epochs then multiplied. The median: the
        per-row cost is multiplied by rows x epochs (~400k in the demo), so one scheduler
        stall of 0.1 s in a single 20-ms probe on a busy machine became an estimate of an
        hour and more for work of three minutes."""
        from spectratac.train import train

        # no validation split: 64 probe rows hold too few groups to hold one out, and an
        # epoch's validation pass is a small share of it
        one = dataclasses.replace(
            spec, epochs=1, val_fraction=0.0, best_val=False, uncertainty=False
        )
        two = dataclasses.replace(one, epochs=2)
        train(dataset, one, rows=np.arange(16), progress=False)  # torch's once-per-process set-up
        small = np.arange(min(64, dataset.n))
        # at least PROBE_ROWS: at batch 256 four batches were a few ms of work, and the
        # per-row cost of a best() fit came out four times what the fit then took
        rows = np.arange(
            min(max(batches * int(getattr(spec, "batch_size", 256)), PROBE_ROWS), dataset.n)
        )
        fixed = median_s(repeats, train, dataset, one, rows=small, progress=False)
        t1 = median_s(repeats, train, dataset, one, rows=rows, progress=False)
        t2 = median_s(repeats, train, dataset, two, rows=rows, progress=False)
        extra = max(rows.size - small.size, 1)
        per_epoch = max((t2 - t1) / rows.size, t1 / rows.size / 10)  # a noisy probe: never ~0
        # what the first epoch cost beyond an epoch's work: once per row of the fit
        per_row = max((t1 - fixed) / extra - per_epoch, 0.0)
        return cls(fixed, per_epoch, per_row)


@dataclass(frozen=True)
class PredictCost:
    """Time of one prediction pass of a decoder over a dataset: pass_s (assembling every
    row of the dataset, which temporal context and the drift baseline make the larger
    part) plus row_s per row predicted."""

    pass_s: float
    row_s: float

    def seconds(self, rows: Sequence[int]) -> float:
        return sum(self.pass_s + self.row_s * int(r) for r in rows)

    @classmethod
    def measure(
        cls, dataset: Dataset, spec: Any, rows: int = PROBE_ROWS, repeats: int = PROBE_REPEATS
    ) -> PredictCost:
        """A decoder of `spec` (the recipe's own architecture, features and context, trained
        for one epoch on 64 rows) predicts 64 rows and then `rows` rows of `dataset`, each
        `repeats` times, keeping the medians."""
        from spectratac.train import train

        one = dataclasses.replace(
            spec, epochs=1, val_fraction=0.0, best_val=False, uncertainty=False
        )
        dec = train(dataset, one, rows=np.arange(min(64, dataset.n)), progress=False)
        small, large = np.arange(min(64, dataset.n)), np.arange(min(rows, dataset.n))
        t_small = median_s(repeats, dec.predict, dataset, small)
        if large.size <= small.size:  # a pass's cost only
            return cls(t_small, 0.0)
        t_large = median_s(repeats, dec.predict, dataset, large)
        per_row = max((t_large - t_small) / max(large.size - small.size, 1), 0.0)
        return cls(max(t_small - per_row * small.size, 0.0), per_row)


def training_estimate(
    dataset: Dataset,
    spec: Any,
    fits: int = 1,
    check_rows: Sequence[int] = (),
    predictions: Sequence[int] = (),
    check_spec: Any = None,
) -> Estimate:
    """`spectratac train`: `fits` trainings of `spec` on every row of `dataset`, the held-out
    check's models on `check_rows` rows each (train/check.py `check_plan`) with their own
    recipe `check_spec` (`check_recipe`: a smaller batch, so more steps per row, probed
    apart; None: `spec`), and the prediction passes of the check and the summary on
    `predictions` rows each (`check_predictions`), probed on the dataset's own first rows."""
    t0 = time.perf_counter()
    cost = TrainingCost.measure(dataset, spec)
    parts = {"train": fits * cost.seconds(dataset.n, spec.epochs)}
    rates = {"s/row-epoch": cost.row_epoch_s, "s/row per fit": cost.row_s, "fixed s": cost.fixed_s}
    if check_rows:
        checking = cost
        if check_spec is not None and check_spec != spec:
            checking = TrainingCost.measure(dataset, check_spec)
            rates["check s/row-epoch"] = checking.row_epoch_s
        parts["held-out and forward check"] = sum(
            checking.seconds(int(r), spec.epochs) for r in check_rows
        )
    if predictions:
        scoring = PredictCost.measure(dataset, spec)
        parts["scoring (check and summary)"] = scoring.seconds(predictions)
        rates.update({"s/pass": scoring.pass_s, "predict s/row": scoring.row_s})
    return Estimate(parts, rates, time.perf_counter() - t0)


def auto_estimate(budget_s: float, dataset: Dataset, workers: int | None = None) -> Estimate:
    """`spectratac train --recipe auto`: the work its search will launch within the budget
    (`planned_work`: the trials that fit and the final refit, in nominal seconds per worker,
    train/auto_recipe/budget.py), each family's (networks, ridge) at this machine's rate
    for it now, plus the fixed cost of each of its fits and prediction passes, shared among
    the workers. Probes train a small network and a ridge on the dataset's first rows
    (`machine_factors`)."""
    from spectratac import threads
    from spectratac.train.auto_recipe.search import planned_work

    t0 = time.perf_counter()
    n_workers = max(1, workers or threads.usable_cpus())
    plan = planned_work(dataset, budget_s, workers=n_workers)
    factors, fixed = machine_factors(dataset, workers)
    parts = {
        "search, forward folds and final refit (planned work at this machine's rate)":
        sum(w * factors[fam] for fam, w in plan["work_by_family"].items()),
        "fixed cost of each fit and prediction pass":
        (plan["fits"] * fixed.fit_s + plan["passes"] * fixed.pass_s
         + (plan["fits_drift"] + plan["passes_drift"]) * fixed.drift_pass_s) / n_workers,
    }  # fmt: skip
    rates = {"wall / nominal (networks)": factors["network"],
             "wall / nominal (ridge)": factors["classical"], "fixed s/fit": fixed.fit_s,
             "s/pass": fixed.pass_s, "s/pass with drift baseline": fixed.drift_pass_s}  # fmt: skip
    if n_workers > 1:  # spawned side by side, each importing torch and the trainer
        parts["starting the worker processes"] = rates["s/worker start"] = worker_start_s()
    return Estimate(parts, rates, time.perf_counter() - t0)


def worker_start_s() -> float:
    """Seconds a new Python process takes to import what a search worker imports (torch
    and the trainer), as the search's spawned workers do before their first trial."""
    import subprocess
    import sys

    code = "import torch, spectratac.train.auto_recipe.trial"
    _, seconds = timed(subprocess.run, [sys.executable, "-c", code], check=False,
                       capture_output=True, timeout=300)  # fmt: skip
    return seconds


@dataclass(frozen=True)
class FixedCosts:
    """Seconds of a fit's fixed part (planning, features, runtime, assembly) and of one
    prediction pass over the dataset, for a small network."""

    fit_s: float
    pass_s: float
    # a pass of a network with the drift baseline and temporal context (the search's
    # "+drift" and "+context" candidates): its assembly, also part of each such fit
    drift_pass_s: float = 0.0


def machine_factors(
    dataset: Dataset, workers: int | None = None
) -> tuple[dict[str, float], FixedCosts]:
    """Wall seconds per nominal second of work now, per family: for networks, a small
    network's cost per row and epoch probed on the dataset's first rows
    (`TrainingCost.measure`: the fixed cost of a fit taken out), for ridge a quadratic
    ridge fitted on those rows and on half of them (the difference: the fixed cost taken
    out), each over the nominal rate the budget counts with (the nominal ridge work is
    a machine's, not a dataset's: on four channels it bought a fortieth of its seconds);
    beside them, the network's fixed costs of a fit and of a prediction pass
    (`PredictCost`)."""
    from spectratac.decode.networks import flops
    from spectratac.train import TrainSpec
    from spectratac.train.auto_recipe.budget import NOMINAL_S_PER_WORK
    from spectratac.train.plan import default_features, default_targets, plan

    spec = TrainSpec(
        features=default_features(dataset), targets=default_targets(dataset), model="mlp",
        hidden=64, blocks=2, val_fraction=0.0, best_val=False, threads=1,
    )  # fmt: skip
    p = plan(dataset, spec)
    per_row = 3 * flops(spec.arch, p.features.n_features, p.heads.n_out)
    cost = TrainingCost.measure(dataset, spec)
    passes = PredictCost.measure(dataset, spec)
    ctx = dataclasses.replace(spec, context=8, context_ema=(10.0, 40.0, 160.0), drift="baseline")
    drift = PredictCost.measure(dataset, ctx, rows=64)
    factor = float(np.clip(cost.row_epoch_s / (per_row * NOMINAL_S_PER_WORK["network"]), 0.2, 50))
    # a fit's once-per-row work (its rows' inputs assembled) on at most the dataset's rows
    fit_s = cost.fixed_s + cost.row_s * dataset.n
    fixed = FixedCosts(fit_s, passes.pass_s, drift.pass_s)
    return {"network": factor, "classical": ridge_factor(dataset, spec, factor)}, fixed


def ridge_factor(dataset: Dataset, like: Any, fallback: float) -> float:
    """Wall seconds per nominal second of ridge work now (`machine_factors`); `fallback`
    when the dataset's first rows are too few to fit a ridge on."""
    from spectratac.errors import SpectraTacError
    from spectratac.train import TrainSpec, train
    from spectratac.train.auto_recipe.budget import NOMINAL_S_PER_WORK, work
    from spectratac.train.plan import plan

    full = np.arange(min(PROBE_ROWS, dataset.n))
    half = full[: full.size // 2]
    try:  # ridge decodes the regression targets only (the search's ridge candidates too)
        regression = tuple(t for t in like.targets if t in dataset.target_names)
        ridge = TrainSpec(features=like.features, targets=regression, model="ridge", degree=2)
        n_features = plan(dataset, ridge).features.n_features
        t_full = median_s(PROBE_REPEATS, train, dataset, ridge, rows=full, progress=False)
        t_half = median_s(PROBE_REPEATS, train, dataset, ridge, rows=half, progress=False)
    except SpectraTacError:
        return fallback
    units = work("classical", full.size, n_features, 1, 0) - work(
        "classical", half.size, n_features, 1, 0
    )
    # the fixed part (planning, features) is counted with each fit's fixed cost; a noisy
    # probe that finds no per-row cost leaves the ridge work at the floor
    seconds = max(t_full - t_half, 0.0)
    return float(np.clip(seconds / (units * NOMINAL_S_PER_WORK["classical"]), 0.005, 50))


# ------------------------------------------------------------------ evaluate
def predict_rate(decoder: Any, dataset: Dataset, rows: int = 2000) -> float:
    """Seconds per row of `decoder.predict` on the first `rows` rows of `dataset`."""
    sel = np.arange(min(rows, dataset.n))
    _, seconds = timed(decoder.predict, dataset, rows=sel)
    return seconds / max(sel.size, 1)


def evaluation_estimate(decoder: Any, dataset: Dataset, models: int) -> Estimate:
    """`spectratac evaluate`: `models` decoders predict every row, at the rate of the
    user's model on the user's dataset. (On simulated data the twin's oracle decodes rows
    too: `spectratac.studies.cost_model.with_oracle` adds that part.)"""
    t0 = time.perf_counter()
    per_row = predict_rate(decoder, dataset)
    return Estimate(
        {"predict": models * per_row * dataset.n},
        {"predict s/row": per_row},
        time.perf_counter() - t0,
    )


# ------------------------------------------------------------------ dataset build
@dataclass(frozen=True)
class BuildCost:
    """Build time of recordings: fixed_s per recording (reading its session, fitting its
    clocks) plus byte_s per byte of it."""

    fixed_s: float
    byte_s: float

    def seconds(self, sizes: Sequence[int]) -> float:
        return sum(self.fixed_s + self.byte_s * n for n in sizes)

    @classmethod
    def measure(
        cls,
        path: Path,
        probe_bytes: int = BUILD_PROBE_BYTES,
        options: Any = None,
        repeats: int = PROBE_REPEATS,
    ) -> BuildCost:
        """Build the first `probe_bytes` of the recording `path` (whole chunks of it, read
        back as the truncated prefix they are) and its first half as much, `repeats` times
        each, keeping the medians: the two sizes part the fixed cost from the per-byte cost,
        and the median leaves out a stall of a busy machine, which the file's size would
        multiply. Raises what the build raises when a prefix holds too
        little to build."""
        from spectratac.dataset.build import build_datasets

        def build(part: Path) -> None:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a prefix is a truncated recording by design
                build_datasets([part], options=options)

        with open(path, "rb") as f:
            head = f.read(probe_bytes)
        with tempfile.TemporaryDirectory() as folder:
            small, large = Path(folder) / f"half-{path.name}", Path(folder) / path.name
            small.write_bytes(head[: len(head) // 2])
            large.write_bytes(head)
            # the median also leaves out the first call's costs (imports, caches)
            t_small = median_s(repeats, build, small)
            t_large = median_s(repeats, build, large)
        per_byte = (t_large - t_small) / max(len(head) - len(head) // 2, 1)
        per_byte = max(per_byte, t_large / max(len(head), 1) / 10)  # a noisy probe: never ~0
        return cls(max(t_large - per_byte * len(head), 0.0), per_byte)


def build_estimate(paths: Sequence[Path], options: Any = None) -> Estimate:
    """`spectratac dataset build`: every recording at the build cost of the largest one's
    first chunks (`BuildCost.measure`, with the build's options, e.g. an external F/T). A
    probe too short to build (no clock fit yet) is retried once on four times the bytes;
    SpectraTacError if that fails too."""
    from spectratac.errors import SpectraTacError

    t0 = time.perf_counter()
    sizes = {p: p.stat().st_size for p in paths if p.exists()}
    largest = max(sizes, key=lambda p: sizes[p])
    try:
        cost = BuildCost.measure(largest, BUILD_PROBE_BYTES, options)
    except SpectraTacError:
        cost = BuildCost.measure(largest, 4 * BUILD_PROBE_BYTES, options)
    return Estimate(
        {"build": cost.seconds(list(sizes.values()))},
        {"s/MB": cost.byte_s * 1e6, "fixed s": cost.fixed_s},
        time.perf_counter() - t0,
    )


# ------------------------------------------------------------------ record
def recording_estimate(duration_s: float | None, clock_scale: float | None) -> Estimate | None:
    """`spectratac record --duration S`: S seconds of the sensor's clock take S / scale wall
    seconds (the link's own pace: 1 for hardware, speed for a paced simulation); None when
    the length is not known up front (a count, a guided protocol, Ctrl-C, speed=max)."""
    if duration_s is None or not clock_scale:
        return None
    return Estimate({"record": duration_s / clock_scale}, {"sensor s per s": clock_scale}, 0.0)
