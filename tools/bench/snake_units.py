"""Snake over simulated units: one press, exactly one correct command, on ten units the model
never saw (issue 22 item 3).

    python tools/bench/snake_units.py [--json] [--seeds 0-9] [--model PATH]

Each unit plays `sim://?scene=presses&speed=max&seed=N` (nine scripted presses of 2.5 N on
up, right, down, left, centre, up, left, down, right); its estimates go, as in
`spectratac snake`, through `Decoder.stream` into the `CommandDetector`. A press counts as
right when exactly one command is decided during it and its region is the pressed one (the
centre's command is neutral: decided, no direction); a press with two commands is a double.
The figure is the share of right presses over all units, beside the target 0.95; per-unit
figures are in `extra`. The reference in the same run is the same model and streams through
the detector as it was before issue 22 (re-armed by an out-of-distribution flicker, region
decided on the rise), so the effect of the detector is seen apart from the model's.

Without --model, a population model is trained here (a few minutes): `TrainSpec.best()` at
a small size (ResMLP 64 x 1, 15 epochs; its context, drift baseline, rotated and mirrored
presses and +-15 % gain jitter, to which its out-of-distribution guard is widened), on
`twin population` data of units 10-19 (one 2-minute calibration session each, with its
re-mounting and ageing), so no test unit is seen;
--save-model PATH keeps it for another run (--model PATH). With --finetune-minutes M each
unit first gets its own fine-tune (`train --finetune`) of the model on M minutes of that
unit's calibration (a twin session of the unit, not the scene played).
"""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from benchlib import Figure, parser, report
from spectratac.apps.sensor_setup import SampleTap, open_for_decoder
from spectratac.apps.snake.control import CommandDetector
from spectratac.decode import Decoder
from spectratac.sim.named_scenes import make_scene
from spectratac.twin.scripted_presses import press_regions

URL = "sim://?scene=presses&speed=max&seed={seed}"
TRAIN_UNITS = tuple(range(10, 20))


def tuned(decoder: Decoder, seed: int, minutes: float) -> Decoder:
    """`decoder` fine-tuned on `minutes` of unit `seed`'s calibration (itself when 0)."""
    if not minutes:
        return decoder
    from spectratac.sim.twin_dataset import population
    from spectratac.train import finetune

    own = population([seed], sessions_per_unit=1, session_s=60.0 * minutes, seed=1)
    out = finetune(decoder, own, progress=False)
    out.unit_policy = "off"
    return out


def population_model(folder: Path) -> Path:
    from spectratac.sim.twin_dataset import population
    from spectratac.train import TrainSpec, train

    ds = population(list(TRAIN_UNITS), sessions_per_unit=1, session_s=120.0)
    spec = TrainSpec.best(targets=("Fx", "Fy", "Fz", "region", "contact"), epochs=15,
                          hidden=64, blocks=1, threads=2)  # fmt: skip
    return train(ds, spec, progress=False).save(folder / "population.stac")


class OldDetector(CommandDetector):
    """The detector before issue 22: an unusable estimate counts as a release, and the
    region is decided by the first `confirm` equal reads above the threshold."""

    def reset(self) -> None:
        super().reset()
        self._candidate, self._streak = -1, 0

    def feed(self, estimate: Any, t: float) -> Any:
        from spectratac.apps.snake.control import Command

        usable = not estimate.invalid and (self.accept_ood or not estimate.ood)
        normal = self.normal_force(estimate) if usable else math.nan
        if not self.pressed:
            if normal > self.threshold_n:
                self.pressed, self.decided, self._streak, self._below = True, False, 0, 0
            else:
                return None
        if not normal >= self.release_n:
            self._below += 1
            self._streak = 0
            if self._below >= self.rearm:
                self.pressed = False
            return None
        self._below = 0
        if self.decided or normal <= self.threshold_n:
            return None
        region = int(estimate.region)
        self._streak = self._streak + 1 if region == self._candidate else 1
        self._candidate = region
        if self._streak < self.confirm or region < 1:
            return None
        self.decided = True
        return Command(self.mapping.direction(region), region, float(t), normal)


