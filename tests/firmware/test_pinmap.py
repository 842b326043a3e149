"""The STM32 port's pin table (firmware/ports/stm32f411/board.h, generated from pinmap.toml by
tools/codegen) matches pinmap.toml, the single source of truth the KiCad board is also checked
against: same MCU pin, alternate function, peripheral instance and timer channel for every
connector signal and the host link, in the order the port's drivers index. The drift test in
tests/protocol/test_codegen.py checks that board.h is what the generator writes; this one checks
that what it writes means what pinmap.toml says."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PINMAP = REPO / "firmware" / "ports" / "stm32f411" / "pinmap.toml"
BOARD_H = REPO / "firmware" / "ports" / "stm32f411" / "board.h"

ROW = re.compile(
    r'\{"(?P<signal>\w+)", \'(?P<port>[AB])\', (?P<pin>\d+), (?P<af>\d+), (?P<role>PIN_\w+), '
    r"(?P<unit>\d+), (?P<channel>\d+)\}"
)
FUNCTION = re.compile(
    r"(?P<periph>I2C|TIM|USART)(?P<unit>\d)_(?P<what>SCL|SDA|TX|RX|CH(?P<ch>\d)) AF(?P<af>\d+)"
)


def port_table() -> dict[str, dict[str, str]]:
    return {m["signal"]: m.groupdict() for m in ROW.finditer(BOARD_H.read_text())}


def expected() -> dict[str, tuple[str, int, int, int, int]]:
    """signal -> (port, pin, af, unit, channel) from pinmap.toml."""
    data = tomllib.loads(PINMAP.read_text())
    link = data["host_link"]
    rows = [(pad["signal"], pad["mcu"], pad["function"]) for pad in data["connector"]["pads"]]
    rows += [(name.upper(), link[name]["mcu"], link[name]["function"]) for name in ("tx", "rx")]
    out: dict[str, tuple[str, int, int, int, int]] = {}
    for signal, mcu, function in rows:
        if not re.fullmatch(r"P[AB]\d+", mcu):
            continue  # supplies and ground
        fn = FUNCTION.search(function)
        assert fn, f"{signal}: cannot read function {function!r}"
        out[signal] = (mcu[1], int(mcu[2:]), int(fn["af"]), int(fn["unit"]), int(fn["ch"] or 0))
    return out


def test_port_pins_match_pinmap() -> None:
    table = port_table()
    want = expected()
    assert set(table) == set(want), "board.h and pinmap.toml name different signals"
    for signal, (port, pin, af, unit, channel) in want.items():
        row = table[signal]
        got = (row["port"], int(row["pin"]), int(row["af"]), int(row["unit"]), int(row["channel"]))
        assert got == (port, pin, af, unit, channel), f"{signal}: port {got} != pinmap {want}"


def test_roles_follow_signal_names() -> None:
    for signal, row in port_table().items():
        role = row["role"]
        if signal.startswith("SCL"):
            assert role == "PIN_I2C_SCL" and int(row["unit"]) == int(signal[-1])
        elif signal.startswith("SDA"):
            assert role == "PIN_I2C_SDA" and int(row["unit"]) == int(signal[-1])
        elif signal.startswith("LED"):
            assert role == "PIN_LED"
        else:
            assert role in {"PIN_UART_TX", "PIN_UART_RX"}


def test_led_order_matches_driver_indexing() -> None:
    """pwm.c finds LED j colour c at BOARD_LED_FIRST + 3j + c: the table order must agree."""
    names = list(port_table())
    first = int(re.search(r"#define BOARD_LED_FIRST (\d+)u", BOARD_H.read_text())[1])
    count = int(re.search(r"#define BOARD_PIN_COUNT (\d+)u", BOARD_H.read_text())[1])
    assert count == len(names)
    leds = [f"LED{j + 1}_{c}" for j in range(3) for c in "RGB"]
    assert names[first : first + 9] == leds
    # Sensor k's bus pins sit at 2k (SCL) and 2k+1 (SDA) for the bus-clear code in i2c.c.
    assert names[:6] == ["SCL1", "SDA1", "SCL2", "SDA2", "SCL3", "SDA3"]


def test_board_constants_come_from_pinmap() -> None:
    data = tomllib.loads(PINMAP.read_text())
    text = BOARD_H.read_text()
    assert f'#define BOARD_NAME "{data["board"]["name"]}"' in text
    assert f"#define BOARD_BAUD {data['host_link']['baud']}u" in text
    assert f"#define BOARD_HSE_HZ {data['board']['hse_hz']}u" in text
    assert f"#define BOARD_PWM_HZ {data['board']['pwm_hz']}u" in text
