"""The board, part definition and pin map against hardware/datasheet_facts.toml.

The facts table is transcribed from the manufacturers' documents (VEML3328 datasheet 84968,
STM32F411 datasheet DS10314, NXP UM10204, the LED and Black Pill documents); every expected value
here comes from it or is computed from it, never from the generator. The KiCad files are read
with kiutils, so these tests run without KiCad.
"""

from __future__ import annotations

import csv
import math
import re
import tomllib
from pathlib import Path
from typing import Any

import pytest
from conftest import REPO, pad_nets, reference
from kiutils.board import Board
from kiutils.schematic import Schematic
from test_schematic import schematic_netlist

FACTS = tomllib.loads((REPO / "hardware" / "datasheet_facts.toml").read_text(encoding="utf-8"))
PART = tomllib.loads(
    (REPO / "hardware" / "definitions" / "veml3328.toml").read_text(encoding="utf-8")
)
PINMAP = tomllib.loads(
    (REPO / "hardware" / "definitions" / "stm32f411_pinmap.toml").read_text(encoding="utf-8")
)
I2C_SOURCE = (REPO / "firmware" / "ports" / "stm32f411" / "i2c.c").read_text(encoding="utf-8")
STATUSES = {"primary", "secondary", "unverified"}
COLOURS = ("R", "G", "B")


def value(section: str, key: str) -> Any:
    """The value of one fact, e.g. value("veml3328", "vdd_max")."""
    return FACTS[section][key]["value"]


def ohms(text: str) -> int:
    """A resistor value as the BOM writes it: "560", "2k2", "10k"."""
    m = re.fullmatch(r"(\d+)(?:k(\d?))?", text)
    assert m, f"unreadable resistor value {text!r}"
    if m.group(2) is None and "k" not in text:
        return int(m.group(1))
    return int(m.group(1)) * 1000 + int(m.group(2) or 0) * 100


def footprint_values(board: Board) -> dict[str, str]:
    out = {}
    for fp in board.footprints:
        for item in fp.graphicItems:
            if getattr(item, "type", None) == "value":
                out[reference(fp)] = str(item.text)
    return out


def footprints(board: Board) -> dict[str, Any]:
    return {reference(fp): fp for fp in board.footprints}


def i2c_hz() -> int:
    m = re.search(r"#define I2C_HZ (\d+)u", I2C_SOURCE)
    assert m, "firmware/ports/stm32f411/i2c.c defines I2C_HZ"
    return int(m.group(1))


def mcu_pins() -> dict[str, dict[str, Any]]:
    return {p["pin"]: p for p in FACTS["stm32f411"]["pins"]}


def led_pads() -> list[dict[str, Any]]:
    return [p for p in PINMAP["connector"]["pads"] if p["signal"].startswith("LED")]


# --- the table itself ---------------------------------------------------------------------------


def _facts_with_status() -> list[tuple[str, dict[str, Any]]]:
    found = []

    def walk(path: str, node: Any) -> None:
        if isinstance(node, dict):
            if "status" in node:
                found.append((path, node))
            for k, v in node.items():
                walk(f"{path}.{k}", v)
        elif isinstance(node, list):
            for i, v in enumerate(node):
                walk(f"{path}[{i}]", v)

    for key, node in FACTS.items():
        if key != "sources":
            walk(key, node)
    return found


def test_every_fact_names_its_source_place_and_status() -> None:
    facts = _facts_with_status()
    assert len(facts) > 40
    for path, fact in facts:
        assert fact["status"] in STATUSES, path
        assert fact["source"] in FACTS["sources"], f"{path}: unknown source {fact['source']}"
        assert fact["where"], f"{path}: say where in the source"
        if fact["status"] == "secondary":
            assert fact.get("also"), f"{path}: name the independent sources that agree"
        if fact["status"] == "unverified":
            assert fact.get("why"), f"{path}: say why it is unverified"


def test_every_source_is_identified() -> None:
    for key, src in FACTS["sources"].items():
        assert src["title"] and src["document"] and src["url"] and src["reached"], key


# --- VEML3328: part definition (driver registers) against the datasheet ----------------------


def test_part_definition_register_map_matches_datasheet() -> None:
    want = {r["name"]: r["address"] for r in FACTS["veml3328"]["registers"]}
    got = {r["name"]: r["address"] for r in PART["registers"]}
    assert got == want
    assert PART["part"]["address"] == value("veml3328", "address")
    assert PART["part"]["id_low"] == value("veml3328", "id_low")


