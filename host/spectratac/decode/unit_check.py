"""Is the sensor the unit the decoder was calibrated on? Compared on open, from the device's
unique id (INFO) and any other name its link knows it by (a simulated unit: twin-<seed>),
against the unit id the model carries.

>>> unit_mismatch("twin-0", ("0a1b", "twin-0")) is None
True
>>> msg = unit_mismatch("twin-0", ("0a1b", "twin-3"))
>>> msg.split(":")[0]
"the sensor is unit '0a1b' (twin-3) but the model was calibrated on unit 'twin-0'"
>>> "--finetune" in msg and len(msg.splitlines())
1
>>> unit_mismatch(None, ("0a1b",)) is None  # a model without a unit id: nothing to compare
True
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any, Literal

from spectratac.decode.errors import DecoderUnitError, DecoderUnitWarning

UnitPolicy = Literal["warn", "strict", "off"]


def device_unit_ids(sensor: Any) -> tuple[str, ...]:
    """Every id `sensor` answers to: its unique id in hex, then the unit name its link gives
    (empty for a stream that knows neither, such as a replayed file)."""
    ids: list[str] = []
    info = getattr(sensor, "info", None)
    uid = getattr(info, "device_uid", None)
    if isinstance(uid, (bytes, bytearray)) and uid:
        ids.append(bytes(uid).hex())
    name = getattr(getattr(sensor, "link_info", None), "unit_name", None)
    if isinstance(name, str) and name:
        ids.append(name)
    return tuple(ids)


def unit_mismatch(model_unit: str | None, ids: Sequence[str]) -> str | None:
    """A one-line message when the sensor (known by `ids`) is not `model_unit`; None when
    it is, or when either side has no id."""
    if not model_unit or not ids or model_unit in ids:
        return None
    also = f" ({', '.join(ids[1:])})" if len(ids) > 1 else ""
    return (
        f"the sensor is unit {ids[0]!r}{also} but the model was calibrated on unit "
        f"{model_unit!r}: expect larger errors; recalibrate it for this unit from a minute of "
        f"guided presses, no reference F/T needed: spectratac record URL --guided 9 -o "
        f"g.mcap, dataset build g.mcap -o g.npz, then spectratac train g.npz --finetune "
        f"MODEL.stac -o NEW.stac"
    )


def check_sensor_unit(model_unit: str | None, sensor: Any, policy: UnitPolicy) -> str | None:
    """Compare on open: "warn" emits DecoderUnitWarning, "strict" raises DecoderUnitError,
    "off" does nothing. Returns the mismatch message, if any."""
    if policy == "off":
        return None
    msg = unit_mismatch(model_unit, device_unit_ids(sensor))
    if msg is None:
        return None
    if policy == "strict":
        raise DecoderUnitError(msg + " (or drop --strict-unit to decode anyway)")
    warnings.warn(msg, DecoderUnitWarning, stacklevel=3)
    return msg
