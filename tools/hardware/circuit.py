"""The board's circuit as data: parts, where they sit, and which net each pad carries.

Both the PCB generator (pcbnew) and the schematic writer (kiutils) read this, so the two KiCad
files describe one netlist. Stdlib only (imported by Debian's python3 and by the venv).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .params import Geometry, load_pinmap

# Bottom-side connector: pad angles grouped by the part they serve, so that every trace from a
# pad runs radially inward to its own sector. Sensor k gets SCL at -20°, SDA at +20° around its
# angle and one supply pad on its axis; LED j gets R, G, B at -20°, 0°, +20° around its angle.
SUPPLY_ON_SENSOR = ("VDD", "GND", "VLED")
LED_COLOURS = ("R", "G", "B")
# Electrical values, each checked by tests/hardware/test_datasheet_facts.py against
# hardware/datasheet_facts.toml (which names the document, table and page of every value).
VLED_VOLTS = 5.0  # Black Pill 5V pin = USB VBUS (<= 5.25 V, USB 2.0 section 7.2.1)
LED_MA = 5.0  # per die: bright enough for the 50 ms integration, far below the die's 20 mA
# Typical V_F at 5 mA of a 1615 RGB LED (facts: led.vf_typ, unverified: the XL-1615RGBC
# datasheet was not reachable) and the open-drain pin's drop at 5 mA (below the 0.4 V V_OL max
# at 8 mA of DS10314 section 6.3.16).
LED_VF = {"R": 2.0, "G": 2.9, "B": 2.9}
PIN_DROP = 0.2
E12 = (100, 120, 150, 180, 220, 270, 330, 390, 470, 560, 680, 820)
# UM10204 section 7.1: R_p <= t_r / (0.8473 C_b) with t_r <= 300 ns at 400 kHz (Table 10), so
# 2.2 kOhm allows up to 160 pF per line (a 10 pF sensor pin, a 5 pF MCU pin, traces and
# 30 cm of cable: ~50 pF); R_p >= (3.3 V - 0.4 V) / 3 mA = 967 Ohm keeps V_OL within the
# 3 mA sink rating (Table 9).
PULLUP_OHMS = 2200
# 100 nF X7R at each VEML3328's VDD pin (facts: veml3328.decoupling_nf; Vishay's application
# circuits for the VEML family).
DECOUPLING = "100n"
# VEML3328 pads (facts: veml3328.pins): 1 GND, 2 SDA, 3 SCL, 4 VDD, datasheet 84968 pin
# description, as also in an independent KiCad part citing it. LED pads (facts: led.pins):
# 1 common anode, 2 R, 3 G, 4 B cathodes; unverified, check the drawing of the part ordered.
SENSOR_PINS = {"1": "GND", "2": "SDA", "3": "SCL", "4": "VDD"}


@dataclass(frozen=True)
class Part:
    ref: str
    value: str
    footprint: str  # key of tools/hardware/footprints.FOOTPRINTS
    side: str  # "top" or "bottom"
    radius: float  # from the board centre, mm
    angle: float  # position angle, degrees CCW seen from the top
    rotation: float  # footprint rotation, degrees CCW seen from the top
    pins: dict[str, str]  # pad number -> net name
    mpn: str
    description: str
    dnp: bool = field(default=False)


def e12_at_least(ohms: float) -> int:
    """Smallest E12 value >= ohms, so the LED current never exceeds LED_MA."""
    decade = 1
    while True:
        for base in E12:
            if base * decade >= ohms:
                return base * decade
        decade *= 10


def led_resistor(colour: str) -> int:
    return e12_at_least((VLED_VOLTS - LED_VF[colour] - PIN_DROP) / (LED_MA / 1000.0))


def uniohm_0402(ohms: int) -> str:
    """UniOhm 0402 1 % part number: three significant digits and a power-of-ten digit."""
    exp = 0
    while ohms >= 1000 * 10**exp:
        exp += 1
    return f"0402WGF{ohms // 10**exp:03d}{exp}TCE"


def format_ohms(ohms: int) -> str:
    return f"{ohms // 1000}k{(ohms % 1000) // 100 or ''}" if ohms >= 1000 else str(ohms)


def connector_layout(geo: Geometry) -> dict[str, float]:
    """Signal name -> pad angle (degrees, top view) on the connector ring."""
    angles: dict[str, float] = {}
    for k, a in enumerate(geo.sensor_angles):
        angles[f"SCL{k + 1}"] = (a - 20.0) % 360.0
        angles[SUPPLY_ON_SENSOR[k]] = a % 360.0
        angles[f"SDA{k + 1}"] = (a + 20.0) % 360.0
    for j, a in enumerate(geo.led_angles):
        for c, offset in zip(LED_COLOURS, (-20.0, 0.0, 20.0), strict=True):
            angles[f"LED{j + 1}_{c}"] = (a + offset) % 360.0
    return angles


def parts(geo: Geometry) -> list[Part]:
    out: list[Part] = []
    r = geo.ring_radius
    for k, a in enumerate(geo.sensor_angles):
        bus = k + 1
        out.append(Part(f"U{bus}", "VEML3328", "VEML3328", "top", r, a, a,
                        {pad: f"{name}{bus}" if name in ("SDA", "SCL") else name
                         for pad, name in SENSOR_PINS.items()},
                        "VEML3328", f"RGBCIR colour sensor {k}, I2C bus {bus} (address 0x10)"))
    for j, a in enumerate(geo.led_angles):
        n = j + 1
        pins = {"1": "VLED"} | {str(i + 2): f"LED{n}_{c}_K" for i, c in enumerate(LED_COLOURS)}
        out.append(Part(f"D{n}", "RGB_CA", "LED_RGB_1615", "top", r, a, a, pins,
                        "XL-1615RGBC", f"RGB LED {j}, common anode"))
    # Bottom side: decoupling right under each sensor, pull-ups inboard of it, LED resistors
    # under each LED, so that every part is a via away from the pad it serves.
    for k, a in enumerate(geo.sensor_angles):
        bus = k + 1
        out.append(Part(f"C{bus}", DECOUPLING, "C_0402", "bottom", r, a, a + 90.0,
                        {"1": "VDD", "2": "GND"}, "CL05B104KO5NNNC",
                        f"100 nF X7R decoupling, sensor {k}"))
        for i, (sig, offset) in enumerate((("SCL", -14.0), ("SDA", 14.0))):
            out.append(Part(f"R{2 * k + i + 1}", format_ohms(PULLUP_OHMS), "R_0402", "bottom",
                            3.6, (a + offset) % 360.0, a + offset,
                            {"1": "VDD", "2": f"{sig}{bus}"}, uniohm_0402(PULLUP_OHMS),
                            f"I2C pull-up, {sig}{bus}"))
    for j, a in enumerate(geo.led_angles):
        n = j + 1
        for i, (c, offset) in enumerate(zip(LED_COLOURS, (-16.0, 0.0, 16.0), strict=True)):
            ohms = led_resistor(c)
            out.append(Part(f"R{7 + 3 * j + i}", format_ohms(ohms), "R_0402", "bottom", r,
                            (a + offset) % 360.0, a + offset,
                            {"1": f"LED{n}_{c}", "2": f"LED{n}_{c}_K"}, uniohm_0402(ohms),
                            f"LED {j} {c} series resistor ({LED_MA:g} mA)"))
    pinmap = load_pinmap()
    out.append(Part("J1", "SENSOR_LINK", "SensorLink_18pad", "bottom", 0.0, 0.0, 0.0,
                    {str(pad): row["signal"] for pad, row in sorted(pinmap.items())},
                    "", "18 solder pads to the Black Pill (hardware/definitions/"
                    "stm32f411_pinmap.toml)"))
    return out


def nets(geo: Geometry) -> list[str]:
    """Every net name, sorted, as the PCB and the schematic must both carry them."""
    return sorted({net for p in parts(geo) for net in p.pins.values()})
