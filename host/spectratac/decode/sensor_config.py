"""The sensor configuration a decoder was trained under, and checks against another one.

A configuration is the dict a dataset stores in ``meta["config"]`` (integration_ms, gain,
digital_gain, sensitivity, leds, settle_us). A device's CONFIG reply is converted to it.
Only the fields that change the counts are compared (settle time is not).

>>> a = {"integration_ms": 50, "gain": 1.0, "digital_gain": 1, "sensitivity": "high",
...      "leds": [[[250, 250, 250]] * 3], "settle_us": 0}
>>> differences(a, dict(a, integration_ms=100, settle_us=1000))
['integration_ms: trained 50, got 100']
"""

from __future__ import annotations

import json
from typing import Any

from spectratac.decode.errors import DecoderConfigError

COMPARED = ("integration_ms", "gain", "digital_gain", "sensitivity", "leds")
_GAIN = {0: 1.0, 1: 2.0, 2: 4.0, 3: 0.5}
_DG = {0: 1, 1: 2, 2: 4}


def from_message(msg: Any) -> dict[str, Any]:
    """A device CONFIG message (protocol codes) as a dataset-style configuration dict."""
    steps = int(msg.led_step_count)
    return {
        "integration_ms": int(msg.integration_ms),
        "gain": _GAIN.get(int(msg.gain), float("nan")),
        "digital_gain": _DG.get(int(msg.digital_gain), -1),
        "sensitivity": "high" if int(msg.sensitivity) == 0 else "low",
        "leds": [[list(map(int, led)) for led in step] for step in msg.led_duty[:steps]],
        "settle_us": int(msg.led_settle_us),
    }


def normalise(config: Any) -> dict[str, Any] | None:
    """A dict, a CONFIG message, a list of identical dicts or None, as a dict (or None)."""
    if config is None or isinstance(config, dict):
        return config
    if isinstance(config, list):  # a dataset joined across configurations
        distinct = {json.dumps(c, sort_keys=True) for c in config}
        if len(distinct) == 1:
            return normalise(config[0])
        raise DecoderConfigError(
            "the data mixes several sensor configurations; a decoder serves one: split it "
            "with spectratac.dataset.split_by_config"
        )
    if hasattr(config, "led_step_count"):
        return from_message(config)
    raise TypeError(f"expected a configuration dict or CONFIG message, got {type(config)}")


def _canon(key: str, v: Any) -> Any:
    if key == "leds":
        return [[[int(c) for c in led] for led in step] for step in v]
    if key == "gain":
        return float(v)
    return v


def differences(trained: dict[str, Any] | None, other: dict[str, Any] | None) -> list[str]:
    """Human-readable differences between two configurations (empty if compatible)."""
    if trained is None or other is None:
        return []
    out = []
    for k in COMPARED:
        a, b = trained.get(k), other.get(k)
        if a is None or b is None:
            continue
        if _canon(k, a) != _canon(k, b):
            out.append(f"{k}: trained {a}, got {b}")
    return out


def n_steps(config: dict[str, Any] | None) -> int:
    """LED steps in the sequence (1 without a configuration)."""
    if not config or not config.get("leds"):
        return 1
    return len(config["leds"])