def play_unit(decoder: Decoder, seed: int) -> dict[str, dict[str, int]]:
    """Presses right / doubled / missed on unit `seed`, for the new and the old detector."""
    detectors = {"new": CommandDetector(), "old": OldDetector()}
    got: dict[str, list[tuple[float, int]]] = {k: [] for k in detectors}
    scene = make_scene("presses", seed=str(seed))  # what the URL plays
    end = scene.duration_s
    with open_for_decoder(decoder, URL.format(seed=seed)) as sensor:
        tap = SampleTap(sensor)
        for est in decoder.stream(tap):
            assert tap.last is not None
            t = tap.last.device_time_us / 1e6
            for k, det in detectors.items():
                c = det.feed(est, t)
                if c is not None:
                    got[k].append((t, c.region))
            if t >= end:
                break
    want = press_regions(scene)
    out = {}
    for k, commands in got.items():
        per_press: list[list[int]] = [[] for _ in want]
        stray = 0
        for t, region in commands:
            i = int(scene.press_index(np.array([t]))[0])
            if i < 0:
                stray += 1
            else:
                per_press[i].append(region)
        right = sum(1 for regs, w in zip(per_press, want, strict=True) if regs == [int(w)])
        doubled = sum(1 for regs in per_press if len(regs) > 1)
        out[k] = {"presses": len(want), "right": right, "doubled": doubled, "stray": stray}
    return out


def main() -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--seeds", default="0-9", help="unit seeds, e.g. 0-9 or 0,3,5")
    p.add_argument("--model", type=Path, help="a .stac (default: train a population model)")
    p.add_argument("--save-model", type=Path, help="where to keep the trained population model")
    p.add_argument("--finetune-minutes", type=float, default=0.0, help="fine-tune per unit")
    args = p.parse_args()
    lo, _, hi = args.seeds.partition("-")
    seeds = list(range(int(lo), int(hi) + 1)) if hi else [int(s) for s in lo.split(",")]
    with tempfile.TemporaryDirectory() as tmp:
        path = args.model or population_model(Path(tmp))
        decoder = Decoder.load(path)
        if args.save_model is not None and args.model is None:
            decoder.save(args.save_model)
    decoder.unit_policy = "off"  # another unit on purpose: that is what is measured
    per_unit = {
        seed: play_unit(tuned(decoder, seed, args.finetune_minutes), seed) for seed in seeds
    }
    tot = {k: {m: sum(u[k][m] for u in per_unit.values()) for m in ("presses", "right",
                                                                     "doubled", "stray")}
           for k in ("new", "old")}  # fmt: skip
    share = {k: tot[k]["right"] / tot[k]["presses"] for k in tot}
    fig = Figure(
        "presses with exactly one correct command",
        100.0 * share["new"],
        "%",
        "the detector before issue 22",
        100.0 * share["old"],
        share["new"] / max(share["old"], 1e-9),
        {
            "target_pct": 95.0,
            "doubled": tot["new"]["doubled"],
            "stray": tot["new"]["stray"],
            "old_doubled": tot["old"]["doubled"],
            "per_unit": {s: u["new"] for s, u in per_unit.items()},
            "per_unit_old": {s: u["old"] for s, u in per_unit.items()},
            "model": str(args.model or "population model, units 10-19"),
            "finetune_minutes": args.finetune_minutes,
        },
    )
    report([fig], args.json)
    if not args.json:
        for s, u in per_unit.items():
            n, o = u["new"], u["old"]
            print(f"  unit {s}: {n['right']}/{n['presses']} right, {n['doubled']} doubled, "
                  f"{n['stray']} stray (before: {o['right']}/{o['presses']}, {o['doubled']} "
                  f"doubled)")  # fmt: skip


if __name__ == "__main__":
    main()
