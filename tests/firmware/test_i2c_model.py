"""The port's real i2c.c and gpio.c against a register-level model of the F411's I2C master.

tests/firmware/i2c/i2c_model.c compiles the driver natively (ASan, UBSan), maps the peripherals'
bus addresses without access rights and answers each register access as the chip would: SB,
ADDR, BTF, RXNE, TXE, the error flags and BUSY, CR1's START/STOP/ACK/POS/SWRST, SR1-then-SR2
and SR1-then-DR clearing, with a VEML3328 on each bus and the pads' line levels. QEMU has no
I2C, so this is where recovery from NACK, spurious BERR, arbitration loss, a slave holding SDA
and a late interrupt runs before a board does. Time there is simulated.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest

from .regs_svd import PORT, REPO

pytestmark = [pytest.mark.firmware, pytest.mark.subprocess]  # compiles and runs the model

MODEL_C = REPO / "tests" / "firmware" / "i2c" / "i2c_model.c"
CORE = REPO / "firmware" / "core"
RUN_TIMEOUT_S = 120  # the model stops a driver that waits for more than 2 s of bus time
OK, NACK, TIMEOUT = 0, 1, 2
TIMEOUT_US = 2000  # what the model's transfers pass
# A clean transfer takes ~120 us of bus time; one that needed a bus clear or a second attempt
# takes longer. Simulated time counts register accesses, so it does not vary between runs.
CLEAN_US = 150


def build(out: Path, i2c_c: Path = PORT / "i2c.c", gpio_c: Path = PORT / "gpio.c") -> Path:
    gcc = shutil.which("gcc")
    assert gcc, "gcc is needed to build the I2C model (apt install gcc)"
    cmd = [gcc, "-std=c11", "-O1", "-g", "-Wall", "-Wextra", "-Werror"]
    cmd += ["-Wno-int-to-pointer-cast", "-fsanitize=address,undefined", "-fno-sanitize-recover"]
    cmd += [f"-I{PORT}", f"-I{CORE}", str(MODEL_C), str(i2c_c), str(gpio_c), "-o", str(out)]
    done = subprocess.run(cmd, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return out


@dataclass(frozen=True)
class Run:
    code: int
    rc: list[int]
    elapsed_us: list[int]
    data: list[list[int]]
    lines: dict[str, list[str]]
    violations: list[str]
    text: str


def run(binary: Path, scenario: str) -> Run:
    done = subprocess.run(
        [str(binary), scenario], capture_output=True, text=True, timeout=RUN_TIMEOUT_S
    )
    text = done.stdout + done.stderr
    assert done.returncode in (0, 1), f"the model could not run the driver: {text}"
    assert "runtime error" not in text and "AddressSanitizer" not in text, text
    lines: dict[str, list[str]] = {}
    for line in done.stdout.splitlines():
        key, _, rest = line.partition(" ")
        lines.setdefault(key, []).append(rest)
    return Run(
        done.returncode,
        [int(v) for v in lines.get("rc", [])],
        [int(v) for v in lines.get("elapsed_us", [])],
        [[int(b, 16) for b in v.split()] for v in lines.get("data", [])],
        lines,
        re.findall(r"^violation: (.*)$", done.stdout, re.M),
        text,
    )


@pytest.fixture(scope="module")
def model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build(tmp_path_factory.mktemp("i2c") / "i2c_model")


def test_reads_and_writes_a_veml3328(model: Path) -> None:
    r = run(model, "plain")
    assert r.violations == [] and r.code == 0, r.text
    # ID (0x0028), CONF written 0x0008 and read back, then a one-byte read of ID's low byte
    assert r.rc == [OK] * 4
    assert r.data == [[0x28, 0x00], [0x08, 0x00], [0x28]]


def test_an_absent_sensor_nacks_and_the_bus_stays_usable(model: Path) -> None:
    r = run(model, "nack")
    assert r.violations == [], r.text
    assert r.rc == [NACK, OK] and r.data == [[0x28, 0x00]], r.text


def test_a_spurious_bus_error_is_cleared_and_the_transfer_goes_on(model: Path) -> None:
    """ES0287: BERR in master mode can be raised by mistake and does not affect the transfer."""
    r = run(model, "berr")
    assert r.violations == [], r.text
    assert r.rc == [OK, OK], r.text
    assert r.data == [[0x08, 0x00]], "the write and the read after it both went through"
    assert max(r.elapsed_us) < CLEAN_US, f"continued, not reset and retried: {r.elapsed_us}"


def test_arbitration_lost_is_retried(model: Path) -> None:
    r = run(model, "arlo")
    assert r.violations == [], r.text
    assert r.rc == [OK] and r.data == [[0x28, 0x00]], r.text


def test_a_sensor_holding_sda_at_boot_is_clocked_free_at_init(model: Path) -> None:
    """A reset in the middle of a read leaves the sensor driving a 0 bit: BUSY stays set until
    SCL is clocked. The first transfer after i2c_init_all must already work (else the sensor
    is reported absent at the boot probe)."""
    r = run(model, "sda-stuck-at-init")
    assert r.violations == [], r.text
    assert r.rc == [OK] and r.data == [[0x28, 0x00]], r.text
    assert r.elapsed_us[0] < CLEAN_US, "the bus was already clear when the transfer began"


def test_busy_stuck_between_transfers_is_cleared_within_the_transfer(model: Path) -> None:
    r = run(model, "sda-stuck-later")
    assert r.violations == [], r.text
    assert r.rc == [OK, OK], r.text
    assert r.elapsed_us[1] < TIMEOUT_US, "cleared well inside the transfer's own bound"


def test_an_interrupt_after_addr_cannot_make_the_two_byte_read_late(model: Path) -> None:
    """RM0383's two-byte read: ACK must be cleared after ADDR and before the first byte's
    acknowledge pulse; a 100-us interrupt in between makes the master acknowledge the second
    byte, the sensor goes on sending, the STOP cannot happen and the bus is stuck."""
    r = run(model, "irq-after-addr")
    assert r.violations == [], r.text
    assert r.rc == [OK, OK], r.text
    assert r.data == [[0x01, 0x80], [0x28, 0x00]]


def test_a_held_clock_line_times_out_within_the_bound(model: Path) -> None:
    r = run(model, "scl-stuck")
    assert r.violations == [], r.text
    assert r.rc == [TIMEOUT], r.text
    # the bound, plus at most one bus clear (~0.1 ms)
    assert r.elapsed_us[0] <= TIMEOUT_US + 300, r.text


def test_filters_on_and_configured_while_disabled(model: Path) -> None:
    r = run(model, "config")
    assert r.violations == [], r.text  # CCR/TRISE/FLTR written only with PE = 0
    fltr = [int(v) for v in r.lines["fltr"][0].split()]
    # analog filter on (ANOFF = 0) and a digital filter of ~100 ns at APB1 = 48 MHz
    assert fltr == [4, 4, 4], r.text


def test_led_pins_switch_at_low_slew(model: Path) -> None:
    r = run(model, "config")
    speeds = dict(v.split() for v in r.lines["ospeed"])
    leds = {k: int(v) for k, v in speeds.items() if k.startswith("LED")}
    assert len(leds) == 9 and set(leds.values()) == {0}, leds
    assert int(speeds["SCL1"]) == 2 and int(speeds["SDA1"]) == 2, "I2C keeps fast edges"


IRQ_MASKED = (
    "        const uint32_t primask = irq_save();\n"
    "        (void)i2c->SR2;\n"
    "        i2c->CR1 &= ~I2C_CR1_ACK; /* with POS: NACK the second byte */\n"
    "        irq_restore(primask);\n"
)
MUTATIONS = [
    # (what the driver no longer does, its text, the text instead, the scenario that then fails)
    (
        "mask interrupts from ADDR clear to ACK clear",
        IRQ_MASKED,
        "        (void)i2c->SR2;\n        i2c->CR1 &= ~I2C_CR1_ACK;\n",
        "irq-after-addr",
    ),
    (
        "clear a spurious BERR and go on",
        "            i2c->SR1 = ~I2C_SR1_BERR; /* rc_w0: only BERR is cleared */\n",
        "            return STAC_I2C_BUS_ERROR;\n",
        "berr",
    ),
    (
        "clear the bus at init",
        "        recover(b);\n",
        "        i2c_setup(k_i2c[b]);\n",
        "sda-stuck-at-init",
    ),
    (
        "retry after arbitration lost",
        "            i2c->SR1 = ~I2C_SR1_ARLO;\n            rc = STAC_I2C_BUS_ERROR;\n",
        "            return STAC_I2C_BUS_ERROR;\n",
        "arlo",
    ),
]


@pytest.mark.parametrize(
    ("what", "old", "new", "scenario"), MUTATIONS, ids=[m[0] for m in MUTATIONS]
)
def test_the_model_catches_a_driver_without_the_step(
    tmp_path: Path, what: str, old: str, new: str, scenario: str
) -> None:
    source = (PORT / "i2c.c").read_text(encoding="utf-8")
    assert source.count(old) == 1, f"i2c.c no longer contains the step to remove: {old!r}"
    broken = tmp_path / "i2c.c"
    broken.write_text(source.replace(old, new), encoding="utf-8")
    r = run(build(tmp_path / "i2c_model", i2c_c=broken), scenario)
    slow = scenario in ("berr", "sda-stuck-at-init") and max(r.elapsed_us) >= CLEAN_US
    assert r.violations or any(rc != OK for rc in r.rc) or slow, f"{what}: {r.text}"
