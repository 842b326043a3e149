"""Benchmark: decoder runtime and training cost, each beside a reference measured in the same
run (this machine is shared: read the ratios, not the absolute times).

    python -m tools.bench.decoder_runtime [--json] [--samples 60000] [--epochs 30]

1. Single-sample latency (p50, p99) of the paper's decoder (ResMLP 128 x 3 on 33 features,
   six axes + nine regions) through the fused NumPy runtime, torch not imported, against one
   128 x 128 float32 matrix-vector product; calls of the two alternate in small batches so
   that load spikes hit both. Then the live path (assembly + network, what Decoder.stream
   does per sample) against the network alone. Optionally (--onnx) ONNX Runtime.
2. Training time of the paper's recipe on --samples twin calibration samples for --epochs,
   against plain GEMMs of the same shapes and total FLOPs (forward + backward ~ 3x forward):
   the ratio is the training loop's overhead over raw matrix arithmetic.
Targets: p99 <= 100 us; the paper recipe on 60,000 samples in <= 60 s. A p99
far above the p50 means the process was preempted (see load_average_1min in --json).
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np
from spectratac import threads
from spectratac.dataset import FT_NAMES, SPECTRATAC_INPUTS, Dataset
from spectratac.decode import Decoder

from tools.bench import benchlib

BATCH = 50  # calls per alternation


def latencies(fn, args: list, start: int, calls: int) -> np.ndarray:
    out = np.empty(calls)
    clock = time.perf_counter_ns
    n = len(args)
    for i in range(calls):
        a = args[(start + i) % n]
        t0 = clock()
        fn(a)
        out[i] = clock() - t0
    return out / 1000.0


def interleaved(subject, s_args: list, reference, r_args: list, calls: int):
    """Latencies (us) of subject and reference, alternating batches of BATCH calls."""
    s, r = [], []
    for k in range(max(1, calls // BATCH)):
        s.append(latencies(subject, s_args, k * BATCH, BATCH))
        r.append(latencies(reference, r_args, k * BATCH, BATCH))
    return np.concatenate(s), np.concatenate(r)


def paper_decoder(n: int = 500) -> tuple[Decoder, np.ndarray]:
    """The paper's architecture with random weights (latency does not depend on them)."""
    rng = np.random.default_rng(0)
    x = rng.uniform(8000, 28000, (n, 12))
    ds = Dataset.generic(x, np.zeros((n, 6)), SPECTRATAC_INPUTS, FT_NAMES)
    dec = Decoder.untrained(ds, "paper33", (*FT_NAMES, "region"), ("resmlp", 128, 3))
    return dec, x


def latency_figures(calls: int, onnx: bool) -> list[benchlib.Figure]:
    dec, x = paper_decoder()
    rows = [v.astype(np.float32) for v in x]
    run1 = dec.runtime.run1
    w = np.random.default_rng(1).random((128, 128)).astype(np.float32)
    v = np.random.default_rng(2).random(128).astype(np.float32)

    def matvec(_: np.ndarray) -> None:
        np.dot(v, w)

    for r in rows[:200]:
        run1(r)
    torch_loaded = "torch" in sys.modules
    s, r = interleaved(run1, rows, matvec, rows, calls)
    extra = {
        "torch_imported": torch_loaded,
        "load_average_1min": os.getloadavg()[0],
        "target_p99_us": 100,
        "params": dec.n_params,
        "flops": dec.flops_per_sample,
    }
    figs = percentile_figures(
        "paper decoder single sample {} (NumPy)", s, "128x128 matvec", r, extra
    )
    figs += live_figures(dec, x, calls, s)
    if onnx:
        figs += onnx_figures(dec, rows, calls, s)
    return figs


