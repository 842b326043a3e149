"""What the board says about its last reset (protocol 1.4): the reset cause, the fault record
a HardFault left, resets in a row and safe mode, the brown-out level, and the TRIG latency of
each sensor. On an older firmware each check is skipped, saying so."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from spectratac.conformance.bringup.bench import POST_MORTEM_MINOR, REOPEN_S, WAIT_S, Bench
from spectratac.conformance.bringup.report import FAIL, PASS, SKIPPED, Row
from spectratac.conformance.bringup.sensing import DIM
from spectratac.device import DeviceTimeoutError, DisconnectedError
from spectratac.protocol.generated import messages as m

#: the causes a healthy board boots from (a watchdog reset also pulls NRST: PIN alone is normal)
NORMAL = m.ResetCause.RESET_PIN | m.ResetCause.RESET_POWER | m.ResetCause.RESET_SOFTWARE
FAULT_FIELDS = (
    "fault_pc", "fault_lr", "fault_xpsr", "fault_cfsr", "fault_hfsr", "fault_mmfar", "fault_bfar",
)  # fmt: skip
#: CFSR bits worth naming (ARMv7-M: MemManage, BusFault and UsageFault status)
CFSR_BITS = {
    0: "IACCVIOL", 1: "DACCVIOL", 7: "MMARVALID", 8: "IBUSERR", 9: "PRECISERR",
    10: "IMPRECISERR", 15: "BFARVALID", 16: "UNDEFINSTR", 17: "INVSTATE", 18: "INVPC",
    19: "NOCP", 24: "UNALIGNED", 25: "DIVBYZERO",
}  # fmt: skip
BOR_WANTED = 3  # 2.7 V: what 32-bit flash writes need
TRIG_SAMPLES = 20
#: TRIG latency bins, as fractions of the integration time
TRIG_EDGES = (0.0, 0.5, 0.9, 1.0, 1.1, 1.25, 1.5, 2.0)
TRIG_MAX = 1.5  # a conversion longer than 1.5 integration times is a sensor or bus problem


def too_old(name: str, bench: Bench) -> Row | None:
    if bench.speaks(POST_MORTEM_MINOR):
        return None
    return Row(
        name,
        SKIPPED,
        f"the firmware speaks protocol {bench.version}; this check reads STATUS fields of "
        f"protocol 1.{POST_MORTEM_MINOR}: flash a firmware from this checkout to run it",
    )


def causes(bits: int) -> list[str]:
    """RESET_* names of STATUS.reset_cause, without the prefix: ['PIN', 'IWDG']."""
    return [f.name.removeprefix("RESET_") for f in m.ResetCause if f.name and bits & f]


def cfsr_names(cfsr: int) -> list[str]:
    return [name for bit, name in CFSR_BITS.items() if cfsr >> bit & 1]


def fault_record(status: Any) -> dict[str, str]:
    return {name: f"0x{int(getattr(status, name)):08X}" for name in FAULT_FIELDS}


def reset_cause(bench: Bench) -> Row:
    skipped = too_old("reset cause and fault record", bench)
    if skipped or bench.first_status is None:
        return skipped or Row("reset cause and fault record", SKIPPED, "no STATUS")
    st = bench.first_status
    found = causes(int(st.reset_cause))
    values: dict[str, Any] = {
        "reset_cause": found,
        "reset_cause_bits": int(st.reset_cause),
        "abnormal_resets": int(st.abnormal_resets),
        "safe_mode": bool(st.safe_mode),
    }
    problems = []
    if st.reset_cause & m.ResetCause.RESET_FAULT:
        values["fault"] = fault_record(st)
        values["cfsr_bits"] = cfsr_names(int(st.fault_cfsr))
        problems.append(
            f"a fault record: PC {values['fault']['fault_pc']}, LR {values['fault']['fault_lr']}, "
            f"CFSR {values['fault']['fault_cfsr']} ({', '.join(values['cfsr_bits']) or '-'}): "
            "look the PC up in the image (arm-none-eabi-addr2line -e firmware.elf PC)"
        )
    odd = causes(st.reset_cause & ~(NORMAL | m.ResetCause.RESET_FAULT))
    if odd:
        problems.append(f"the last reset was by {', '.join(odd)}")
    if st.abnormal_resets:
        problems.append(f"{st.abnormal_resets} abnormal resets in a row")
    if st.safe_mode:
        problems.append("booted in safe mode (without the model store) after abnormal resets")
    said = f"reset by {', '.join(found) or 'nothing recorded'}; no fault record"
    verdict = FAIL if problems else PASS
    return Row("reset cause and fault record", verdict, "; ".join(problems) or said, values)


def brownout(bench: Bench) -> Row:
    """The brown-out reset level of the option bytes: 32-bit flash writes need 2.7 V (3)."""
    name = "brown-out level"
    skipped = too_old(name, bench)
    if skipped or bench.first_status is None:
        return skipped or Row(name, SKIPPED, "no STATUS")
    level = int(bench.first_status.bor_level)
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
    lat = np.array(seen, dtype=np.int64)  # samples x sensors, µs
    edges_us = [e * it * 1000 for e in TRIG_EDGES] + [np.inf]
    present = [k for k in range(3) if s.info.sensor_present >> k & 1]
    values: dict[str, Any] = {
        "integration_ms": it,
        "bin_edges_us": [int(e) for e in edges_us[:-1]],
        "histogram": {k: np.histogram(lat[:, k], bins=edges_us)[0].tolist() for k in present},
        "median_us": {k: int(np.median(lat[:, k])) for k in present},
        "max_us": {k: worst[k] for k in present},
        "polls": len(seen),
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
        f"sensor {k} median {values['median_us'][k] / 1000:.1f} ms, max {worst[k] / 1000:.1f} ms"
        for k in present
    )
    return Row(name, FAIL if problems else PASS, "; ".join(problems) or f"{said} ({it} ms)", values)


def watchdog(bench: Bench) -> Row:
    """Command a hang (DEBUG_FAULT, test images only) and read the reset cause after the
    independent watchdog has reset the board."""
    name = "watchdog"
    skipped = too_old(name, bench)
    if skipped:
        return skipped
    s = bench.sensor
    if not s.info.capabilities & m.Capabilities.CAP_DEBUG_FAULT:
        return Row(
            name,
            SKIPPED,
            "a release image (no CAP_DEBUG_FAULT): flash a test image (firmware/README.md, "
            "bring-up) to check the watchdog",
        )
    before = s.status()
    reply = s.request_raw(m.DebugFault.TYPE_ID, m.DebugFault(kind=m.FaultKind.FAULT_HANG).pack())
    if isinstance(reply, m.Nack):
        known = reply.error in m.Error._value2member_map_
        error = m.Error(reply.error).name if known else str(reply.error)
        return Row(
            name,
            SKIPPED,
            f"DEBUG_FAULT refused ({error}): a release image; flash a test image "
            "(firmware/README.md, bring-up) to check the watchdog",
        )
    started = time.monotonic()
    st = back_after_reset(bench, int(before.uptime_ms))
    back_s = time.monotonic() - started
    found = causes(int(st.reset_cause))
    values = {"reset_cause": found, "back_after_s": round(back_s, 3)}
    if not st.reset_cause & m.ResetCause.RESET_IWDG:
        return Row(
            name,
            FAIL,
            f"after a commanded hang the board reports reset by {', '.join(found) or 'nothing'}, "
            "not the independent watchdog: is the watchdog started and fed only by the superloop?",
            values,
        )
    return Row(
        name,
        PASS,
        f"reset by the independent watchdog after a commanded hang; back "
        f"after {back_s:.1f} s (host time)",
        values,
    )


def back_after_reset(bench: Bench, uptime_ms: int) -> m.Status:
    """The first STATUS of the board's next boot (its uptime below `uptime_ms`): on the same
    link while it holds (a UART, a simulated device), else opened again (USB re-enumerates)."""
    deadline = time.monotonic() + REOPEN_S
    while True:
        try:
            status = bench.sensor.status()
            if status.uptime_ms < uptime_ms:
                return status
        except DisconnectedError:
            bench.reopen(max(0.0, deadline - time.monotonic()))
        except DeviceTimeoutError:
            pass  # hung until the watchdog bites, or still booting
        if time.monotonic() > deadline:
            raise DeviceTimeoutError(
                f"{bench.url} did not come back within {REOPEN_S:.0f} s of a commanded hang: "
                "is the independent watchdog running? (power-cycle the board)"
            )
        time.sleep(0.2)
