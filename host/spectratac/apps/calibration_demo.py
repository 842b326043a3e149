"""The full job on the built-in simulated sensor, as a user would run it on hardware:

1. record a shortened, accelerated calibration session from the simulated optical sensor and
   a simulated Bota F/T sensor of the same scene (both over their real wire protocols);
2. build the aligned dataset from the recording;
3. train the paper's recipe and our best decoder, each under the random and the blocked split
   (the four fits side by side in worker processes that split the cores, started with step 1
   so that they have imported torch by step 3: spectratac.train.parallel);
4. evaluate them beside the paper's figures and a reference column (`DemoOptions.floor`:
   the command line passes the twin's inverse, spectratac.studies.oracle_floor: the twin's
   own forward model inverted sample by sample, which knows the unit but not the press
   history, so it is a reference the decoders beat, not a floor), with the Fig. 3 panels
   written to a folder. Each blocked-split gain of the best decoder over the recipe is
   shown with its spread over GAIN_BLOCKS consecutive blocks of the held-out rows (one
   blocked split of one session is a small sample), and so is the difference of their region
   accuracies (a handful of held-out presses: one near a region boundary moves it by
   points); the table says so when the best decoder's region accuracy is below the recipe's.

Every figure it prints is measured in this run. This process imports torch only if it
trains itself (one worker: a single CPU, or SPECTRATAC_THREADS set to every CPU). The demo
names the simulated devices by URL only: it never imports the twin or the simulator.
"""

from __future__ import annotations

import textwrap
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from spectratac.apps.durations import duration_text
from spectratac.evaluate.paper import paper_mae
from spectratac.evaluate.run import Floor
from spectratac.hardware.generated import vocabulary as vocab

Say = Callable[[str], None]
GAIN_BLOCKS = 5  # consecutive blocks of the blocked split's held-out rows, for the spread
#: Scene seconds per wall second while recording (600 s in 10 s), and the simulated F/T's
#: rate (5 samples per 50 ms window: its noise averages to under 0.01 N). A simulated
#: recording is a function of its URL whatever the pace (tests/record/test_reproducible.py)
#: as long as the host keeps up with the F/T stream; 6,000 F/T frames/s does beside two busy
#: loops on a loaded 2-core machine, 15,000 (30x at 500 Hz) did not.
DEMO_SPEED = 60.0
DEMO_FT_RATE = 100
#: The decoders the demo trains, each under the random and the blocked split (four fits,
#: run side by side: train/parallel.py), in the order they are evaluated.
DEMO_SPECS = ("paper", "best")


def best_spec(epochs: int, seed: int) -> Any:
    """Our best decoder at no more than the paper's inference cost (`TrainSpec.best`):
    temporal context for the elastomer's hysteresis and creep, drift compensation against a
    running no-contact baseline, and a smaller ResMLP."""
    from spectratac.train import TrainSpec

    return TrainSpec.best(epochs=epochs, seed=seed)


@dataclass
class DemoOptions:
    out: Path = Path("demo-output")
    # the folder the outputs are named by when `out` is a staging folder renamed onto it later
    named: Path | None = None
    scene_s: float = 600.0  # scene seconds of the calibration protocol
    speed: float = DEMO_SPEED  # scene seconds per wall second while recording
    seed: int = 0
    ft: str = "bota"
    ft_rate: int = DEMO_FT_RATE
    epochs: int = 40
    # scored beside the paper's recipe, e.g. studies' OracleFloor (the twin's inverse)
    floor: Floor | None = None
    progress: bool = True
    timings: dict[str, float] = field(default_factory=dict)
    # estimated seconds per stage ("record", "dataset", "train + evaluate"), said as each starts
    estimates: dict[str, float] = field(default_factory=dict)

    @property
    def final(self) -> Path:
        """Where the outputs end up (what messages and reports name)."""
        return self.out if self.named is None else self.named

    def about(self, stage: str) -> str:
        """' (estimated 40 s)' for a stage with an estimate, else ''."""
        seconds = self.estimates.get(stage)
        return "" if seconds is None else f" (estimated {duration_text(seconds)})"

    @property
    def url(self) -> str:
        return (
            f"sim://?scene=calibration&duration={self.scene_s:g}&seed={self.seed}"
            f"&speed={self.speed:g}&ft={self.ft}&ft_rate={self.ft_rate}"
        )