def test_part_definition_conf_fields_match_datasheet() -> None:
    def fields(rows: list[dict[str, Any]]) -> dict[str, tuple[int, int, list[Any]]]:
        return {r["name"]: (r["bit"], r.get("width", 1), r.get("values", [])) for r in rows}

    assert fields(PART["conf"]) == fields(FACTS["veml3328"]["conf"])
    assert PART["conf_masks"]["SD"] == ["SD1", "SD0"], "shutdown needs both SD bits"


def test_conf_fields_do_not_overlap() -> None:
    used = 0
    for f in FACTS["veml3328"]["conf"]:
        mask = ((1 << f.get("width", 1)) - 1) << f["bit"]
        assert used & mask == 0, f["name"]
        used |= mask
    assert used < 1 << 16


def test_firmware_i2c_clock_within_sensor_limit() -> None:
    assert i2c_hz() <= value("veml3328", "i2c_max_hz")


def test_sensor_supply_in_datasheet_range() -> None:
    assert value("veml3328", "vdd_min") <= value("blackpill", "vdd") <= value("veml3328", "vdd_max")


# --- VEML3328 footprint and connections -----------------------------------------------------


def _sensor_net(name: str, bus: int) -> str:
    return {"GND": "GND", "VDD": "VDD", "SDA": f"SDA{bus}", "SCL": f"SCL{bus}"}[name]


@pytest.mark.parametrize("bus", [1, 2, 3])
def test_sensor_pads_are_numbered_and_placed_as_the_datasheet(board: Board, bus: int) -> None:
    fp = footprints(board)[f"U{bus}"]
    pads = {p.number: p for p in fp.pads}
    pins = FACTS["veml3328"]["pins"]
    assert set(pads) == {p["number"] for p in pins}, "one pad per package pin"
    for pin in pins:
        pad = pads[pin["number"]]
        sx, sy = pin["corner"]
        # Pad positions are in the footprint's own frame (KiCad y down, before rotation).
        assert math.copysign(1, pad.position.X) == sx, f"pin {pin['number']} x side"
        assert math.copysign(1, pad.position.Y) == sy, f"pin {pin['number']} y side"
        assert pad.net.name == _sensor_net(pin["name"], bus), f"U{bus} pin {pin['name']}"


def test_sensor_pads_fit_the_package_body(board: Board) -> None:
    length, width, _ = value("veml3328", "body_mm")
    for bus in (1, 2, 3):
        for pad in footprints(board)[f"U{bus}"].pads:
            assert abs(pad.position.X) < length / 2 and abs(pad.position.Y) < width / 2


def sensor_terminals() -> dict[str, dict[str, Any]]:
    return {t["number"]: t for t in FACTS["veml3328"]["terminals"]}


def test_sensor_terminals_sit_at_their_pins_corners_inside_the_body() -> None:
    length, width, _ = value("veml3328", "body_mm")
    terminals = sensor_terminals()
    assert set(terminals) == {p["number"] for p in FACTS["veml3328"]["pins"]}
    for pin in FACTS["veml3328"]["pins"]:
        (x, y), (w, h) = terminals[pin["number"]]["center"], terminals[pin["number"]]["size"]
        assert [math.copysign(1, x), math.copysign(1, y)] == pin["corner"], pin["number"]
        assert abs(x) + w / 2 <= length / 2 + 1e-9 and abs(y) + h / 2 <= width / 2 + 1e-9


@pytest.mark.parametrize("bus", [1, 2, 3])
def test_sensor_lands_are_the_package_terminals(board: Board, bus: int) -> None:
    # One source of truth: footprints.py builds the lands from [[veml3328.terminals]], one to
    # one; the board must carry exactly that (in the footprint's own frame, KiCad y down).
    terminals = sensor_terminals()
    for pad in footprints(board)[f"U{bus}"].pads:
        want = terminals[pad.number]
        got_at, got_size = (pad.position.X, pad.position.Y), (pad.size.X, pad.size.Y)
        assert got_at == pytest.approx(tuple(want["center"]), abs=1e-3), f"U{bus} pad {pad.number}"
        assert got_size == pytest.approx(tuple(want["size"]), abs=1e-3), f"U{bus} pad {pad.number}"


def test_schematic_connects_each_sensor_pin_as_the_datasheet(sch: Schematic) -> None:
    net = schematic_netlist(sch)
    for bus in (1, 2, 3):
        for pin in FACTS["veml3328"]["pins"]:
            assert net[(f"U{bus}", pin["number"])] == _sensor_net(pin["name"], bus)


