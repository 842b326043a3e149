"""The board's identity and clock: INFO's versions and unit id, STATUS's `cycle_hz` (the
96 MHz PLL from the 25 MHz crystal, or the 16 MHz internal fallback)."""

from __future__ import annotations

from spectratac.conformance.bringup.bench import Bench
from spectratac.conformance.bringup.report import FAIL, PASS, SKIPPED, Row
from spectratac.protocol.generated import messages as m
from spectratac.protocol.versions import expected_definition_hash

#: the core clock the firmware sets up: 25 MHz crystal x PLL (firmware/docs/stm32f411.md)
PLL_HZ = 96_000_000
#: the internal RC oscillator the firmware falls back to when the crystal or PLL fails
HSI_HZ = 16_000_000
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
    values = {"cycle_hz": hz, "expected_hz": PLL_HZ}
    if hz == 0:
        return Row(
            "clock",
            SKIPPED,
            "the device counts no cycles (cycle_hz 0): a simulated device, or a core whose "
            "cycle counter does not run (QEMU)",
            values,
        )
    if abs(hz - PLL_HZ) <= PLL_HZ * CLOCK_TOLERANCE:
        return Row("clock", PASS, f"{hz / 1e6:.1f} MHz: the PLL runs from the crystal", values)
    if abs(hz - HSI_HZ) <= HSI_HZ * CLOCK_TOLERANCE:
        return Row(
            "clock",
            FAIL,
            f"{hz / 1e6:.1f} MHz: the HSI fallback, so the 25 MHz crystal (HSE) did not start "
            "or the PLL did not lock. USB is off on this clock and the UART is 2.1 % off "
            "speed. Check the crystal and its two load capacitors (reflow them), that the board "
            "is a 25 MHz WeAct Black Pill, and power it from a supply that holds 3.3 V",
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