def run_demo(opts: DemoOptions, say: Say = print) -> dict[str, Any]:
    """Run the four stages into `opts.out`; return the JSON-ready summary."""
    from spectratac.train import KINDS
    from spectratac.train.parallel import FitPool

    opts.out.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    # the training workers start now and import torch while the session records
    with FitPool(len(DEMO_SPECS) * len(KINDS)) as pool:
        rec = _record(opts, say)
        opts.timings["record_s"] = time.monotonic() - t0
        t1 = time.monotonic()
        dataset = _build(opts, say)
        opts.timings["dataset_s"] = time.monotonic() - t1
        t2 = time.monotonic()
        results = _train_and_evaluate(opts, on_scene_clock(dataset, opts.scene_s), say, pool)
        opts.timings["train_evaluate_s"] = time.monotonic() - t2
    opts.timings["total_s"] = time.monotonic() - t0
    return {
        "url": opts.url,
        "recording": rec,
        "dataset": {"path": str(opts.final / "data.npz"), "samples": dataset.n},
        "results": results,
        "timings_s": {k: round(v, 1) for k, v in opts.timings.items()},
        "out": str(opts.final),
    }


def _record(opts: DemoOptions, say: Say) -> dict[str, Any]:
    from spectratac.record import RecordOptions, record_url

    path = opts.out / "session.mcap"
    say(
        f"[1/4] recording {opts.scene_s:g} s of the calibration protocol at {opts.speed:g}x"
        f"{opts.about('record')}: simulated sensor (real firmware core on the twin) + "
        f"simulated Bota F/T at {opts.ft_rate} Hz\n      {opts.url}"
    )
    bar = _bar(opts, total=opts.scene_s, unit="scene s", desc="recording")

    def progress(status: Any) -> None:
        scene_now = min(status.sensor_s, opts.scene_s)
        if bar is not None:
            bar.n = round(scene_now, 1)  # shown as a person reads it: 3.1, not 3.1000000000000005
            bar.set_postfix_str(
                f"{status.samples} samples, F/T {status.ft_rate_hz:.0f} Hz, "
                f"lost {status.lost}+{status.ft_lost}"
            )

    try:
        summary = record_url(opts.url, path, RecordOptions(), progress=progress)
    finally:
        if bar is not None:
            bar.close()
    s = summary.as_dict()
    say(
        f"      {s['samples']} samples ({s['lost']} lost), {s['ft_samples']} F/T samples "
        f"({s['ft_lost']} lost{_on_purpose(s['ft_simulated_loss'])}), {s['labels']} labels -> "
        f"{opts.final / path.name} ({s['file_bytes'] / 1e6:.1f} MB)"
    )
    s["path"] = str(opts.final / path.name)
    return {
        k: s[k]
        for k in (
            "path",
            "samples",
            "lost",
            "ft_samples",
            "ft_lost",
            "ft_simulated_loss",
            "labels",
            "stopped_by",
        )
    }


def _on_purpose(simulated_loss: float | None) -> str:
    """The simulated F/T drops samples on purpose (its ft_loss): say so beside the count."""
    return "" if simulated_loss is None else f" on purpose: simulated ft_loss={simulated_loss:g}"


def _build(opts: DemoOptions, say: Say) -> Any:
    from spectratac.dataset.build import build_datasets

    say(
        f"[2/4] building the dataset{opts.about('dataset')}: clocks aligned, F/T averaged "
        "over each integration window"
    )
    (dataset,) = build_datasets([opts.out / "session.mcap"])
    dataset.save(opts.out / "data.npz")
    valid = float(dataset.target_valid.mean()) * 100
    presses = dataset.press_count()  # the same count as `dataset info`
    say(f"      {dataset.n} samples, {valid:.1f} % with F/T targets, {presses} presses")
    return dataset


def on_scene_clock(dataset: Any, scene_s: float) -> Any:
    """The recorded dataset with its windows on the simulated sensor's own clock.

    A simulated device's clock is scene time, so its samples keep their true 50 ms spacing
    even though the session was recorded at `speed` times real time (host times are
    compressed by that factor). On this clock the twin oracle can replay the scene to give
    its floor beside the decoders; the session stays marked as recorded.
    """
    from spectratac.dataset import Dataset

    integration_s = dataset.meta["config"]["integration_ms"] / 1000.0
    t_end = dataset.device_time_us / 1e6
    arrays = dict(dataset.arrays, t_end=t_end, t_start=t_end - integration_s)
    sessions = [
        {**s, "source": "twin", "recorded_by": s.get("source"), "duration_s": scene_s}
        for s in dataset.meta["sessions"]
    ]
    return Dataset(arrays, {**dataset.meta, "sessions": sessions})


