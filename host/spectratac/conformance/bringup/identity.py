"""The board's identity and clock: INFO's versions and unit id, STATUS's `cycle_hz` (the
96 MHz PLL from the 25 MHz crystal, or one of the internal RC's fallbacks: the PLL from it at
the same 96 MHz, which only the boot LOG tells apart, or the raw 16 MHz)."""

from __future__ import annotations

from spectratac.conformance.bringup.bench import Bench
from spectratac.conformance.bringup.report import FAIL, PASS, SKIPPED, Row
from spectratac.protocol.generated import messages as m
from spectratac.protocol.versions import expected_definition_hash

#: the core clock the firmware sets up: 25 MHz crystal x PLL (firmware/docs/stm32f411.md)
PLL_HZ = 96_000_000
#: the internal RC oscillator the firmware falls back to when the PLL fails from both sources
HSI_HZ = 16_000_000
#: how the boot LOG (ports/stm32f411/clock.c, clock_note) begins when the crystal failed and
#: the PLL runs from the internal RC: the same 96 MHz, so STATUS alone cannot tell
HSI_PLL_LOG = "clock HSI+PLL"
#: what to look at when the crystal did not start
CRYSTAL_ADVICE = (
    "Check the crystal and its two load capacitors (reflow them), that the board is a 25 MHz "
    "WeAct Black Pill, and power it from a supply that holds 3.3 V"
)
#: cycle_hz is a constant of the firmware's clock set-up, so any difference is a different clock
CLOCK_TOLERANCE = 0.001


def device_facts(bench: Bench) -> dict[str, object]:
    """INFO in the report's `device` section: who this board is."""
    i = bench.sensor.info
    return {
        "protocol": bench.version,
        "firmware": ".".join(map(str, i.firmware_version)),
        "build_id": i.build_id,
        "board": i.board,
        "unit_id": bytes(i.device_uid).hex(),
        "definition_hash": f"0x{i.definition_hash:08X}",
        "capabilities": [c.name for c in m.Capabilities if i.capabilities & c],
        "sensor_present": [k for k in range(3) if i.sensor_present >> k & 1],
        "baud": i.baud,
    }


def identity(bench: Bench) -> Row:
    i, facts = bench.sensor.info, device_facts(bench)
    expected = expected_definition_hash(i.protocol_minor)
    problems = []
    if i.protocol_major != m.PROTOCOL_MAJOR:
        problems.append(f"protocol major {i.protocol_major}, this host speaks {m.PROTOCOL_MAJOR}")
    if expected is not None and expected != i.definition_hash:
        problems.append(
            f"definition hash {facts['definition_hash']}, protocol {bench.version} defines "
            f"0x{expected:08X}: the firmware was built from other message definitions; "
            "rebuild and flash it from this checkout (make firmware)"
        )
    said = (
        f"firmware {facts['firmware']} ({i.build_id or 'no build id'}), protocol "
        f"{bench.version}, board {i.board!r}, unit {facts['unit_id']}"
    )
    values = dict(facts, expected_hash=None if expected is None else f"0x{expected:08X}")
    return Row("identity", FAIL if problems else PASS, "; ".join([*problems, said]), values)


def clock(bench: Bench) -> Row:
    status = bench.first_status
    if status is None or not bench.speaks(2):
        return Row(
            "clock", SKIPPED, f"STATUS cycle_hz is protocol 1.2; the device speaks {bench.version}"
        )
    hz = int(status.cycle_hz)
    fallback = next((t for t in bench.boot_logs if t.startswith(HSI_PLL_LOG)), None)
    values = {"cycle_hz": hz, "expected_hz": PLL_HZ, "boot_log": fallback}
    if hz == 0:
        return Row(
            "clock",
            SKIPPED,
            "the device counts no cycles (cycle_hz 0): a simulated device, or a core whose "
            "cycle counter does not run (QEMU)",
            values,
        )
    if abs(hz - PLL_HZ) <= PLL_HZ * CLOCK_TOLERANCE and fallback is not None:
        return Row(
            "clock",
            FAIL,
            f"{hz / 1e6:.1f} MHz from the PLL, but on the internal RC (HSI): the 25 MHz crystal "
            f"(HSE) did not start (boot LOG: {fallback!r}). USB is off on this clock; the UART "
            f"keeps its speed. {CRYSTAL_ADVICE}",
            values,
        )
    if abs(hz - PLL_HZ) <= PLL_HZ * CLOCK_TOLERANCE:
        return Row(
            "clock",
            PASS,
            f"{hz / 1e6:.1f} MHz: the PLL runs from the crystal (the boot LOG names the HSI "
            "fallback to the first host after a reset: run bring-up first after one)",
            values,
        )
    if abs(hz - HSI_HZ) <= HSI_HZ * CLOCK_TOLERANCE:
        return Row(
            "clock",
            FAIL,
            f"{hz / 1e6:.1f} MHz: the HSI fallback, so the 25 MHz crystal (HSE) did not start "
            "and the PLL did not lock from the internal RC either. USB is off on this clock and "
            f"the UART is 2.1 % off speed. {CRYSTAL_ADVICE}",
            values,
        )
    return Row(
        "clock",
        FAIL,
        f"{hz / 1e6:.3f} MHz: neither the {PLL_HZ / 1e6:.0f} MHz PLL nor the "
        f"{HSI_HZ / 1e6:.0f} MHz fallback; the firmware's clock set-up differs from this "
        "host's (flash a firmware from this checkout)",
        values,
    )
