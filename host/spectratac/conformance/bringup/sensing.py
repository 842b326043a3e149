"""The three VEML3328s: present and answering on their buses, and the sample rate at each
integration time, measured on the device's own clock against what the LED sequence's timing
gives (one integration per sample for a single LED step)."""

from __future__ import annotations

import numpy as np

from spectratac.conformance.bringup.bench import Bench
from spectratac.conformance.bringup.report import FAIL, PASS, Row
from spectratac.protocol.generated import messages as m

INTEGRATION_TIMES = (50, 100, 200, 400)
#: samples per integration time (the first after CONFIGURE is dropped: its window may have
#: begun under the previous configuration)
RATE_SAMPLES = 6
#: a period this far from the integration time fails (the conformance suite's bound)
RATE_TOLERANCE = 0.05
#: a dim white step: the rate does not depend on the light, and dim counts never saturate
DIM = [[[50, 50, 50]] * 3]
BAD = m.SensorStatus.SENSOR_ABSENT | m.SensorStatus.SENSOR_BUS_FAULT | m.SensorStatus.SENSOR_STALE
SENSOR_SAMPLES = 8


def flag_names(bits: int) -> list[str]:
    return [str(f.name) for f in m.SensorStatus if bits & f]


def sensors(bench: Bench) -> Row:
    s = bench.sensor
    before = s.status().bus_errors if s.info.capabilities & m.Capabilities.CAP_STATUS else None
    batch = bench.stream(SENSOR_SAMPLES, 50, DIM, skip=1)
    after = s.status().bus_errors if before is not None else None
    present = [k for k in range(3) if s.info.sensor_present >> k & 1]
    problems, flags = [], {}
    absent = [k for k in range(3) if k not in present]
    if absent:
        problems.append(
            f"sensor{'s' if len(absent) > 1 else ''} {', '.join(map(str, absent))} did not "
            "answer the ID probe: check the I²C bus (SDA/SCL pull-ups, the VEML3328's solder "
            "joints, 3.3 V at its VDD)"
        )
    for k in range(3):
        seen = int(np.bitwise_or.reduce(batch["status"][:, k])) if len(batch) else 0
        flags[str(k)] = flag_names(seen)
        if k in present and seen & BAD:
            problems.append(f"sensor {k} flagged {', '.join(flag_names(seen & BAD))}")
    errors = [b - a for a, b in zip(before, after, strict=True)] if before and after else None
    if errors and any(errors):
        problems.append(f"I²C bus errors while streaming: {errors} per sensor")
    if len(batch) < SENSOR_SAMPLES:
        problems.append(f"only {len(batch)} of {SENSOR_SAMPLES} samples arrived")
    values = {"present": present, "flags": flags, "bus_errors": errors, "samples": len(batch)}
    said = f"sensors present {present}, {len(batch)} samples" + (
        f", bus errors {errors}" if errors is not None else ""
    )
    return Row("sensors", FAIL if problems else PASS, "; ".join(problems) or said, values)


def sample_rate(bench: Bench) -> Row:
    rows, problems = [], []
    for it in INTEGRATION_TIMES:
        batch = bench.stream(RATE_SAMPLES, it, DIM, skip=1)
        t = batch["device_time_us"].astype(np.int64)
        if len(t) < 3:
            problems.append(f"{it} ms: only {len(t)} samples arrived")
            continue
        period_ms = float(np.median(np.diff(t))) / 1000
        width_ms = float(np.median(t - batch["t_start_us"].astype(np.int64))) / 1000
        seq = batch["sequence"].astype(np.int64)
        gaps = int(np.sum(np.diff(seq) - 1))
        rows.append(
            {
                "integration_ms": it,
                "expected_hz": round(1000 / it, 4),
                "measured_hz": round(1000 / period_ms, 4),
                "period_ms": round(period_ms, 3),
                "window_ms": round(width_ms, 3),
                "gaps": gaps,
            }
        )
        off = period_ms / it - 1
        if abs(off) > RATE_TOLERANCE:
            problems.append(
                f"{it} ms: a sample every {period_ms:.2f} ms ({off:+.1%}; the VEML3328's "
                f"internal oscillator or the device clock is off by more than "
                f"{RATE_TOLERANCE:.0%})"
            )
        if abs(width_ms / it - 1) > RATE_TOLERANCE:
            problems.append(
                f"{it} ms: integration windows of {width_ms:.2f} ms (trigger to read): the "
                "firmware reads the sensor before its conversion ends, or stamps it wrongly"
            )
        if gaps:
            problems.append(f"{it} ms: {gaps} samples missing from the sequence")
    said = ", ".join(f"{r['integration_ms']} ms {r['measured_hz']:.2f}/s" for r in rows)
    return Row(
        "sample rate",
        FAIL if problems else PASS,
        "; ".join(problems) or f"{said} (device clock; expected 1/integration time)",
        {"rates": rows},
    )