def _train_and_evaluate(
    opts: DemoOptions, dataset: Any, say: Say, pool: Any = None
) -> dict[str, Any]:
    from spectratac.evaluate import write_report
    from spectratac.evaluate.fit_both_splits import fit_and_evaluate_each, save_models
    from spectratac.train import KINDS, TrainSpec

    out: dict[str, Any] = {}
    models: dict[str, Any] = {}
    held: Any = None
    paper = TrainSpec.paper(epochs=opts.epochs, seed=opts.seed)
    specs = dict(zip(DEMO_SPECS, (paper, best_spec(opts.epochs, opts.seed)), strict=True))
    say(
        f"[3/4] training the paper's recipe and our best decoder, each under the random and the "
        f"blocked split, at once{opts.about('train + evaluate')}"
    )
    # the four fits run side by side (train/parallel.py); the paper's are evaluated and
    # written while the best decoder's still train
    bar = _bar(opts, total=len(specs) * len(KINDS) * opts.epochs, unit="epoch", desc="training")
    epochs: dict[int, int] = {}

    def tick(job: int, done: int) -> None:
        epochs[job] = done
        if bar is not None:
            bar.n = sum(epochs.values())
            bar.refresh()

    try:
        for name, res in fit_and_evaluate_each(
            dataset,
            specs,
            seed=opts.seed,
            floors={"paper": opts.floor},
            pool=pool,
            tick=tick,
        ):
            files = save_models(res, opts.out / f"{name}.stac")
            write_report(
                res.evaluation,
                opts.out / f"report-{name}",
                {"path": str(opts.final / "data.npz"), "samples": dataset.n},
                {
                    "path": ", ".join(
                        f"{opts.final / f.name} ({kind} split)" for kind, f in files.items()
                    )
                },
                dataset,
            )
            out[name] = {kind: _scores(section) for kind, section in res.sections.items()} | {
                "train_seconds": {k: round(v, 1) for k, v in res.train_seconds.items()}
            }
            models[name] = res.models["blocked"]
            held = res.splits["blocked"].test
    finally:
        if bar is not None:
            bar.close()
    out["gain_blocks"] = gain_blocks(dataset, held, models["paper"], models["best"])
    say("[4/4] results (MAE in N and N·m; held-out rows only)")
    for line in results_table(out):
        say("      " + line)
    say(f"      reports and Fig. 3 panels: {opts.final}/report-paper, {opts.final}/report-best")
    return out


def gain_blocks(
    dataset: Any, rows: Any, paper: Any, best: Any, blocks: int = GAIN_BLOCKS
) -> dict[str, dict[str, float]]:
    """Per force/torque axis: the best decoder's MAE gain over the recipe (%, 100 x (1 -
    best / recipe)) on each of `blocks` consecutive blocks of the held-out `rows` (rows with
    a valid target only), as {"mean", "sd", "n"}; under "region", the best decoder's region
    accuracy minus the recipe's (percentage points) on each block of the labelled rows."""
    import numpy as np

    from spectratac.evaluate.predictions import predict

    rows = np.sort(np.asarray(rows, np.int64))
    names = list(dataset.target_names)
    pp, pb = predict(paper, dataset, rows), predict(best, dataset, rows)
    out: dict[str, dict[str, float]] = {}
    for c in vocab.FT_AXES:
        if c not in names or c not in pp.target_names or c not in pb.target_names:
            continue
        col = names.index(c)
        y = np.asarray(dataset.targets)[rows, col]
        ok = np.asarray(dataset.target_valid, bool)[rows] & np.isfinite(y)
        ep = np.abs(pp.targets[:, list(pp.target_names).index(c)] - y)
        eb = np.abs(pb.targets[:, list(pb.target_names).index(c)] - y)
        gains = []
        for part in np.array_split(np.flatnonzero(ok), blocks):
            if part.size and ep[part].mean() > 0:
                gains.append(100.0 * (1.0 - eb[part].mean() / ep[part].mean()))
        out[c] = _spread(gains)
    labels = np.asarray(dataset.region)[rows]
    if pp.region is not None and pb.region is not None:
        diffs = [  # region accuracy of best minus the recipe's, in percentage points
            100.0
            * (np.mean(pb.region[part] == labels[part]) - np.mean(pp.region[part] == labels[part]))
            for part in np.array_split(np.flatnonzero(labels > 0), blocks)
            if part.size
        ]
        out["region"] = _spread(diffs)
    return out


def _spread(values: list[float]) -> dict[str, float]:
    """{"mean", "sd" (NaN for fewer than two), "n"} of per-block figures."""
    import numpy as np

    g = np.asarray(values, np.float64)
    sd = float(g.std(ddof=1)) if g.size > 1 else float("nan")
    return {"mean": float(g.mean()) if g.size else float("nan"), "sd": sd, "n": g.size}


