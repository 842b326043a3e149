"""Parse sim:// URLs: sim://?scene=tour&seed=3&speed=max&absent=1

Every parameter is in one table, `SIM_PARAMS` (kind, range, meaning; the guide lists it):
a value out of its range, or a key the table does not know, is refused with the range or
the known keys (spectratac.url_schemes.parse_params).

``fault=NAME[,NAME…]`` makes the device faulty (spectratac.sim.faults.FAULTS), tuned by
``fault_rate``, ``fault_stall``, ``fault_every`` and ``fault_unplug``:

>>> opts = parse_sim_url("sim://?scene=idle&fault=corrupt,stall&fault_rate=1e-3")
>>> opts.faults, opts.fault_params, opts.scene_params
(('corrupt', 'stall'), {'fault_rate': '1e-3'}, {})
>>> parse_sim_url("sim://?speed=1e-300")
Traceback (most recent call last):
...
spectratac.sim.url.SimURLError: sim://?speed=1e-300: speed=1e-300 must be a finite number ...

``model_store=PATH`` keeps the device's model store (its flash, where an uploaded decoder
lives) in that file; without it each seed gets a file in a temporary folder of this process
(spectratac.sim.model_store), so a model survives closing and re-opening the same device:

>>> parse_sim_url("sim://?seed=2&model_store=/tmp/dev2.flash").model_store
'/tmp/dev2.flash'
"""

from __future__ import annotations

from dataclasses import dataclass, field
from urllib.parse import parse_qs, quote, urlsplit

from spectratac.device.transport import BadAddressError
from spectratac.sim.faults import FAULTS
from spectratac.sim.runner import MAX
from spectratac.url_schemes import Param, check_url, parse_params

#: Slowest and fastest time scale of a paced device (speed=max: as fast as the machine can).
#: Slower than 1/100 a stream of 50-ms samples waits 5 s per sample; faster than 1000 the
#: pacing is no pacing at all (use max).
SPEED_RANGE = (0.01, 1000.0)

#: Every sim:// parameter: the device's, the faults', the scenes' and the paired F/T's.
SIM_PARAMS: dict[str, Param] = {
    "scene": Param("text", meaning="scene name (spectratac twin generate --list)"),
    "seed": Param("integer", 0, 2**32 - 1, "the unit and its noise"),
    "speed": Param("number", *SPEED_RANGE, "time scale: 1 real time, 10 ten times faster, or max"),
    "absent": Param("choice", meaning="sensors that do not answer", choices=("0", "1", "2")),
    "model_store": Param("text", meaning="file of the device's model store"),
    "fault": Param("choice", meaning="faults of the device", choices=tuple(FAULTS)),
    "fault_rate": Param("number", 0.0, 1.0, "probability per byte of a corrupt fault"),
    "fault_stall": Param("number", 0.0, 3600.0, "seconds a stall fault holds the output"),
    "fault_every": Param("number", 0.01, 86400.0, "seconds between stalls"),
    "fault_unplug": Param("number", 0.001, 1e6, "mean seconds before an unplug fault"),
    # the scene's (spectratac.sim.named_scenes)
    "start": Param("number", 0.0, 1e6, "join the scene this far in, s"),
    "duration": Param("number", 0.001, 1e6, "scene length, s (idle, calibration, drift)"),
    "region": Param("integer", 0, 63, "the region a press scene presses"),
    "force": Param("numbers", 0.0, 100.0, "press force, N (presses: a comma list)"),
    "period": Param("number", 0.01, 3600.0, "seconds per region of a tour"),
    "order": Param("text", meaning="regions a presses scene presses, e.g. up,left,5"),
    "hold": Param("number", 0.0, 1e6, "seconds a press holds"),
    "gap": Param("number", 0.0, 1e6, "seconds between presses"),
    "prompts": Param("integer", 1, 10_000, "prompts a guided scene's person follows"),
    "rest": Param("number", 0.0, 3600.0, "seconds of rest after each guided prompt"),
    # the paired simulated F/T sensor's (spectratac.sim.ft_source)
    "ft": Param("choice", meaning="a paired simulated F/T", choices=("bota", "netft")),
    "ft_rate": Param("number", 1.0, 100_000.0, "F/T samples per second"),
    "ft_loss": Param("number", 0.0, 0.999, "probability an F/T sample is lost"),
    "ft_offset": Param("number", -1e6, 1e6, "F/T clock at scene time 0, s"),
    "ft_drift": Param("number", -0.01, 0.01, "F/T clock rate error"),
    "ft_port": Param("integer", 0, 65535, "port of a served F/T (0: any free one)"),
}
_DEVICE_KEYS = ("scene", "seed", "speed", "absent", "model_store", "fault")


class SimURLError(BadAddressError, ValueError):
    """A sim:// URL that cannot be opened: the message names the parameter and its range, or
    the known parameters."""


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
    """The options of a sim:// URL; SimURLError (a DeviceError and a ValueError) names what
    is wrong."""
    check_url(url, SimURLError)
    parts = urlsplit(url)
    if parts.scheme != "sim":
        raise SimURLError(f"{url!r} is not a sim:// URL")
    query = {k: v[-1] for k, v in parse_qs(parts.query, keep_blank_values=True).items()}
    raw_speed = query.get("speed", "1")
    checked = {k: v for k, v in query.items() if not (k == "speed" and v == MAX)}
    values = parse_params(url, checked, SIM_PARAMS, SimURLError)
    if query.get("model_store") == "":
        raise SimURLError(f"bad sim URL {url!r}: model_store needs a file path")
    speed: float | str = MAX if raw_speed == MAX else float(values.get("speed", 1.0))  # type: ignore[arg-type]
    absent = tuple(int(a) for a in str(values.get("absent", "")).split(",") if a)
    faults = tuple(n for n in str(values.get("fault", "")).split(",") if n)
    fault_params = {k: v for k, v in query.items() if k.startswith("fault_")}
    scene_params = {
        k: v for k, v in query.items() if k not in _DEVICE_KEYS and not k.startswith("fault_")
    }
    return SimOptions(
        query.get("scene", parts.netloc or "idle"),
        int(values.get("seed", 0)),  # type: ignore[call-overload]
        speed,
        absent,
        scene_params,
        faults,
        fault_params,
        query.get("model_store"),
    )
