"""Joining under load: live Fz error during contact on the tour joined mid-press, beside the
same model on the same scene joined at rest (issue 22 item 1).

    python -m tools.bench.midpress [--json] [--seconds S] [--model PATH]

Three simulated sensors play the region tour at real time (speed=1) side by side, so that
load hits them alike: one joined at rest (start=0, the reference), one joined 226 ms into
the first press (start=0.282 s), and the same mid-press join decoded by the model with its
rest signature removed (the baseline as it was before it searched for rest: it learns its
zero on the pressed skin). Each is decoded live with `Decoder.stream`; the error is against
the scene's ground truth (-normal force averaged over each sample's integration window),
over samples in contact. Figures: the mid-press MAE as a ratio to the at-rest MAE (target
<= 1.15) and the old baseline's ratio; also how long the first estimates said `no_rest`.

Without --model: demo-output/best.stac if it exists, else a small decoder of Fx, Fy, Fz with
a drift baseline trained here on twin presses of seed 0's unit (the tour's unit).
"""

from __future__ import annotations

import tempfile
import threading
from dataclasses import replace
from pathlib import Path

import numpy as np
from spectratac.apps.sensor_setup import SampleTap, sensor_settings
from spectratac.decode import Decoder
from spectratac.device import Sensor
from spectratac.device.ground_truth import ground_truth_of
from spectratac.device.transport import open_transport

from tools.bench.benchlib import Figure, parser, report

TOUR = "sim://?scene=tour&seed=0&speed=1&start={start}"
MID_PRESS_S = 0.056 + 0.226  # the tour's first press starts at 0.056 s; 226 ms into it
DEMO = Path("demo-output/best.stac")


def small_model(folder: Path) -> Path:
    from spectratac.hardware.generated import vocabulary as vocab
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.train import TrainSpec, train
    from spectratac.twin import generate_session
    from spectratac.twin.scripted_presses import scripted_presses

    rng = np.random.default_rng(5)
    regions = list(vocab.REGIONS) * 5
    rng.shuffle(regions)
    scene = scripted_presses(regions, np.tile([1.0, 2.5, 4.0, 5.0, 3.0], 9))
    ds = from_twin_session(generate_session(scene, seed=0), scene)
    spec = TrainSpec.paper(targets=("Fx", "Fy", "Fz"), epochs=40, hidden=48, blocks=1,
                           threads=1, context=2, drift="baseline")  # fmt: skip
    return train(ds, spec, progress=False).save(folder / "midpress.stac")


def run_one(decoder: Decoder, start: float, seconds: float, out: dict) -> None:
    """Decode the tour joined at `start` for `seconds` of device time; results into `out`."""
    transport = open_transport(TOUR.format(start=start), 921_600)
    truth = ground_truth_of(transport)
    assert truth is not None, "sim:// links carry ground truth"
    err: list[float] = []
    no_rest_s, first = 0.0, None
    with Sensor.attach(transport) as sensor:
        sensor.configure(**sensor_settings(decoder.config))
        tap = SampleTap(sensor)
        sensor.start()
        for est in decoder.stream(tap):
            sample = tap.last
            assert sample is not None
            t0, t1 = sample.t_start_us / 1e6, sample.device_time_us / 1e6
            first = t1 if first is None else first
            if est.no_rest:
                no_rest_s = t1 - first
            c = truth.contact(np.linspace(t0, t1, 11))
            if c["in_contact"].all() and not est.invalid:
                err.append(abs(float(est.force[2]) + float(c["force_n"][:, 2].mean())))
            if t1 - first >= seconds:
                break
        sensor.stop()
    out.update(mae=float(np.mean(err)), n=len(err), no_rest_s=no_rest_s)


def main() -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=30.0, help="device seconds per join")
    p.add_argument("--model", type=Path, help="a .stac with a drift baseline")
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = args.model or (DEMO if DEMO.is_file() else small_model(Path(tmp)))
        model = Decoder.load(path)
    if not model.layout.drift:
        raise SystemExit(f"{path}: no drift baseline, nothing to measure (train --drift baseline)")
    old = replace(model, layout=replace(model.layout, rest=(), press=()))
    runs = {"at rest": (model, 0.0), "mid-press": (model, MID_PRESS_S),
            "mid-press, old baseline": (old, MID_PRESS_S)}  # fmt: skip
    results: dict[str, dict] = {k: {} for k in runs}
    threads = [
        threading.Thread(target=run_one, args=(dec, start, args.seconds, results[k]))
        for k, (dec, start) in runs.items()
    ]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    ref = results["at rest"]
    figures = [
        Figure(
            f"Fz MAE in contact, {k}",
            r["mae"],
            "N",
            "joined at rest",
            ref["mae"],
            r["mae"] / ref["mae"],
            {
                "contact_samples": r["n"],
                "no_rest_s": round(r["no_rest_s"], 3),
                "model": str(path),
                "seconds": args.seconds,
                "target_ratio": 1.15,
            },
        )
        for k, r in results.items()
        if k != "at rest"
    ]
    report(figures, args.json)


if __name__ == "__main__":
    main()
