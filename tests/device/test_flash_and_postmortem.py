"""Protocol 1.4 on the host side against the simulated device (a test image with a ROM
bootloader): `spectratac flash` asks a running board into DFU and then runs dfu-util (fakes
that record what they were asked stand in for dfu-util and openocd), DEBUG_FAULT's reset is
reported by STATUS and `spectratac info`, and the typed refusals of a device that cannot."""

from __future__ import annotations

import json
import stat
from pathlib import Path

import pytest
from spectratac.cli import main
from spectratac.cli.exit_codes import ExitCode
from spectratac.device import MissingCapabilityError, Sensor
from spectratac.device.errors import DeviceTimeoutError
from spectratac.protocol.generated import messages as m

SIM = "sim://?scene=idle&seed=1&speed=max"


def fake_tool(tmp_path: Path, name: str, stdout: str, code: int = 0) -> tuple[Path, Path]:
    """An executable that appends its arguments to a log and prints `stdout`."""
    log = tmp_path / f"{name}.log"
    tool = tmp_path / name
    tool.write_text(f"#!/bin/sh\necho \"$@\" >> '{log}'\nprintf '%s\\n' '{stdout}'\nexit {code}\n")
    tool.chmod(tool.stat().st_mode | stat.S_IXUSR)
    return tool, log


@pytest.fixture
def image(tmp_path: Path) -> Path:
    path = tmp_path / "firmware.bin"
    path.write_bytes(bytes(range(256)) * 8)
    return path


def test_flash_enters_dfu_by_command_then_downloads(
    tmp_path: Path, image: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    dfu, log = fake_tool(tmp_path, "dfu-util", "Found DFU: [0483:df11] ver=2200, devnum=7")
    args = ["flash", str(image), "--device", SIM, "--dfu-util", str(dfu), "--json"]
    assert main(args) == ExitCode.OK
    out = json.loads(capsys.readouterr().out)
    assert out["steps"][0].endswith("restarted in its ROM bootloader (ENTER_BOOTLOADER)")
    calls = log.read_text().splitlines()
    assert calls[0] == "-l"  # waited for the bootloader on USB first
    assert calls[-1] == f"-d 0483:df11 -a 0 -s 0x08000000:leave -D {image}"


def test_flash_gives_up_when_no_bootloader_appears(tmp_path: Path, image: Path) -> None:
    dfu, log = fake_tool(tmp_path, "dfu-util", "No DFU capable USB device available")
    args = ["flash", str(image), "--device", SIM, "--dfu-util", str(dfu), "--dfu-wait", "0.3"]
    assert main(args) == ExitCode.ERROR
    assert "-D" not in log.read_text()  # nothing was written


def test_flash_reports_a_failed_download(
    tmp_path: Path, image: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    dfu, _ = fake_tool(tmp_path, "dfu-util", "dfu-util: Cannot open DFU device 0483:df11", 74)
    assert main(["flash", str(image), "--dfu-util", str(dfu)]) == ExitCode.ERROR
    assert "Cannot open DFU device" in capsys.readouterr().err


def test_set_bor_programs_and_reads_back_level_3(tmp_path: Path) -> None:
    ocd, log = fake_tool(tmp_path, "openocd", "stm32f2x user_options 0x0E0")
    assert main(["flash", "--set-bor", "--openocd", str(ocd)]) == ExitCode.OK
    assert "stm32f2x options_write 0 0xE0" in log.read_text()
    wrong, _ = fake_tool(tmp_path, "openocd-old", "stm32f2x user_options 0x0EC")
    assert main(["flash", "--set-bor", "--openocd", str(wrong)]) == ExitCode.ERROR


def test_sim_reports_an_injected_fault_after_its_reset(capsys: pytest.CaptureFixture[str]) -> None:
    with Sensor.open(SIM) as s:
        assert s.boot_report().reset_cause == m.ResetCause.RESET_POWER | m.ResetCause.RESET_PIN
        s.debug_fault(m.FaultKind.FAULT_HARD)
        report = s.boot_report()
        assert report.fault_present and report.fault["cfsr"] & 1 << 16  # UNDEFINSTR
        assert report.abnormal_resets == 1 and not report.safe_mode
        s.debug_fault(m.FaultKind.FAULT_HANG)
        s.debug_fault(m.FaultKind.FAULT_HANG)
        report = s.boot_report()
        assert report.causes == ["pin", "iwdg"] and report.safe_mode
        assert report.abnormal_resets == 3


def test_info_prints_the_boot_report(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", SIM, "--json"]) == ExitCode.OK
    boot = json.loads(capsys.readouterr().out)["boot"]
    assert boot["reported"] and boot["causes"] == ["pin", "power"]
    assert boot["bor_level"] == 3 and boot["uploads_allowed"] and boot["fault"] is None
    assert main(["info", SIM]) == ExitCode.OK
    out = capsys.readouterr().out
    assert "reset cause      pin, power (0 abnormal resets in a row)" in out
    assert "brown-out level  3 (2.7 V)" in out


def test_sim_goes_silent_in_its_bootloader() -> None:
    with Sensor.open(SIM, timeout=0.5) as s:
        s.enter_bootloader()
        with pytest.raises(DeviceTimeoutError):
            s.status()


def test_commands_refused_without_the_capability() -> None:
    """A release image (no CAP_DEBUG_FAULT): refused on the host, nothing sent."""
    with Sensor.open(SIM) as s:
        release = s.info.capabilities & ~m.Capabilities.CAP_DEBUG_FAULT
        object.__setattr__(s.info, "capabilities", release)  # as a release image reports
        received = s.status().rx_frames
        with pytest.raises(MissingCapabilityError, match="flash a test image"):
            s.debug_fault(m.FaultKind.FAULT_HARD)
        assert s.status().rx_frames == received + 1  # only the second GET_STATUS arrived