def live_figures(dec: Decoder, x: np.ndarray, calls: int, net_lat: np.ndarray) -> list:
    """What Decoder.stream does per sample: assembly, then the network (torch not imported)."""
    from spectratac.decode.assemble import Assembler

    push, run1 = Assembler(dec.layout).push, dec.runtime.run1

    def live(v: np.ndarray) -> None:
        run1(push(0, v)[0])

    rows = list(x)
    lv, _ = interleaved(live, rows, run1, [r.astype(np.float32) for r in rows], calls)
    name = "paper decoder live sample {} (assembly + network)"
    return percentile_figures(
        name, lv, "network alone", net_lat, {"torch_imported": "torch" in sys.modules}
    )


def onnx_figures(dec: Decoder, rows: list, calls: int, numpy_lat: np.ndarray) -> list:
    import tempfile

    import onnxruntime as ort

    with tempfile.TemporaryDirectory() as tmp:
        path = dec.export("onnx", Path(tmp) / "m.onnx")
        opts = ort.SessionOptions()
        opts.intra_op_num_threads = 1
        sess = ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"])
    feed = [{"u": r[None, :]} for r in rows]
    run = sess.run
    o, _ = interleaved(lambda f: run(None, f), feed, dec.runtime.run1, rows, calls)
    return percentile_figures(
        "paper decoder single sample {} (ONNX Runtime)", o, "NumPy runtime", numpy_lat, {}
    )


def percentile_figures(
    name: str, lat: np.ndarray, ref_name: str, ref: np.ndarray, extra: dict
) -> list[benchlib.Figure]:
    """p50 and p99 of `lat` (us) against the same percentile of `ref`; `name` has a {} for pNN."""
    return [
        benchlib.Figure(
            name.format(f"p{q}"),
            float(np.percentile(lat, q)),
            "us",
            f"{ref_name} p{q}",
            float(np.percentile(ref, q)),
            float(np.percentile(lat, q) / np.percentile(ref, q)),
            {"calls": int(lat.size), **extra},
        )
        for q in (50, 99)
    ]


def training_figure(samples: int, epochs: int) -> benchlib.Figure:
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.train import TrainSpec, train
    from spectratac.twin import builtin_scenes as scenes
    from spectratac.twin import generate_session

    scene = scenes.calibration_session(seed=0, duration_s=samples / 20.0)
    ds = from_twin_session(generate_session(scene, seed=0), scene)
    spec = TrainSpec.paper(epochs=epochs)
    t0 = time.perf_counter()
    dec = train(ds, spec, progress=False)
    train_s = time.perf_counter() - t0
    # plain GEMMs of the model's shapes, same total FLOPs (forward + backward = 3x forward),
    # on the threads training had: the spec's, else the thread policy's share (spec.threads 0)
    total = 3 * dec.flops_per_sample * ds.n * epochs
    n_threads = spec.threads or threads.current().threads
    gemm_s = benchlib.gemm_seconds(total, spec.batch_size, n_threads)
    return benchlib.Figure(
        f"paper recipe training, {ds.n} samples x {epochs} epochs",
        train_s,
        "s",
        "same FLOPs as 1024x128x128 GEMMs",
        gemm_s,
        train_s / gemm_s,
        {
            "samples": ds.n,
            "epochs": epochs,
            "target_s_scaled": 60.0 * ds.n * epochs / 1.8e6,
            "final_loss": dec.meta["history"][-1],
        },
    )


def main() -> None:
    p = benchlib.parser(__doc__.splitlines()[0])
    p.add_argument("--calls", type=int, default=20000, help="latency calls per subject")
    p.add_argument("--samples", type=int, default=60000)
    p.add_argument("--epochs", type=int, default=30)
    p.add_argument("--onnx", action="store_true", help="also time ONNX Runtime")
    p.add_argument("--no-train", action="store_true", help="latency figures only")
    args = p.parse_args()
    figs = latency_figures(args.calls, args.onnx)
    if not args.no_train:
        figs.append(training_figure(args.samples, args.epochs))
    benchlib.report(figs, args.json)


if __name__ == "__main__":
    main()
