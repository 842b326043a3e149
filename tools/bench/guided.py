"""A new unit without a reference F/T: Snake on units 1-6 with the newcomer's `make demo`
model adapted from a guided minute of each unit, beside the model as it is (issue 35).

    python -m tools.bench.guided [--json] [--units 1,2,3,4,5,6] [--model PATH]

Per unit S, what a user runs: `record "sim://?scene=guided&seed=S&speed=max" --guided 9`
(no --ft; the simulated person presses what is prompted), `dataset build`, `train
--finetune MODEL` (region head, guard, rest signature, the rest's force offset:
`spectratac.train.unlabelled`), then Snake on `sim://?scene=presses&seed=S&speed=max`, the
nine scripted presses, decoded live by the adapted model and by the model as it is. A press
is right when it gave exactly one command, of its region (centre included: it fires a
neutral command); a press that fired twice is counted apart. Beside it: the Fz error during
contact against the scene's truth (normal force averaged over each sample's window), on the
same streams. Figures: right presses out of those played (target >= 50 of 54), for the
adapted model and the base; the adapted model's Fz error as a ratio to the base's.

Without --model: demo-output/best.stac (`make demo`) if it exists, else a small decoder of
unit 0 trained here in seconds (the apps' tests' recipe), whose figures are lower.
"""

from __future__ import annotations

import io
import tempfile
from pathlib import Path

import numpy as np
from spectratac.apps.sensor_setup import SampleTap, sensor_settings
from spectratac.apps.snake.control import CommandDetector
from spectratac.dataset.build import build_datasets
from spectratac.decode import Decoder
from spectratac.device import Sensor
from spectratac.device.ground_truth import ground_truth_of
from spectratac.device.transport import open_transport
from spectratac.record import GuidedProtocol, RecordOptions, record_url
from spectratac.sim.named_scenes import make_scene
from spectratac.train.unlabelled import EPOCHS, adapt_without_targets
from spectratac.twin.scripted_presses import press_regions

from tools.bench.benchlib import Figure, parser, report

DEMO = Path("demo-output/best.stac")
GUIDED = "sim://?scene=guided&seed={seed}&speed=max"
PRESSES = "sim://?scene=presses&seed={seed}&speed=max"


def small_model(folder: Path) -> Path:
    """Unit 0's decoder of the apps' tests (tests/apps/conftest.py), trained here."""
    from spectratac.hardware.generated import vocabulary as vocab
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.train import TrainSpec, train
    from spectratac.twin import generate_session
    from spectratac.twin.scripted_presses import scripted_presses

    rng = np.random.default_rng(5)
    regions = list(vocab.REGIONS) * 6
    rng.shuffle(regions)
    scene = scripted_presses(regions, np.tile([0.6, 1.5, 3.0, 2.0, 4.0, 1.0], 9))
    ds = from_twin_session(generate_session(scene, seed=0), scene)
    spec = TrainSpec.paper(targets=("Fx", "Fy", "Fz", "region", "contact"), epochs=60,
                           hidden=64, blocks=2, threads=1, context=2, drift="baseline")  # fmt: skip
    return train(ds, spec, progress=False).save(folder / "small.stac")


def adapted(base: Decoder, seed: int, folder: Path, epochs: int) -> Decoder:
    """`base` adapted from a guided session of unit `seed` recorded without an F/T."""
    leds = np.asarray(base.config["leds"]).tolist() if base.config.get("leds") else None
    path = folder / f"guided{seed}.mcap"
    record_url(GUIDED.format(seed=seed), path, RecordOptions(leds=leds),
               guided=GuidedProtocol(9, out=io.StringIO()))  # fmt: skip
    [ds] = build_datasets([path])
    dec, _ = adapt_without_targets(base, ds, epochs=epochs, progress=False)
    return dec


def play(decoder: Decoder, seed: int) -> dict[str, float]:
    """Snake's commands and the Fz error in contact on unit `seed`'s scripted presses."""
    scene = make_scene("presses", seed=str(seed))
    want = [int(r) for r in press_regions(scene)]
    per_press: list[list[int]] = [[] for _ in want]
    transport = open_transport(PRESSES.format(seed=seed), 921_600)
    truth = ground_truth_of(transport)
    assert truth is not None, "sim:// links carry ground truth"
    det, err = CommandDetector(), []
    with Sensor.attach(transport) as sensor:
        sensor.configure(**sensor_settings(decoder.config))
        tap = SampleTap(sensor)
        sensor.start()
        for est in decoder.stream(tap):
            sample = tap.last
            assert sample is not None
            t0, t1 = sample.t_start_us / 1e6, sample.device_time_us / 1e6
            c = truth.contact(np.linspace(t0, t1, 11))
            if c["in_contact"].all() and not est.invalid:
                err.append(abs(float(est.force[2]) + float(c["force_n"][:, 2].mean())))
            command = det.feed(est, t1)
            if command is not None:
                i = int(np.searchsorted(scene.presses.start, t1)) - 1
                per_press[max(i, 0)].append(command.region)
            if t1 >= scene.duration_s:
                break
        sensor.stop()
    return {
        "right": sum(c == [r] for c, r in zip(per_press, want, strict=True)),
        "twice": sum(len(c) > 1 for c in per_press),
        "presses": len(want),
        "fz_mae": float(np.mean(err)) if err else float("nan"),
    }


def main() -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--units", default="1,2,3,4,5,6", help="units (seeds) to adapt and play")
    p.add_argument("--model", type=Path, help="the base .stac (default: the demo's)")
    p.add_argument("--epochs", type=int, default=EPOCHS, help="epochs of the region head")
    args = p.parse_args()
    units = [int(u) for u in args.units.split(",")]
    with tempfile.TemporaryDirectory() as tmp:
        path = args.model or (DEMO if DEMO.is_file() else small_model(Path(tmp)))
        base = Decoder.load(path)
        base.unit_policy = "off"
        rows = {}
        for seed in units:
            rows[seed] = (play(base, seed), play(adapted(base, seed, Path(tmp), args.epochs), seed))
    played = sum(a["presses"] for _, a in rows.values())
    per_unit = {s: {"base": b["right"], "adapted": a["right"], "twice": a["twice"],
                    "fz_mae_base": round(b["fz_mae"], 4), "fz_mae_adapted": round(a["fz_mae"], 4)}
                for s, (b, a) in rows.items()}  # fmt: skip
    extra = {"model": str(path), "units": units, "per_unit": per_unit, "target": ">= 50 of 54"}
    figures = [
        Figure(
            f"Snake presses right, {which}",
            float(sum(r[k]["right"] for r in rows.values())),
            "presses",
            "presses played",
            float(played),
            sum(r[k]["right"] for r in rows.values()) / played,
            extra | {"fired_twice": sum(r[k]["twice"] for r in rows.values())},
        )
        for k, which in ((1, "adapted"), (0, "base"))
    ]
    base_mae = float(np.mean([b["fz_mae"] for b, _ in rows.values()]))
    mae = float(np.mean([a["fz_mae"] for _, a in rows.values()]))
    figures.append(Figure("Fz MAE in contact, adapted", mae, "N", "the base model's", base_mae,
                          mae / base_mae, {"units": units}))  # fmt: skip
    report(figures, args.json)


if __name__ == "__main__":
    main()
