"""What the board says about its last reset (protocol 1.4): the reset cause, the fault record
a HardFault left, resets in a row and safe mode, the brown-out level, and the TRIG latency of
each sensor. On an older firmware each check is skipped, saying so."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from spectratac.conformance.bringup.bench import REOPEN_S, WAIT_S, Bench
from spectratac.conformance.bringup.report import FAIL, PASS, SKIPPED, Row
from spectratac.conformance.bringup.sensing import DIM
from spectratac.device import (
    CommandRejectedError,
    DeviceTimeoutError,
    DisconnectedError,
    MissingCapabilityError,
)
from spectratac.device.boot_report import BOR_LEVEL_FOR_FLASH, SINCE_MINOR, BootReport
from spectratac.protocol.generated import messages as m

BOR_WANTED = BOR_LEVEL_FOR_FLASH  # 2.7 V: what 32-bit flash writes need
TRIG_SAMPLES = 20
#: TRIG latency bins, as fractions of the integration time
TRIG_EDGES = (0.0, 0.5, 0.9, 1.0, 1.1, 1.25, 1.5, 2.0)
TRIG_MAX = 1.5  # a conversion longer than 1.5 integration times is a sensor or bus problem


def too_old(name: str, bench: Bench) -> Row | None:
    if bench.speaks(SINCE_MINOR):
        return None
    return Row(
        name,
        SKIPPED,
        f"the firmware speaks protocol {bench.version}; this check reads STATUS fields of "
        f"protocol 1.{SINCE_MINOR}: flash a firmware from this checkout to run it",
    )


def boot_values(boot: BootReport) -> dict[str, Any]:
    values: dict[str, Any] = {
        "reset_cause": boot.causes,
        "reset_cause_bits": boot.reset_cause,
        "abnormal_resets": boot.abnormal_resets,
        "safe_mode": boot.safe_mode,
    }
    if boot.fault_present:
        values["fault"] = {k: f"0x{v:08X}" for k, v in boot.fault.items()}
        values["fault_flags"] = boot.fault_flags()
    return values


def fault_text(boot: BootReport) -> str:
    f = boot.fault
    return (
        f"a fault record: PC 0x{f['pc']:08X}, LR 0x{f['lr']:08X}, CFSR 0x{f['cfsr']:08X} "
        f"({' '.join(boot.fault_flags()) or '-'}): look the PC up in the image "
        "(arm-none-eabi-addr2line -e firmware.elf PC)"
    )


def reset_cause(bench: Bench) -> Row:
    name = "reset cause and fault record"
    skipped = too_old(name, bench)
    if skipped or bench.first_status is None:
        return skipped or Row(name, SKIPPED, "no STATUS")
    boot = BootReport.from_status(bench.first_status, bench.minor)
    values = boot_values(boot)
    problems = []
    if boot.fault_present:
        problems.append(fault_text(boot))
    if boot.abnormal:
        problems.append(f"the last reset was abnormal ({', '.join(boot.causes)})")
    if boot.abnormal_resets:
        problems.append(f"{boot.abnormal_resets} abnormal resets in a row")
    if boot.safe_mode:
        problems.append("booted in safe mode (without the model store) after abnormal resets")
    said = f"reset by {', '.join(boot.causes) or 'nothing recorded'}; no fault record"
    return Row(name, FAIL if problems else PASS, "; ".join(problems) or said, values)


def brownout(bench: Bench) -> Row:
    """The brown-out reset level of the option bytes: 32-bit flash writes need 2.7 V (3)."""
    name = "brown-out level"
    skipped = too_old(name, bench)
    if skipped or bench.first_status is None:
        return skipped or Row(name, SKIPPED, "no STATUS")
    level = BootReport.from_status(bench.first_status, bench.minor).bor_level
    values = {"bor_level": level, "wanted": BOR_WANTED}
    if level < BOR_WANTED:
        return Row(
            name,
            FAIL,
            f"level {level}, not {BOR_WANTED}: a sagging supply could corrupt a flash write, "
            "and the firmware refuses model uploads (BOR_TOO_LOW); set level 3 once, at "
            "provisioning (firmware/README.md, bring-up)",
            values,
        )
    return Row(name, PASS, f"level {level} (reset below 2.7 V)", values)


def trig_latency(bench: Bench) -> Row:
    """TRIG written to TRIG cleared, per sensor: STATUS polled after each sample streams in."""
    name = "TRIG latency"
    skipped = too_old(name, bench)
    if skipped:
        return skipped
    s, it = bench.sensor, 50
    if not s.info.sensor_present:
        return Row(name, SKIPPED, "no sensor answers (see sensors)")
    config_id = s.configure(integration_ms=it, leds=DIM)
    s.read(1_000_000, timeout=0)
    seen: list[tuple[int, ...]] = []
    s.start()
    try:
        for _ in range(TRIG_SAMPLES):
            batch = s.read(1, timeout=WAIT_S)
            if not len(batch) or batch["config_id"][0] != config_id:
                continue
            seen.append(tuple(int(v) for v in s.status().trig_latency_us_last))
        worst = tuple(int(v) for v in s.status().trig_latency_us_max)
    finally:
        s.stop()
    if not seen:
        return Row(name, FAIL, "no samples arrived while polling STATUS")
    present = [k for k in range(3) if s.info.sensor_present >> k & 1]
    return latency_row(np.array(seen, dtype=np.int64), worst, present, it)


def latency_row(lat: np.ndarray, worst: tuple[int, ...], present: list[int], it: int) -> Row:
    """The TRIG latency verdict on what was polled: `lat` (polls x 3 sensors, µs), the
    device's own maxima `worst`, the sensors present, the integration time `it` (ms).

    >>> lat = np.array([[50_900, 51_000, 50_800]] * 4)
    >>> latency_row(lat, (51_200, 51_000, 50_900), [0, 1, 2], 50).verdict
    'pass'
    >>> latency_row(lat, (120_000, 51_000, 50_900), [0, 1, 2], 50).detail[:40]
    'sensor 0: TRIG took up to 120.0 ms for a'
    """
    name = "TRIG latency"
    edges_us = [e * it * 1000 for e in TRIG_EDGES] + [np.inf]
    values: dict[str, Any] = {
        "integration_ms": it,
        "bin_edges_us": [int(e) for e in edges_us[:-1]],
        "histogram": {str(k): np.histogram(lat[:, k], bins=edges_us)[0].tolist() for k in present},
        "median_us": {str(k): int(np.median(lat[:, k])) for k in present},
        "max_us": {str(k): int(worst[k]) for k in present},
        "polls": len(lat),
    }
    if not lat.any():
        return Row(name, SKIPPED, "the firmware does not measure it (every latency 0)", values)
    problems = []
    for k in present:
        if np.any(lat[:, k] == 0):
            problems.append(f"sensor {k}: no TRIG latency measured (0 µs)")
        if worst[k] > TRIG_MAX * it * 1000:
            problems.append(
                f"sensor {k}: TRIG took up to {worst[k] / 1000:.1f} ms for a {it} ms integration: "
                "the sensor may not clear TRIG itself (hardware/datasheet_facts.toml)"
            )
    said = ", ".join(
        f"sensor {k} median {values['median_us'][str(k)] / 1000:.1f} ms, max "
        f"{worst[k] / 1000:.1f} ms"
        for k in present
    )
    return Row(name, FAIL if problems else PASS, "; ".join(problems) or f"{said} ({it} ms)", values)


def _commanded(bench: Bench, name: str, kind: m.FaultKind) -> tuple[BootReport, float] | Row:
    """DEBUG_FAULT `kind`, then the boot report of the reset it causes and the host seconds
    the board took to answer again; a skipped Row for a release image."""
    s = bench.sensor
    before = s.status()
    try:
        s.debug_fault(kind)
    except (MissingCapabilityError, CommandRejectedError) as exc:
        return Row(name, SKIPPED, f"a release image: {exc}")
    started = time.monotonic()
    status = back_after_reset(bench, before)
    return BootReport.from_status(status, bench.minor), time.monotonic() - started


def watchdog(bench: Bench) -> Row:
    """Command a hang (test images only) and read the reset cause once the independent
    watchdog has reset the board."""
    name = "watchdog"
    skipped = too_old(name, bench)
    if skipped:
        return skipped
    got = _commanded(bench, name, m.FaultKind.FAULT_HANG)
    if isinstance(got, Row):
        return got
    boot, back_s = got
    values = boot_values(boot) | {"back_after_s": round(back_s, 3)}
    if not boot.reset_cause & m.ResetCause.RESET_IWDG:
        return Row(
            name,
            FAIL,
            f"after a commanded hang the board reports reset by "
            f"{', '.join(boot.causes) or 'nothing'}, not the independent watchdog: is the "
            "watchdog started, and fed only by the superloop?",
            values,
        )
    return Row(
        name,
        PASS,
        f"reset by the independent watchdog after a commanded hang; answering again after "
        f"{back_s:.1f} s (host time)",
        values,
    )


def fault_record(bench: Bench) -> Row:
    """Command a HardFault (test images only): after the reset the fault record names it."""
    name = "fault record"
    skipped = too_old(name, bench)
    if skipped:
        return skipped
    got = _commanded(bench, name, m.FaultKind.FAULT_HARD)
    if isinstance(got, Row):
        return got
    boot, _ = got
    values = boot_values(boot)
    if not boot.fault_present or not boot.fault["pc"]:
        return Row(
            name,
            FAIL,
            f"after a commanded HardFault the board reports reset by "
            f"{', '.join(boot.causes) or 'nothing'} and no fault record: the record in .noinit "
            "RAM did not survive the reset",
            values,
        )
    return Row(
        name,
        PASS,
        f"the commanded HardFault is recorded: PC 0x{boot.fault['pc']:08X}, "
        f"{' '.join(boot.fault_flags()) or 'no CFSR flags'}",
        values,
    )


def back_after_reset(bench: Bench, before: m.Status) -> m.Status:
    """The first STATUS of the board's next boot (its uptime or its count of frames received
    went back: both start from zero at boot), on the same link while it holds (a UART, a
    simulated device), else opened again (USB re-enumerates)."""
    deadline = time.monotonic() + REOPEN_S
    while True:
        try:
            status = bench.sensor.status()
            if status.uptime_ms < before.uptime_ms or status.rx_frames <= before.rx_frames:
                return status
        except DisconnectedError:
            bench.reopen(max(0.0, deadline - time.monotonic()))
        except DeviceTimeoutError:
            pass  # hung until the watchdog bites, or still booting
        if time.monotonic() > deadline:
            raise DeviceTimeoutError(
                f"{bench.url} did not come back within {REOPEN_S:.0f} s of a commanded fault: "
                "is the independent watchdog running? (power-cycle the board)"
            )
        time.sleep(0.2)