def test_each_sensor_is_decoupled_next_to_its_supply_pins(board: Board) -> None:
    nets_of = pad_nets(board)
    fps = footprints(board)
    values = footprint_values(board)
    want_nf = value("veml3328", "decoupling_nf")
    caps = [ref for ref in fps if ref.startswith("C")]
    for bus in (1, 2, 3):
        sensor = fps[f"U{bus}"]
        across = [c for c in caps if {nets_of[(c, "1")], nets_of[(c, "2")]} == {"VDD", "GND"}]
        near = [
            c
            for c in across
            if math.dist(
                (fps[c].position.X, fps[c].position.Y), (sensor.position.X, sensor.position.Y)
            )
            <= 2.0
        ]
        assert near, f"U{bus}: no VDD-GND capacitor within 2 mm"
        assert any(values[c] == f"{want_nf}n" for c in near), f"U{bus}: {want_nf} nF"


# --- I2C pull-ups (UM10204) -------------------------------------------------------------------


def _bus_capacitance_pf() -> float:
    i2c = FACTS["i2c"]
    pins = value("i2c", "device_pin_pf") + value("stm32f411", "pin_capacitance_pf")
    cable = i2c["cable_pf_per_m"]["value"] * i2c["cable_max_m"]["value"]
    return pins + cable + i2c["board_trace_pf"]["value"]


def test_pullups_meet_rise_time_and_sink_current(board: Board) -> None:
    nets_of = pad_nets(board)
    values = footprint_values(board)
    hz = i2c_hz()
    tr_max_ns = value("i2c", "rise_time_max_ns")[str(hz)]
    cb_pf = _bus_capacitance_pf()
    assert cb_pf <= value("i2c", "cb_max_pf")
    r_max = tr_max_ns * 1e-9 / (value("i2c", "rise_time_factor") * cb_pf * 1e-12)
    r_min = (value("blackpill", "vdd") - value("i2c", "vol_max")) / (value("i2c", "iol_ma") * 1e-3)
    for bus in (1, 2, 3):
        for line in (f"SCL{bus}", f"SDA{bus}"):
            pullups = [
                ref
                for (ref, pad), net in nets_of.items()
                if ref.startswith("R")
                and net == line
                and {nets_of[(ref, "1")], nets_of[(ref, "2")]} == {"VDD", line}
            ]
            assert len(pullups) == 1, f"{line}: one pull-up to VDD"
            r = ohms(values[pullups[0]])
            assert r_min <= r <= r_max, f"{line}: {r} ohm outside [{r_min:.0f}, {r_max:.0f}]"


# --- RGB LEDs ---------------------------------------------------------------------------------


def test_the_bom_orders_the_parts_the_facts_describe() -> None:
    # The pin tables and land patterns above are only true for the exact parts ordered.
    bom_path = REPO / "hardware" / "kicad" / "spectratac-bom.csv"
    with bom_path.open(newline="", encoding="utf-8") as f:
        mpn = {row["Footprint"]: row["MPN"] for row in csv.DictReader(f)}
    assert mpn["LED_RGB_1615"] == FACTS["led"]["part"]
    assert mpn["VEML3328"] == "VEML3328"
    assert FACTS["sources"]["vishay-84968"]["document"] == "84968"


@pytest.mark.parametrize("led", [1, 2, 3])
def test_led_pads_follow_the_led_pinout(board: Board, sch: Schematic, led: int) -> None:
    sch_net = schematic_netlist(sch)
    pads = {p.number: p.net.name for p in footprints(board)[f"D{led}"].pads}
    assert FACTS["led"]["common"]["value"] == "anode"
    for pin in FACTS["led"]["pins"]:
        want = "VLED" if pin["name"] == "A" else f"LED{led}_{pin['name']}_K"
        assert pads[pin["number"]] == want, f"D{led} pin {pin['number']} ({pin['function']})"
        assert sch_net[(f"D{led}", pin["number"])] == want


def _led_resistors(board: Board) -> dict[tuple[int, str], int]:
    nets_of = pad_nets(board)
    values = footprint_values(board)
    out = {}
    for led in (1, 2, 3):
        for c in COLOURS:
            ends = {f"LED{led}_{c}", f"LED{led}_{c}_K"}
            refs = [
                ref
                for ref in values
                if ref.startswith("R") and {nets_of[(ref, "1")], nets_of[(ref, "2")]} == ends
            ]
            assert len(refs) == 1, f"LED{led} {c}: one series resistor"
            out[(led, c)] = ohms(values[refs[0]])
    return out


