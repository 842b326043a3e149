"""Post-mortem under QEMU (-M netduinoplus2): a fault injected into the test image
(DEBUG_FAULT, env blackpill_uart_test) is reported by the next boot, a release image refuses
the command, and ENTER_BOOTLOADER reaches the jump into the ROM bootloader.

What QEMU can show and what it cannot: its Cortex-M4 models the fault status registers, the
stacked frame and SYSRESETREQ, and a system reset keeps SRAM, so the fault record's whole path
runs (handler, .noinit record, reset, boot report, STATUS and LOG). Its STM32 has no RCC reset
flags (RCC_CSR reads 0, so reset_cause shows only RESET_FAULT) and no independent watchdog, so
FAULT_HANG never resets there (a board test: firmware/README.md, bring-up), and no system
memory at 0x1FFF0000: the jump to the ROM bootloader faults on it, which the next boot reports
- the proof the request reached the jump.
"""

from __future__ import annotations

import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from spectratac.protocol.generated import messages as m

from .test_stm32 import IO_TIMEOUT_S, Board, get_info
from .test_stm32 import board as board  # the release image's fixture, re-exported here

pytestmark = [pytest.mark.firmware, pytest.mark.subprocess, pytest.mark.qemu]

CFSR_UNDEFINSTR = 1 << 16
HFSR_FORCED = 1 << 30
CFSR_BFARVALID = 1 << 15
SYSTEM_MEMORY = 0x1FFF_0000


@pytest.fixture
def test_board(qemu_test_port: int) -> Iterator[Board]:
    b = Board(qemu_test_port)
    yield b
    b.link.close()


def until_answered(board: Board) -> list[m.Message]:
    """GET_INFO until the rebooted board answers: every message up to its INFO (the boot LOG
    comes with the first answer)."""
    seen: list[m.Message] = []
    deadline = time.monotonic() + IO_TIMEOUT_S
    while time.monotonic() < deadline:
        board.link.write(b"\x00")
        board.send(m.GetInfo())
        seen += [f.message for f in board.frames(0.3)]
        if any(isinstance(msg, m.Info) for msg in seen):
            return seen
    raise AssertionError(f"the board never answered after the reset: {seen}")


def status(board: Board) -> m.Status:
    board.send(m.GetStatus())
    return board.wait_for("STATUS")[0].message


def function_at(elf: Path, address: int) -> str:
    """The function of `elf` that holds `address` (arm-none-eabi-addr2line)."""
    out = subprocess.run(
        ["arm-none-eabi-addr2line", "-f", "-e", str(elf), hex(address)],
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    ).stdout
    return out.splitlines()[0]


def test_injected_hardfault_is_reported_after_the_reset(
    test_board: Board, test_image: Path
) -> None:
    info = get_info(test_board)
    assert info.capabilities & m.Capabilities.CAP_DEBUG_FAULT
    before = status(test_board)
    assert not before.reset_cause & m.ResetCause.RESET_FAULT and before.fault_pc == 0
    seq = test_board.send(m.DebugFault(kind=m.FaultKind.FAULT_HARD))
    ack, _ = test_board.wait_for("ACK")
    assert (ack.message.acked_type, ack.message.acked_seq) == (m.DebugFault.TYPE_ID, seq)
    log = [msg for msg in until_answered(test_board) if isinstance(msg, m.Log)]
    after = status(test_board)
    assert after.reset_cause & m.ResetCause.RESET_FAULT
    assert after.fault_cfsr & CFSR_UNDEFINSTR, hex(after.fault_cfsr)
    assert after.fault_hfsr & HFSR_FORCED, hex(after.fault_hfsr)
    assert after.fault_xpsr & 0x1FF == 3  # caught by the HardFault handler
    assert function_at(test_image, after.fault_pc) == "hal_debug_fault"
    assert after.abnormal_resets == 1 and after.safe_mode == 0
    assert after.uptime_ms < before.uptime_ms + 60_000  # a fresh boot's uptime
    assert after.bor_level == 3  # QEMU's flash interface reads 0: BOR_LEV 00 is level 3
    errors = [e.text for e in log if e.level == m.LogLevel.LOG_ERROR]
    assert errors == [f"reset fault pc={after.fault_pc:08X} cfsr={after.fault_cfsr:08X}"], log
    # QEMU's board has no RCC (no crystal, no PLL from either source): the clock fell back to
    # the raw HSI, and the boot LOG says which path ran and the UART's error (16 MHz / 17)
    warnings = [e.text for e in log if e.level == m.LogLevel.LOG_WARN]
    assert "clock HSI 16MHz (PLL failed): no USB, UART +2.12%" in warnings


def test_three_faults_in_a_row_boot_in_safe_mode(test_board: Board) -> None:
    get_info(test_board)
    for n in (1, 2, 3):
        test_board.send(m.DebugFault(kind=m.FaultKind.FAULT_HARD))
        test_board.wait_for("ACK")
        get_info(test_board)
        after = status(test_board)
        assert after.abnormal_resets == n
        assert after.safe_mode == (n >= 3)
    test_board.send(m.GetModel())
    model = test_board.wait_for("MODEL_INFO")[0].message
    assert model.present == 0


def test_release_image_refuses_debug_fault(board: Board) -> None:
    info = get_info(board)
    assert not info.capabilities & m.Capabilities.CAP_DEBUG_FAULT
    assert info.capabilities & m.Capabilities.CAP_BOOTLOADER
    seq = board.send(m.DebugFault(kind=m.FaultKind.FAULT_HARD))
    nack, _ = board.wait_for("NACK")
    assert (nack.message.rejected_seq, nack.message.error) == (seq, m.Error.NOT_A_TEST_IMAGE)
    assert status(board).fault_pc == 0  # and it is still running, unharmed


def test_enter_bootloader_reaches_the_rom_jump(board: Board, image: Path) -> None:
    get_info(board)
    seq = board.send(m.EnterBootloader())
    ack, _ = board.wait_for("ACK")
    assert ack.message.acked_seq == seq
    get_info(board)  # QEMU has no ROM there: the jump faulted, the board rebooted
    after = status(board)
    assert after.reset_cause & m.ResetCause.RESET_FAULT
    assert function_at(image, after.fault_pc) == "start_rom_bootloader", hex(after.fault_pc)