def _scores(section: Any) -> dict[str, Any]:
    dec = section.decoder.scores if section.decoder is not None else {}
    ora = section.oracle.scores if section.oracle is not None else None
    return {
        "mae": {c: dec["components"][c]["mae"] for c in vocab.FT_AXES if c in dec["components"]},
        "r2": {c: dec["components"][c]["r2"] for c in vocab.FT_AXES if c in dec["components"]},
        "region_accuracy": (dec.get("region") or {}).get("accuracy"),
        "oracle_mae": (
            {c: ora["components"][c]["mae"] for c in vocab.FT_AXES if c in ora["components"]}
            if ora
            else None
        ),
        "oracle_note": section.oracle_note,
        "test_rows": len(section.rows),
    }


def results_table(results: dict[str, Any]) -> list[str]:
    """Paper's figure | paper recipe random / blocked | best random / blocked | gain ± its
    spread over blocks of the held-out rows | the twin's inverse (blocked); notes say what that
    column is, and when the best decoder's region accuracy is below the recipe's."""
    p, b = results["paper"], results["best"]
    spread = results.get("gain_blocks", {})
    head = (
        f"{'':8}{'paper':>9}{'recipe':>9}{'recipe':>9}{'best':>9}{'best':>9}{'gain':>11}{'twin':>9}"
    )
    sub = (
        f"{'':8}{'reported':>9}{'random':>9}{'blocked':>9}{'random':>9}{'blocked':>9}"
        f"{'blocked':>11}{'inverse':>9}"
    )
    lines = [head, sub]
    oracle = p["blocked"]["oracle_mae"] or {}
    for c in vocab.FT_AXES:
        pb, bb = p["blocked"]["mae"][c], b["blocked"]["mae"][c]
        gain = f"{100 * (1 - bb / pb):+.0f}%" if pb > 0 else "–"
        sd = spread.get(c, {}).get("sd", float("nan"))
        if sd == sd:  # not NaN
            gain = f"{gain[:-1]}±{sd:.0f}%"
        ora = f"{oracle[c]:.3g}" if c in oracle else "–"
        lines.append(
            f"{c:8}{paper_mae(c).replace('<= ', '≤'):>9}{p['random']['mae'][c]:>9.3g}"
            f"{pb:>9.3g}{b['random']['mae'][c]:>9.3g}{bb:>9.3g}{gain:>11}{ora:>9}"
        )

    def acc(r: dict[str, Any]) -> str:
        a = r["region_accuracy"]
        return "–" if a is None else f"{100 * a:.1f}%"

    region_gain = ""
    if "region" in spread and spread["region"]["n"]:
        r = spread["region"]
        region_gain = f"{r['mean']:+.0f}±{r['sd']:.0f}pt" if r["sd"] == r["sd"] else ""
    lines.append(
        f"{'region':8}{'99.9%':>9}{acc(p['random']):>9}{acc(p['blocked']):>9}"
        f"{acc(b['random']):>9}{acc(b['blocked']):>9}{region_gain:>11}"
    )
    if spread:
        n = max(v["n"] for v in spread.values())
        lines.append(f"gain ± sd over {n} consecutive blocks of the blocked split's held-out rows")
        if region_gain:
            lines.append("region: best's accuracy minus the recipe's, in percentage points")
    ra, rb = p["blocked"]["region_accuracy"], b["blocked"]["region_accuracy"]
    if ra is not None and rb is not None and rb < ra:
        lines.append(
            f"note: best's blocked region accuracy ({acc(b['blocked'])}) is below the recipe's "
            f"({acc(p['blocked'])}): best is chosen for force error (Fz weighted 2, context "
            f"and rotation/mirror augmentation); for region decisions use paper.stac"
        )
    if oracle:
        lines += textwrap.wrap(TWIN_INVERSE_NOTE, 80)
    return lines


#: What the demo's last column is (and is not): spectratac.studies.oracle_floor.
TWIN_INVERSE_NOTE = (
    "twin inverse: the twin's own forward model inverted sample by sample with the true unit, "
    "LEDs and environment but no press history (creep, hysteresis): a physics reference, not "
    "a floor; decoders with temporal context beat it"
)


def _bar(opts: DemoOptions, total: float, unit: str, desc: str) -> Any:
    if not opts.progress:
        return None
    from spectratac.progress import bar

    return bar(total=total, unit=unit, desc="      " + desc, leave=False)