def test_led_current_from_forward_voltage_is_within_led_and_pin_limits(board: Board) -> None:
    vbus = value("blackpill", "vbus_max")
    design = value("led", "if_design_ma")
    limit = min(value("led", "if_max_ma"), value("stm32f411", "iio_max_ma"))
    for (led, c), r in _led_resistors(board).items():
        # Nominal: 5 V, typical V_F, the pin's worst V_OL. Worst case: highest VBUS, lowest
        # V_F and an ideal pin, the most current the die and the pin can see.
        nominal = (5.0 - value("led", "vf_typ")[c] - value("stm32f411", "vol_max")) / r * 1e3
        worst = (vbus - value("led", "vf_min")[c]) / r * 1e3
        assert 0.7 * design <= nominal <= design, f"LED{led} {c}: {nominal:.2f} mA nominal"
        assert worst <= limit, f"LED{led} {c}: {worst:.2f} mA worst case"


def test_led_cathode_pins_tolerate_the_off_state_voltage() -> None:
    pins = mcu_pins()
    vdd = value("blackpill", "vdd")
    vbus = value("blackpill", "vbus_max")
    for pad in led_pads():
        colour = pad["signal"][-1]
        fact = pins[pad["mcu"]]
        released = vbus - value("led", "vf_off")[colour]
        if fact["io"] == "FT":
            # FT limit VDD + 4.0 V, taken at VDD = 0 (5 V present before the 3.3 V rail).
            limit = value("stm32f411", "vin_max_ft_over_vdd")
        else:
            limit = vdd + value("stm32f411", "vin_max_tc_over_vdd")
        assert released <= limit, (
            f"{pad['signal']} on {pad['mcu']} ({fact['io']}): {released:.2f} V > {limit:.2f} V"
        )


# --- MCU pin choices --------------------------------------------------------------------------


def _mcu_rows() -> list[tuple[str, str, str]]:
    """(signal, MCU pin, "PERIPH_SIGNAL AFn") for every MCU pin the pin map uses."""
    rows = [
        (p["signal"], p["mcu"], p["function"])
        for p in PINMAP["connector"]["pads"]
        if re.fullmatch(r"P[A-H]\d+", p["mcu"])
    ]
    link = PINMAP["host_link"]
    rows += [(k.upper(), link[k]["mcu"], link[k]["function"]) for k in ("tx", "rx")]
    out = []
    for signal, mcu, function in rows:
        m = re.match(r"\w+ AF\d+", function)
        assert m, f"{signal}: function {function!r} does not start with 'NAME AFn'"
        out.append((signal, mcu, m.group(0)))
    return out


def test_no_signal_on_a_pin_the_black_pill_uses() -> None:
    reserved = {r["pin"]: r["use"] for r in FACTS["blackpill"]["reserved"]}
    for signal, mcu, _ in _mcu_rows():
        assert mcu not in reserved, f"{signal} on {mcu}: {reserved.get(mcu)}"


def test_every_pin_function_is_in_the_datasheet_af_table() -> None:
    pins = mcu_pins()
    for signal, mcu, function in _mcu_rows():
        assert mcu in pins, f"{signal}: {mcu} not in the facts table"
        assert function in pins[mcu]["functions"], f"{signal}: {mcu} has no {function}"


def test_each_pin_and_led_timer_channel_used_once() -> None:
    rows = _mcu_rows()
    assert len({mcu for _, mcu, _ in rows}) == len(rows)
    channels = [fn.split()[0] for s, _, fn in rows if s.startswith("LED")]
    assert len(channels) == 9 and len(set(channels)) == 9, "each die needs its own duty cycle"


def test_red_cathodes_are_on_5v_tolerant_pins() -> None:
    # The red die has the lowest V_F, so its released cathode rises highest (see the off-state
    # test); stated on its own so a pin map change cannot hide it behind the voltage numbers.
    pins = mcu_pins()
    for pad in led_pads():
        if pad["signal"].endswith("_R"):
            assert pins[pad["mcu"]]["io"] == "FT", pad["signal"]


def test_facts_file_is_the_one_the_readme_cites() -> None:
    readme = (REPO / "hardware" / "README.md").read_text(encoding="utf-8")
    assert "## Checked against datasheets" in readme
    assert "datasheet_facts.toml" in readme
    assert Path(REPO / "hardware" / "datasheet_facts.toml").is_file()
