"""Each of the nine LED channels (3 LEDs x R, G, B) lit alone at full duty, and all dark: the
9 x 15 response matrix (a row per channel, a column per count: 3 sensors x R, G, B, C, IR),
judged for saturation, a dark floor, a channel that does not light, and a colour wired to the
wrong pin (a red channel that lights blue counts most).

>>> dark = np.zeros(15); lit = np.full((9, 15), 100.0)
>>> for ch in range(9):
...     lit[ch, [ch % 3, 5 + ch % 3, 10 + ch % 3]] = 5000
>>> judge(lit, dark, np.zeros((9, 15), bool))
[]
"""

from __future__ import annotations

import numpy as np

from spectratac.conformance.bringup.bench import Bench
from spectratac.conformance.bringup.report import FAIL, PASS, SKIPPED, Row
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.protocol.generated import messages as m

FULL = 1000  # duty, permille
FULL_SCALE = 65535  # a VEML3328 count: 16 bits
#: the bring-up configuration: the paper's 50 ms at gain x1 (what `record` uses)
INTEGRATION_MS = 50
SAMPLES = 4  # per channel, after the first of each configuration is dropped
#: all LEDs off, a channel's counts above this (of full scale) is light leaking in or a channel
#: that never turns off
DARK_MAX = 0.05
#: a channel lit at full duty raises its own colour's count by at least this on some sensor
LIT_MIN = 1000
CHANNELS = [f"LED{led}.{colour}" for led in range(vocab.N_LEDS) for colour in vocab.LED_COLOURS]
N_CH = len(vocab.CHANNELS)  # counts per sensor (R, G, B, C, IR)


def alone(channel: int) -> np.ndarray:
    """One LED step with only `channel` (LED channel // 3, colour channel % 3) at full duty."""
    duty = np.zeros((1, vocab.N_LEDS, len(vocab.LED_COLOURS)), dtype=int)
    if channel >= 0:
        duty[0, channel // 3, channel % 3] = FULL
    return duty


def colour_columns(colour: int) -> list[int]:
    """The columns of one colour (R, G or B) on every sensor."""
    return [k * N_CH + colour for k in range(vocab.N_SENSORS)]


def judge(lit: np.ndarray, dark: np.ndarray, saturated: np.ndarray) -> list[str]:
    """What is wrong with a measured matrix: `lit` (9 x 15 median counts, each channel alone),
    `dark` (15, all off), `saturated` (9 x 15, a count read full scale or flagged)."""
    problems = []
    names = vocab.SENSOR_CHANNELS
    clipped = [
        f"{CHANNELS[ch]} on {names[col]}" for ch, col in zip(*np.nonzero(saturated), strict=True)
    ]
    if clipped:
        problems.append(
            f"counts clip at full duty: {', '.join(clipped)}; a sensor this close to its LED "
            "needs a lower duty (record --leds) or gain, or the skin's optical layer is thinner "
            "than designed"
        )
    hot = [names[c] for c in np.nonzero(dark > DARK_MAX * FULL_SCALE)[0]]
    if hot:
        problems.append(
            f"dark (every LED off) reads above {DARK_MAX:.0%} of full scale on {', '.join(hot)}: "
            "light leaks in (skin not black, board not covered) or an LED never turns off"
        )
    response = lit - dark
    dead, crossed = [], []
    for ch, name in enumerate(CHANNELS):
        colour = ch % 3
        if max(response[ch, colour_columns(c)].max() for c in range(3)) < LIT_MIN:
            dead.append(name)
            continue
        per_colour = [response[ch, colour_columns(c)].sum() for c in range(3)]
        strongest = int(np.argmax(per_colour))
        if strongest != colour:
            crossed.append(f"{name} lights {vocab.LED_COLOURS[strongest]} counts most")
    if dead:
        problems.append(
            f"{', '.join(dead)} {'does' if len(dead) == 1 else 'do'} not light (no colour rises "
            f"{LIT_MIN} counts on any sensor): check the LED, its resistor and its PWM pin"
        )
    if crossed:
        problems.append(
            f"{', '.join(crossed)}: colours wired to the wrong PWM pins (see the pin map)"
        )
    return problems


def led_channels(bench: Bench) -> Row:
    if not bench.sensor.info.sensor_present:
        return Row("LED channels", SKIPPED, "no sensor answers to see the LEDs (see sensors)")
    medians, saturated = [], []
    for channel in [-1, *range(len(CHANNELS))]:
        batch = bench.stream(SAMPLES, INTEGRATION_MS, alone(channel), skip=1)
        if not len(batch):
            return Row("LED channels", FAIL, f"no samples with {CHANNELS[channel]} alone")
        counts = batch["counts"].reshape(len(batch), -1).astype(np.int64)
        flags = batch["status"] & m.SensorStatus.SENSOR_SATURATED
        flagged = np.repeat(np.bitwise_or.reduce(flags, axis=0) > 0, N_CH)
        medians.append(np.median(counts, axis=0))
        saturated.append((counts.max(axis=0) >= FULL_SCALE) | flagged)
    dark, lit = medians[0], np.array(medians[1:])
    problems = judge(lit, dark, np.array(saturated[1:]))
    response = np.clip(lit - dark, 0, None).round().astype(int)
    values = {
        "integration_ms": INTEGRATION_MS,
        "duty_permille": FULL,
        "channels": CHANNELS,
        "columns": list(vocab.SENSOR_CHANNELS),
        "matrix": response.tolist(),
        "raw": lit.round().astype(int).tolist(),
        "dark": dark.round().astype(int).tolist(),
        "peak_fraction": round(float(lit.max()) / FULL_SCALE, 4),
    }
    said = (
        f"9 channels light their own colour; peak {values['peak_fraction']:.0%} of full scale, "
        f"dark at most {int(dark.max())} counts ({INTEGRATION_MS} ms, gain x1, "
        "full duty)"
    )
    return Row("LED channels", FAIL if problems else PASS, "; ".join(problems) or said, values)
