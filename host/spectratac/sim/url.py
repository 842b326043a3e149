"""Parse sim:// URLs: sim://?scene=tour&seed=3&speed=max&absent=1

``fault=NAME[,NAME…]`` makes the device faulty (spectratac.sim.faults.FAULTS), tuned by
``fault_rate``, ``fault_stall`` and ``fault_every``:

>>> opts = parse_sim_url("sim://?scene=idle&fault=corrupt,stall&fault_rate=1e-3")
>>> opts.faults, opts.fault_params, opts.scene_params
(('corrupt', 'stall'), {'fault_rate': '1e-3'}, {})

``model_store=PATH`` keeps the device's model store (its flash, where an uploaded decoder
lives) in that file; without it each seed gets a file in a temporary folder of this process
(spectratac.sim.model_store), so a model survives closing and re-opening the same device:

>>> parse_sim_url("sim://?seed=2&model_store=/tmp/dev2.flash").model_store
'/tmp/dev2.flash'
"""

from __future__ import annotations

from dataclasses import dataclass, field
from urllib.parse import parse_qs, quote, urlsplit

from spectratac.sim.faults import parse_faults
from spectratac.sim.runner import MAX


@dataclass(frozen=True)
class SimOptions:
    scene: str = "idle"
    seed: int = 0
    speed: float | str = 1.0
    absent: tuple[int, ...] = ()  # sensors (0..2) that do not answer on their bus
    scene_params: dict[str, str] = field(default_factory=dict)
    faults: tuple[str, ...] = ()  # spectratac.sim.faults: how this device misbehaves
    fault_params: dict[str, str] = field(default_factory=dict)
    model_store: str | None = None  # file of the model store; None: the per-seed default

    def query(self) -> str:
        parts = [f"scene={self.scene}", f"seed={self.seed}", f"speed={self.speed}"]
        if self.absent:
            parts.append("absent=" + ",".join(map(str, self.absent)))
        parts += [f"{k}={v}" for k, v in self.scene_params.items()]
        if self.faults:
            parts.append("fault=" + ",".join(self.faults))
        parts += [f"{k}={v}" for k, v in self.fault_params.items()]
        if self.model_store is not None:
            parts.append(f"model_store={quote(self.model_store, safe='/')}")
        return "sim://?" + "&".join(parts)


def parse_sim_url(url: str) -> SimOptions:
    parts = urlsplit(url)
    if parts.scheme != "sim":
        raise ValueError(f"{url!r} is not a sim:// URL")
    query = {k: v[-1] for k, v in parse_qs(parts.query, keep_blank_values=True).items()}
    scene = query.pop("scene", parts.netloc or "idle")
    model_store = query.pop("model_store", None)
    if model_store == "":
        raise ValueError(f"bad sim URL {url!r}: model_store needs a file path")
    try:
        seed = int(query.pop("seed", "0"))
        raw_speed = query.pop("speed", "1")
        speed: float | str = MAX if raw_speed == MAX else float(raw_speed)
        absent = tuple(int(a) for a in query.pop("absent", "").split(",") if a)
        faults = parse_faults(query.pop("fault", ""))
        fault_params = {k: query.pop(k) for k in list(query) if k.startswith("fault_")}
        for value in fault_params.values():
            float(value)  # rates and durations: a number, else the ValueError below
    except ValueError as exc:
        raise ValueError(
            f"bad sim URL {url!r}: {exc}; example: sim://?scene=tour&seed=3&speed=max"
        ) from None
    if isinstance(speed, float) and speed <= 0:
        raise ValueError(f"bad sim URL {url!r}: speed must be > 0 or 'max'")
    if any(a not in (0, 1, 2) for a in absent):
        raise ValueError(f"bad sim URL {url!r}: absent lists sensors 0, 1, 2")
    return SimOptions(scene, seed, speed, absent, query, faults, fault_params, model_store)
