"""`spectratac bringup` against the STM32F411 image in QEMU: the parts QEMU can run pass, and
what QEMU lacks fails or is skipped with the reason a person would read on a broken board.

QEMU's netduinoplus2 models no VEML3328 (every sensor absent: the sensor check fails naming
them, the LED and TRIG checks skip), no flash controller (the model store check fails with the
device's NACK) and no cycle counter (the clock check skips). Its device clock counts
instructions (-icount, conftest.py), not host time, so the clock-drift verdict and the
brown-out level (option bytes QEMU does not model) are not asserted. The rest (identity, reset
cause, the sample rate at every integration time, a soak with nothing lost) must pass.
"""

from __future__ import annotations

from spectratac.conformance.bringup import FAIL, PASS, SKIPPED, plan, postmortem, run_bringup
from spectratac.conformance.bringup.bench import Bench

QEMU_LIMITED = {"clock drift", "brown-out level"}
EXPECTED = {
    "identity": PASS,
    "clock": SKIPPED,
    "reset cause and fault record": PASS,
    "sensors": FAIL,
    "TRIG latency": SKIPPED,
    "sample rate": PASS,
    "LED channels": SKIPPED,
    "model store": FAIL,
    "soak": PASS,
    "watchdog": SKIPPED,  # the UART image is a release image: DEBUG_FAULT is not compiled in
    "fault record": SKIPPED,
}


def test_bringup_against_qemu_image(qemu_port: int) -> None:
    report = run_bringup(f"socket://127.0.0.1:{qemu_port}", timeout=5.0, soak_s=2.0)
    rows = {r.name: r for r in report.rows}
    assert list(rows) == [name for name, _ in plan()]
    verdicts = {name: r.verdict for name, r in rows.items() if name not in QEMU_LIMITED}
    assert verdicts == EXPECTED, {n: rows[n].detail for n in verdicts if verdicts[n] != EXPECTED[n]}
    assert report.device["board"] == "blackpill-f411"
    assert "sensors 0, 1, 2 did not answer" in rows["sensors"].detail
    assert (
        "FLASH_ERROR" in rows["model store"].detail or "BOR_TOO_LOW" in rows["model store"].detail
    )
    rates = rows["sample rate"].values["rates"]
    assert [r["integration_ms"] for r in rates] == [50, 100, 200, 400]
    soak = rows["soak"].values
    assert soak["samples"] == soak["expected"] and soak["crc_errors"] == soak["sequence_gaps"] == 0


def test_the_fault_record_checks_against_qemu_test_image(qemu_test_port: int) -> None:
    """The test image takes DEBUG_FAULT: the fault-record check passes (QEMU models the fault
    registers, SYSRESETREQ and SRAM kept across the reset), and the next bring-up's reset-cause
    check fails on the record, as it would on a board that faulted. FAULT_HANG is not run:
    QEMU has no independent watchdog, so the hang would never end (a board test)."""
    url = f"socket://127.0.0.1:{qemu_test_port}"
    bench = Bench.open(url, 5.0)
    try:
        row = postmortem.fault_record(bench)
    finally:
        bench.sensor.close()
    assert row.verdict == PASS, row.detail
    assert "UNDEFINSTR" in row.values["fault_flags"] and "FORCED" in row.values["fault_flags"]
    again = Bench.open(url, 5.0)
    try:
        row = postmortem.reset_cause(again)
    finally:
        again.sensor.close()
    assert row.verdict == FAIL and "a fault record: PC 0x08" in row.detail, row.detail
