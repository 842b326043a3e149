"""The twin's oracle as a reference column for simulated datasets (the API keeps the name
"floor", the slot `spectratac.evaluate` gives it; it is not a lower bound).

For a dataset generated from the twin, the oracle (`spectratac.twin.oracle`) knows the unit,
the settings, the LEDs and the environment, and inverts the forward model per sample. It
does not know the press history (the elastomer's creep and hysteresis), so a learned decoder
with temporal context beats it: its error is a physics reference, not a floor. It needs the
scene, which the dataset's metadata names (scene, seed; calibration scenes also their
duration). The scene is rebuilt from that and *checked* against the dataset (its contact
state must agree with the recorded one), so a wrong guess never silently produces a
reference. The oracle is slow per sample, so it
runs on a deterministic subsample of the test rows, and the report says so.

>>> from spectratac.twin import generate_session, builtin_scenes as scenes
>>> from spectratac.sim.twin_dataset import from_twin_session
>>> sc = scenes.single_press(6, 6.0, (1.5, 0.0), hold_s=1.0)
>>> ds = from_twin_session(generate_session(sc, seed=3), sc)
>>> o = twin_oracle(ds, scene=sc)
>>> r = o.decode(ds, np.array([int(np.argmax(-ds.targets[:, 2]))]))
>>> bool(abs(r.targets[0, 2] + 6.0) < 1.0), int(r.region[0])
(True, 6)
>>> twin_oracle(ds).reason[:40]
'session 0 comes from the twin but its sc'

`oracle_predictions` decodes a subsample of evaluation rows session by session and returns
them as `Predictions` for the report's floor column; a dataset without an oracle gets a note:

>>> from spectratac.dataset import Dataset
>>> plain = Dataset.generic(np.zeros((4, 1)), np.zeros(4), ["a"], ["Fz"])
>>> rows, pred, note = oracle_predictions(plain, np.arange(4))
>>> rows.size, pred, note[:22]
(0, None, 'no oracle: not a Spect')

`OracleFloor` is the same as the floor column `spectratac.evaluate` takes
(`evaluate_model(model, dataset, floor=OracleFloor(500))`):

>>> OracleFloor(4)(plain, np.arange(4), 0)[2] == note
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.dataset.schema import FT_NAMES, Dataset
from spectratac.evaluate.predictions import Predictions
from spectratac.twin.electronics import SensorConfig
from spectratac.twin.errors import TwinError
from spectratac.twin.oracle import Oracle
from spectratac.twin.scene_model import Scene
from spectratac.twin.unit import UnitParams

F64 = NDArray[np.float64]
#: Fraction of rows whose contact state must agree with the rebuilt scene.
AGREEMENT = 0.99
DEFAULT_SAMPLES = 500


@dataclass(frozen=True)
class OracleEstimates:
    targets: F64  # (n, 6) F/T in the dataset's target order (Fx Fy Fz Tx Ty Tz)
    region: NDArray[np.int8]


@dataclass
class TwinOracle:
    """The oracle of one session, or the reason why there is none (`oracle is None`)."""

    oracle: Oracle | None
    session: int = 0
    reason: str = ""
    scene_name: str = ""

    def decode(self, dataset: Dataset, rows: NDArray[np.int64]) -> OracleEstimates:
        if self.oracle is None:
            raise TwinError(f"no oracle for this dataset: {self.reason}")
        a = dataset.arrays
        if "counts" not in a:
            raise TwinError("the oracle needs raw counts (N, 3, 5); this dataset has none")
        tmid = 0.5 * (a["t_start"][rows] + a["t_end"][rows])
        r = self.oracle.decode(a["counts"][rows], tmid, a["step"][rows])
        return OracleEstimates(targets=r.ft, region=r.region)


def subsample(rows: NDArray[np.int64], k: int, seed: int = 0) -> NDArray[np.int64]:
    """At most `k` of `rows`, drawn without replacement, deterministic by seed, sorted."""
    if rows.size <= k:
        return np.sort(rows)
    rng = np.random.default_rng([int(seed), 0x0AC1])
    return np.sort(rng.choice(rows, k, replace=False))


def twin_oracle(dataset: Dataset, scene: Scene | None = None, session: int = 0) -> TwinOracle:
    """The oracle for rows of `session`, with `scene` given or rebuilt from the metadata."""
    meta = dataset.meta
    sessions = meta.get("sessions") or []
    if not 0 <= session < len(sessions):
        return TwinOracle(None, session, "the dataset names no sessions")
    info = sessions[session]
    cfg_d = meta.get("config")
    if meta.get("kind") != "spectratac" or not isinstance(cfg_d, dict):
        return TwinOracle(None, session, "not a SpectraTac dataset with one sensor configuration")
    seed = info.get("seed")
    if info.get("source") != "twin" or seed is None:
        return TwinOracle(
            None, session, f"session {session} is not simulated by the twin (real data)"
        )
    rows = np.flatnonzero(dataset.arrays["session"] == session)
    if rows.size < 2:
        return TwinOracle(None, session, f"session {session} has fewer than 2 rows")
    if scene is None:
        scene, why = _rebuild_scene(dataset, rows, info)
        if scene is None:
            return TwinOracle(
                None, session, f"session {session} comes from the twin but its scene {why}"
            )
    elif _agreement(dataset, rows, scene) < AGREEMENT:
        return TwinOracle(None, session, "the given scene does not match the dataset's contacts")
    try:
        cfg = SensorConfig(
            integration_ms=int(cfg_d["integration_ms"]),
            gain=float(cfg_d["gain"]),
            dg=int(cfg_d.get("digital_gain", 1)),
            sens_low=cfg_d.get("sensitivity") == "low",
        )
        steps = np.asarray(cfg_d["leds"], dtype=np.float64) / 1000.0
        unit = UnitParams.from_seed(int(info.get("unit_seed", seed)))
    except (KeyError, TypeError, ValueError, TwinError) as exc:
        return TwinOracle(None, session, f"its sensor configuration is unusable ({exc})")
    t0 = dataset.arrays["t_start"][rows]
    period = float(np.median(np.diff(np.sort(t0))))
    oracle = Oracle(unit, cfg, steps, scene.env, sample_period_s=period)
    return TwinOracle(oracle, session, "", scene.name)


def _agreement(dataset: Dataset, rows: NDArray[np.int64], scene: Scene) -> float:
    a = dataset.arrays
    tmid = 0.5 * (a["t_start"][rows] + a["t_end"][rows])
    return float(np.mean(scene.contact(tmid).in_contact == a["in_contact"][rows]))


def _rebuild_scene(
    dataset: Dataset, rows: NDArray[np.int64], info: dict[str, Any]
) -> tuple[Scene | None, str]:
    """Scene from its name and seed; a calibration scene's presses depend on its exact
    duration, so candidate durations consistent with the last window are tried."""
    from spectratac.sim.named_scenes import make_scene

    name = str(info.get("scene", ""))
    seed = int(info.get("scene_seed", info["seed"]))
    params: list[dict[str, str]] = [{}]
    if name == "calibration":
        t_last = float(dataset.arrays["t_end"][rows].max())
        t0 = np.sort(dataset.arrays["t_start"][rows])
        period = float(np.median(np.diff(t0)))
        given = info.get("duration_s")
        durations = [float(given)] if given is not None else _durations(t_last, period)
        params = [{"seed": str(seed), "duration": repr(d)} for d in durations]
    for p in params:
        try:
            scene = make_scene(name, **p)
        except (ValueError, TwinError):
            return None, f"{name!r} is unknown"
        if _agreement(dataset, rows, scene) >= AGREEMENT:
            return scene, ""
    return None, "could not be rebuilt (pass the scene explicitly)"


def _durations(t_last: float, period: float) -> list[float]:
    """Round durations D with t_last <= D < t_last + period (the window schedule's range)."""
    out: list[float] = []
    for step in (60.0, 10.0, 1.0, 0.1):
        d = math.ceil(t_last / step - 1e-9) * step
        d = round(d, 6)
        if d < t_last + period - 1e-9 and d not in out:
            out.append(d)
    return out


def oracle_predictions(
    dataset: Dataset,
    rows: NDArray[np.int64],
    scene: Scene | None = None,
    samples: int = DEFAULT_SAMPLES,
    seed: int = 0,
) -> tuple[NDArray[np.int64], Predictions | None, str]:
    """(rows decoded, their oracle predictions, a note for the report)."""
    sub = subsample(np.asarray(rows, dtype=np.int64), samples, seed)
    sessions = dataset.arrays["session"][sub]
    kept: list[NDArray[np.int64]] = []
    targets: list[NDArray[np.float64]] = []
    regions: list[NDArray[np.int8]] = []
    reasons: list[str] = []
    for s in np.unique(sessions):
        o = twin_oracle(dataset, scene=scene, session=int(s))
        if o.oracle is None:
            reasons.append(o.reason)
            continue
        r = sub[sessions == s]
        est = o.decode(dataset, r)
        kept.append(r)
        targets.append(est.targets)
        regions.append(est.region)
    if not kept:
        why = "; ".join(sorted(set(reasons))) or "no rows to decode"
        return np.zeros(0, np.int64), None, f"no oracle: {why}"
    done = np.concatenate(kept)
    order = np.argsort(done)
    pred = Predictions(
        list(FT_NAMES),
        np.concatenate(targets)[order],
        region=np.concatenate(regions)[order].astype(np.int64),
    )
    note = (
        f"oracle (true unit, model inversion per sample) on a deterministic subsample of "
        f"{done.size} of the {rows.size} evaluation rows (seed {seed}); it knows the unit, LEDs "
        "and environment but not the press history (creep), so a learned decoder can beat it"
    )
    if reasons:
        note += f"; rows of other sessions skipped: {'; '.join(sorted(set(reasons)))}"
    return done[order], pred, note


@dataclass(frozen=True)
class OracleFloor:
    """The oracle as `spectratac.evaluate.run.Floor`: `samples` rows decoded per section,
    with `scene` given or rebuilt from the dataset's metadata."""

    samples: int = DEFAULT_SAMPLES
    scene: Scene | None = None

    def __call__(
        self, dataset: Dataset, rows: NDArray[np.int64], seed: int
    ) -> tuple[NDArray[np.int64], Predictions | None, str]:
        return oracle_predictions(dataset, rows, self.scene, self.samples, seed)
