"""The STM32F411 port's register macros, checked against ST's SVD description of the chip.

`check(sources)` parses the port's register headers (every `#define`, so a new macro is
checked without being listed anywhere), places each one — a peripheral instance and its
struct layout, a register address, a bit field, a field value, a shift or mask, an interrupt
number, a constant — and compares it with ST's `STM32F411xx.svd` (cmsis-svd 0.4) or, for the
ARMv7-M core registers and plain constants that no SVD describes, with
hardware/datasheet_facts.toml. It returns one readable problem per disagreement.

Where the SVD and the reference manual disagree, the manual wins: `MANUAL_WINS` names each case
with the manual's reference, and the checker confirms the SVD still disagrees, so an exception
that is no longer needed is reported too.
"""

from __future__ import annotations

import importlib.util
import re
import tomllib
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PORT = REPO / "firmware" / "ports" / "stm32f411"
FACTS_PATH = REPO / "hardware" / "datasheet_facts.toml"
# The headers that define registers; core_debug.h (DWT, CoreDebug) is the core's, not ST's.
REGISTER_HEADERS = ("regs.h", "flash_store.h")
SVD_IN_PACKAGE = ("data", "STMicro", "STM32F411xx.svd")


# --- the device description ------------------------------------------------------------------


@dataclass(frozen=True)
class Field:
    name: str
    offset: int
    width: int

    @property
    def mask(self) -> int:
        return ((1 << self.width) - 1) << self.offset


@dataclass(frozen=True)
class Register:
    name: str
    offset: int
    fields: Mapping[str, Field]


@dataclass(frozen=True)
class Peripheral:
    name: str
    base: int
    registers: Mapping[str, Register]  # by normalised name


@dataclass(frozen=True)
class Device:
    peripherals: Mapping[str, Peripheral]
    interrupts: Mapping[str, int]

    def register_at(self, address: int) -> tuple[Peripheral, Register] | None:
        for p in self.peripherals.values():
            for r in p.registers.values():
                if p.base + r.offset == address:
                    return p, r
        return None


def norm(name: str) -> str:
    """SVD and manual spell names differently (FS_DCTL, TxE, F_S): compare them in one form."""
    name = name.upper()
    name = name.removeprefix("FS_").removesuffix("_DEVICE")
    return name.replace("_", "")


def svd_path() -> Path:
    spec = importlib.util.find_spec("cmsis_svd")
    if spec is None or spec.origin is None:
        raise FileNotFoundError(
            "cmsis-svd 0.4 is not installed: it carries ST's STM32F411xx.svd "
            "(pip install -r requirements/lock.txt)"
        )
    path = Path(spec.origin).parent.joinpath(*SVD_IN_PACKAGE)
    if not path.is_file():
        raise FileNotFoundError(f"{path} is missing: cmsis-svd 0.4's sdist holds it, 0.6 does not")
    return path


def _int(text: str | None) -> int:
    if text is None:
        raise ValueError("missing number in the SVD")
    return int(text.strip(), 0)


def _fields(node: ET.Element) -> dict[str, Field]:
    out = {
        norm(f.findtext("name", "")): Field(
            f.findtext("name", ""), _int(f.findtext("bitOffset")), _int(f.findtext("bitWidth"))
        )
        for f in node.iter("field")
    }
    # ST splits some fields into one-bit pieces (PLLM0..PLLM5, SW0/SW1): add the whole field.
    stems: dict[str, list[Field]] = {}
    for f in out.values():
        m = re.fullmatch(r"(.*?)(\d+)", norm(f.name))
        if m and f.width == 1:
            stems.setdefault(m.group(1), []).append(f)
    for stem, parts in stems.items():
        parts.sort(key=lambda f: f.offset)
        digits = [int(re.fullmatch(r".*?(\d+)", norm(f.name)).group(1)) for f in parts]  # type: ignore[union-attr]
        contiguous = digits == list(range(len(parts))) and all(
            f.offset == parts[0].offset + i for i, f in enumerate(parts)
        )
        if stem not in out and contiguous and len(parts) > 1:
            out[stem] = Field(stem, parts[0].offset, len(parts))
    return out


def _registers(node: ET.Element) -> dict[str, Register]:
    regs = node.find("registers")
    if regs is None:
        return {}
    return {
        norm(r.findtext("name", "")): Register(
            r.findtext("name", ""), _int(r.findtext("addressOffset")), _fields(r)
        )
        for r in regs.iter("register")
    }


@cache
def svd_device(path: Path | None = None) -> Device:
    root = ET.parse(path or svd_path()).getroot()
    nodes = {p.findtext("name", ""): p for p in root.iter("peripheral")}
    peripherals = {}
    interrupts = {}
    for name, node in nodes.items():
        source = nodes[node.get("derivedFrom", name)]
        peripherals[name] = Peripheral(name, _int(node.findtext("baseAddress")), _registers(source))
        for irq in node.findall("interrupt"):
            interrupts[irq.findtext("name", "")] = _int(irq.findtext("value"))
    return Device(peripherals, interrupts)


@cache
def facts() -> dict[str, object]:
    return tomllib.loads(FACTS_PATH.read_text(encoding="utf-8"))


def core_device() -> Device:
    """SysTick and SCB as hardware/datasheet_facts.toml records them (ARMv7-M)."""
    core = facts()["armv7m"]
    assert isinstance(core, dict)
    bases: dict[str, int] = core["bases"]["value"]
    regs: dict[str, int] = core["registers"]["value"]
    fields: dict[str, list[int]] = core["fields"]["value"]
    peripherals = {}
    for pname, base in bases.items():
        registers = {}
        for key, offset in regs.items():
            p, r = key.split(".")
            if p != pname:
                continue
            fs = {
                norm(k.split(".")[2]): Field(k.split(".")[2], bit, width)
                for k, (bit, width) in fields.items()
                if k.startswith(f"{p}.{r}.")
            }
            registers[norm(r)] = Register(r, offset, fs)
        peripherals[pname] = Peripheral(pname, base, registers)
    return Device(peripherals, {})


def constants() -> dict[str, int]:
    table = facts()["stm32f411"]
    assert isinstance(table, dict)
    return {k: v["value"] for k, v in table["constants"].items()}


# --- the C side: macros and struct layouts ---------------------------------------------------


@dataclass(frozen=True)
class Macro:
    name: str
    params: tuple[str, ...] | None  # None: object-like
    body: str
    file: str


@dataclass(frozen=True)
class Address:
    """What REG32(...) evaluates to."""

    value: int


@dataclass(frozen=True)
class Instance:
    """A `((type *)address)` peripheral instance."""

    struct: str
    base: int


def strip_comments(text: str) -> str:
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    return re.sub(r"//[^\n]*", "", text)


def parse_macros(text: str, file: str) -> dict[str, Macro]:
    text = strip_comments(text).replace("\\\n", " ")
    out = {}
    for m in re.finditer(r"^[ \t]*#[ \t]*define[ \t]+(\w+)(\(([^)]*)\))?[ \t]*(.*)$", text, re.M):
        params = None if m.group(2) is None else tuple(p.strip() for p in m.group(3).split(","))
        out[m.group(1)] = Macro(m.group(1), params, m.group(4).strip(), file)
    return out


def parse_structs(text: str) -> dict[str, list[tuple[str, int]]]:
    """typedef'd register structs: type -> [(field name, offset)], reserved words dropped."""
    out = {}
    for m in re.finditer(r"typedef struct \w*\s*\{(.*?)\}\s*(\w+);", strip_comments(text), re.S):
        if not m.group(1).strip().startswith("volatile uint32_t"):
            continue  # not a register block
        offset = 0
        fields = []
        for decl in m.group(1).split(";"):
            decl = decl.replace("volatile", "").replace("uint32_t", "").strip()
            for item in filter(None, (d.strip() for d in decl.split(","))):
                am = re.fullmatch(r"(\w+)(?:\[(\d+)\])?", item)
                if am is None:
                    raise ValueError(f"unreadable struct member {item!r} in {m.group(2)}")
                count = int(am.group(2) or 1)
                if not am.group(1).startswith("RES"):
                    for i in range(count):
                        name = am.group(1) if am.group(2) is None else f"{am.group(1)}[{i}]"
                        fields.append((name, offset + 4 * i))
                offset += 4 * count
        out[m.group(2)] = fields
    return out


def evaluate(
    body: str, macros: Mapping[str, Macro], args: Mapping[str, int] | None = None
) -> int | Address | Instance:
    """The value of a macro body: an integer, a REG32 address or a struct instance."""
    cast = re.fullmatch(r"\(\(\s*(\w+_t)\s*\*\s*\)\s*(.+)\)", body)
    if cast:
        base = evaluate(cast.group(2), macros, args)
        if not isinstance(base, int):
            raise ValueError(f"{body}: the cast's address is not a number")
        return Instance(cast.group(1), base)
    args = args or {}

    def ident(m: re.Match[str]) -> str:
        word = m.group(0)
        if re.fullmatch(r"(0[xX][0-9a-fA-F]+|\d+)[uUlL]*", word):
            return str(int(re.sub(r"[uUlL]+$", "", word), 0))
        if word in args:
            return f"({args[word]})"
        if word == "REG32":
            return word
        macro = macros.get(word)
        if macro is None:
            raise KeyError(f"{word} is not defined")
        if macro.params is not None:
            return word  # a call; expanded below
        inner = evaluate(macro.body, macros)
        if isinstance(inner, Address):
            return f"REG32({inner.value})"
        if isinstance(inner, Instance):
            raise ValueError(f"{word} is an instance, not a number")
        return f"({inner})"

    expr = re.sub(r"\b\w+\b", ident, body)
    expr = expr.replace("/", "//")

    def call(name: str) -> Callable[..., int | Address]:
        macro = macros[name]
        assert macro.params is not None
        params = macro.params

        def run(*values: int) -> int | Address:
            value = evaluate(macro.body, macros, dict(zip(params, values, strict=True)))
            if isinstance(value, Instance):
                raise ValueError(f"{name}(...) is an instance, not a number")
            return value

        return run

    env: dict[str, object] = {"__builtins__": {}, "REG32": lambda a: Address(a & 0xFFFFFFFF)}
    env.update({n: call(n) for n, m in macros.items() if m.params is not None and n != "REG32"})
    value = eval(expr, env)  # the repository's own headers: digits and operators
    if isinstance(value, int):
        return value & 0xFFFFFFFF
    if isinstance(value, Address):
        return value
    raise ValueError(f"{body}: not an integer expression")


# --- what the SVD cannot settle: the manual's word, aliases, classification -----------------


@dataclass(frozen=True)
class ManualField:
    offset: int
    width: int
    reference: str


@dataclass(frozen=True)
class ManualRegister:
    address: Callable[[int], int]  # n -> address (n ignored for plain registers)
    reference: str


# The SVD and RM0383 disagree, or the SVD leaves something out: the manual wins. The checker
# verifies each against the value here and confirms the SVD still differs.
MANUAL_WINS_FIELDS: dict[str, ManualField] = {
    "OTG_GCCFG_NOVBUSSENS": ManualField(
        21,
        1,
        "RM0383 §22.16.2 OTG_FS_GCCFG bit 21 NOVBUSSENS (VBUS sensing disable); "
        "absent from the SVD",
    ),
}
MANUAL_WINS_REGISTERS: dict[str, ManualRegister] = {
    "OTG_GRXSTSP": ManualRegister(
        lambda n: 0x50000020,
        "RM0383 §22.16.2 OTG_FS_GRXSTSP (status read and pop) at offset 0x020; the SVD has only "
        "GRXSTSR (read, 0x01C), with the same fields",
    ),
    "OTG_FIFO": ManualRegister(
        lambda n: 0x50001000 + 0x1000 * n,
        "RM0383 §22.16.1 OTG_FS CSR memory map: data FIFO n push/pop at 0x1000 * (n + 1); the SVD "
        "describes no FIFO windows",
    ),
}
MANUAL_WINS_STRUCT_MEMBERS: dict[tuple[str, str], ManualField] = {
    ("i2c_t", "FLTR"): ManualField(
        0x24,
        32,
        "RM0383 §18.6.10 I2C_FLTR (analog/digital noise filter) at offset 0x24; "
        "absent from the SVD",
    ),
}
MANUAL_WINS_INTERRUPTS: dict[str, tuple[int, str]] = {
    "USART1_IRQN": (
        37,
        "RM0383 interrupts and events chapter, vector table: USART1 global interrupt at "
        "position 37; the SVD lists no USART1 interrupt",
    ),
}
# Reset values the firmware relies on, where the SVD's is wrong (SVD reset values are known to
# be unreliable). (peripheral, register) -> (manual's reset value, reference).
MANUAL_WINS_RESET: dict[tuple[str, str], tuple[int, str]] = {
    ("PWR", "CR"): (0x00008000, "RM0383 §5.4.1 PWR_CR reset value 0x0000 8000: VOS = 10, scale 2"),
}

# Instance macros whose SVD peripheral has another name.
INSTANCE_NAMES = {"FLASH_REGS": "FLASH", "OTG_FS_BASE": "OTG_FS_GLOBAL", "SYSTICK": "SYSTICK"}
# Macro prefix -> the peripherals it describes (besides instances named PREFIX...).
PREFIX_PERIPHERALS = {
    "OTG": ("OTG_FS_GLOBAL", "OTG_FS_DEVICE", "OTG_FS_PWRCLK"),
    "FLASH": ("FLASH",),
    "SCB": ("SCB",),
    "NVIC": ("NVIC",),
    "DBG": ("DBG",),
    "SYSCFG": ("SYSCFG",),
}
# Register names the macros use for a register the SVD names otherwise, or for several
# registers with one layout (the endpoint registers): macro name -> SVD names (normalised).
REGISTER_ALIASES = {
    "CCMR1": ("CCMR1OUTPUT",),
    "CCMR2": ("CCMR2OUTPUT",),
    "AFR[0]": ("AFRL",),
    "AFR[1]": ("AFRH",),
    "GINT": ("GINTSTS",),  # GINTSTS and GINTMSK share bit positions
    "EPCTL": ("DIEPCTL1", "DOEPCTL1"),
    "EPINT": ("DIEPINT1", "DOEPINT1"),
    "TSIZ": ("DIEPTSIZ1", "DOEPTSIZ1"),
    "DOEPINT": ("DOEPINT0",),
    "GRXSTSP": ("GRXSTSRDEVICE", "GRXSTSR"),
    "DIEPTXF0": ("GNPTXFSIZ",),  # RM0383: OTG_FS_DIEPTXF0 in device mode, HNPTXFSIZ in host mode
    "DIEPTXF": ("DIEPTXF1", "DIEPTXF2", "DIEPTXF3"),
}
# Field names the macros take from RM0383 where the SVD spells them otherwise.
FIELD_ALIASES = {
    ("GAHBCFG", "GINTMSK"): "GINT",
    ("EPCTL", "SD0PID"): "SD0PIDSEVNFRM",
    ("DAINTMSK", "OEPM"): "OEPINT",  # ST's SVD reuses DAINT's name for the mask's half
}
# Macros that are codes of a field rather than masks: macro prefix -> (register, field).
FIELD_CODES = {"OTG_PKTSTS": ("GRXSTSP", "PKTSTS")}
# Function-like register macros and the indices the port uses.
INDEX_RANGES = {
    "OTG_DIEPTXF": range(1, 4),
    "OTG_FIFO": range(0, 4),
    "NVIC_ISER": range(0, 3),  # 86 interrupts: three words
    "NVIC_ISPR": range(0, 3),
    "NVIC_IPR": range(0, 20),  # 86 interrupts: 22 words, the SVD lists the first 20
}
# Macros that are not registers, with why.
NOT_REGISTERS = {
    "REG32": "the register accessor itself",
    "STM32F411_REGS_H": "include guard",
    "STM32F411_FLASH_STORE_H": "include guard",
    "FLASH_STORE_ADDR": "the store's place in the flash memory map (test_store_layout.py)",
    "FLASH_STORE_SIZE": "the store's size (tests/firmware/test_store_layout.py)",
    "FLASH_STORE_SECTORS": "a count",
    "FLASH_ERASE64K_TIMEOUT_US": "a timing bound",
    "FLASH_ERASE128K_TIMEOUT_US": "a timing bound",
    "FLASH_WORD_TIMEOUT_US": "a timing bound",
}


# --- the checker ------------------------------------------------------------------------------


@dataclass
class Checker:
    macros: dict[str, Macro]
    structs: dict[str, list[tuple[str, int]]]
    device: Device
    problems: list[str] = field(default_factory=list)
    checked: list[str] = field(default_factory=list)

    def fail(self, macro: str, text: str) -> None:
        self.problems.append(f"{macro} ({self.macros[macro].file}): {text}")

    # peripherals the macro prefix can mean
    def peripherals_for(self, prefix: str) -> list[Peripheral]:
        names = list(PREFIX_PERIPHERALS.get(prefix, ()))
        for name, m in self.macros.items():
            if m.params is None and name.startswith(prefix) and name not in names:
                try:
                    value = evaluate(m.body, self.macros)
                except (KeyError, ValueError):
                    continue
                if isinstance(value, Instance):
                    names.append(INSTANCE_NAMES.get(name, name))
        return [self.device.peripherals[n] for n in names if n in self.device.peripherals]

    def registers_named(self, peripherals: Iterable[Peripheral], name: str) -> list[Register]:
        wanted = REGISTER_ALIASES.get(name, (norm(name),))
        return [p.registers[w] for p in peripherals for w in wanted if w in p.registers]

    def check_instance(self, name: str, inst: Instance) -> None:
        pname = INSTANCE_NAMES.get(name, name)
        periph = self.device.peripherals.get(pname)
        if periph is None:
            self.fail(name, f"no peripheral {pname} in the SVD or the core facts")
            return
        if periph.base != inst.base:
            self.fail(name, f"base {inst.base:#010x}, but {pname} is at {periph.base:#010x}")
        layout = self.structs.get(inst.struct)
        if layout is None:
            self.fail(name, f"struct {inst.struct} not found")
            return
        for member, offset in layout:
            manual = MANUAL_WINS_STRUCT_MEMBERS.get((inst.struct, member))
            regs = self.registers_named([periph], member)
            if "[" in member and not regs:
                base, index = member[:-1].split("[")
                regs = self.registers_named([periph], f"{base}{int(index) + 1}")
            if manual is not None:
                if regs:
                    self.fail(
                        name,
                        f"{member}: the SVD now has it; drop the exception ({manual.reference})",
                    )
                elif offset != manual.offset:
                    self.fail(
                        name, f"{member} at +{offset:#x}, the manual says +{manual.offset:#x}"
                    )
                continue
            if not regs:
                self.fail(
                    name, f"{inst.struct}.{member} (+{offset:#x}): no such register in {pname}"
                )
            elif regs[0].offset != offset:
                self.fail(
                    name,
                    f"{inst.struct}.{member} at +{offset:#x}, but {pname}.{regs[0].name} is at "
                    f"+{regs[0].offset:#x}",
                )

    def check_address(self, name: str, reg_name: str, address: int) -> None:
        found = self.device.register_at(address)
        if found is None:
            self.fail(name, f"no register at {address:#010x}")
            return
        periph, reg = found
        wanted = REGISTER_ALIASES.get(reg_name, (norm(reg_name),))
        if norm(reg.name) not in wanted:
            self.fail(name, f"{address:#010x} is {periph.name}.{reg.name}, not {reg_name}")

    def check_register_macro(self, name: str, prefix: str, rest: str) -> None:
        macro = self.macros[name]
        indices = INDEX_RANGES.get(name, range(0, 4)) if macro.params else [None]
        for n in indices:
            body_value = (
                evaluate(f"{name}({n})", self.macros)
                if n is not None
                else evaluate(macro.body, self.macros)
            )
            assert isinstance(body_value, Address)
            manual = MANUAL_WINS_REGISTERS.get(name)
            if manual is not None:
                if body_value.value != manual.address(n or 0):
                    self.fail(
                        name,
                        f"at {body_value.value:#010x}, "
                        f"the manual says {manual.address(n or 0):#010x}",
                    )
                elif (
                    self.device.register_at(body_value.value) is not None and name != "OTG_GRXSTSP"
                ):
                    self.fail(
                        name, f"the SVD now describes {body_value.value:#010x}; drop the exception"
                    )
                continue
            self.check_address(name, rest if n is None else f"{rest}{n}", body_value.value)

    def resolve_field(
        self, regs: list[Register], reg_name: str, tokens: list[str]
    ) -> tuple[list[Field], str | None]:
        """The field the tokens name in these registers, and its qualifier (SHIFT, MASK, a code)."""
        for cut, qualifier in ((len(tokens), None), (len(tokens) - 1, tokens[-1])):
            if cut < 1:
                continue
            fname = norm("_".join(tokens[:cut]))
            fname = FIELD_ALIASES.get((reg_name, fname), fname)
            found = [
                r.fields[c]
                for r in regs
                for c in (fname, fname + "EN", fname + "RST")
                if c in r.fields
            ]
            if found:
                return found, qualifier
        return [], None

    def check_field_macro(self, name: str, value: int, prefix: str, tokens: list[str]) -> None:
        peripherals = self.peripherals_for(prefix)
        if not peripherals:
            self.fail(name, f"no peripheral for the prefix {prefix}")
            return
        for cut in range(1, len(tokens)):
            reg_name = "_".join(tokens[:cut])
            regs = self.registers_named(peripherals, reg_name)
            if regs:
                break
        else:
            self.fail(name, f"no register {tokens[0]} in {', '.join(p.name for p in peripherals)}")
            return
        rest = tokens[cut:]
        manual = MANUAL_WINS_FIELDS.get(name)
        fields, qualifier = self.resolve_field(regs, reg_name, rest)
        if manual is not None:
            if fields:
                self.fail(
                    name, f"the SVD now has this field; drop the exception ({manual.reference})"
                )
            fields, qualifier = [Field("_".join(rest), manual.offset, manual.width)], None
        if not fields:
            self.fail(
                name, f"no field {'_'.join(rest)} in {reg_name} ({', '.join(r.name for r in regs)})"
            )
            return
        for f in fields:
            if qualifier == "SHIFT":
                ok, want = value == f.offset, f"{f.offset}"
            elif qualifier == "MASK":
                ok, want = value == f.mask, f"{f.mask:#x}"
            elif qualifier is None:
                ok, want = (
                    value == f.mask,
                    f"{f.mask:#x} (bits {f.offset}..{f.offset + f.width - 1})",
                )
            else:
                ok = value != 0 and value & ~f.mask == 0
                want = f"a code inside {f.mask:#x} (bits {f.offset}..{f.offset + f.width - 1})"
            if not ok:
                self.fail(name, f"{value:#x}, but {reg_name}.{f.name} wants {want}")

    def check_code_macro(self, name: str, value: int, reg_name: str, field_name: str) -> None:
        regs = self.registers_named(self.peripherals_for("OTG"), reg_name)
        fields = [r.fields[norm(field_name)] for r in regs if norm(field_name) in r.fields]
        if not fields:
            self.fail(name, f"no field {reg_name}.{field_name}")
        elif not 0 <= value < 1 << fields[0].width:
            self.fail(
                name, f"code {value} does not fit {reg_name}.{field_name} ({fields[0].width} bits)"
            )

    def check_interrupt(self, name: str, value: int) -> None:
        manual = MANUAL_WINS_INTERRUPTS.get(name)
        svd_name = name.removesuffix("_IRQN")
        if manual is not None:
            if svd_name in self.device.interrupts:
                self.fail(name, f"the SVD now lists {svd_name}; drop the exception ({manual[1]})")
            if value != manual[0]:
                self.fail(name, f"{value}, the manual says {manual[0]}")
            return
        want = self.device.interrupts.get(svd_name)
        if want is None:
            self.fail(name, f"no interrupt {svd_name} in the SVD")
        elif want != value:
            self.fail(name, f"{value}, but the SVD numbers {svd_name} {want}")

    def run(self) -> list[str]:
        table = constants()
        for name, macro in self.macros.items():
            if name in NOT_REGISTERS:
                continue
            try:
                value = evaluate(macro.body, self.macros) if macro.params is None else None
            except (KeyError, ValueError, SyntaxError) as exc:
                self.fail(name, f"cannot evaluate {macro.body!r}: {exc}")
                continue
            self.checked.append(name)
            prefix, _, rest = name.partition("_")
            if name in table:
                if value != table[name]:
                    self.fail(name, f"{value:#x}, but datasheet_facts.toml says {table[name]:#x}")
                if not rest.startswith("KR_"):
                    continue
            if isinstance(value, Instance):
                self.check_instance(name, value)
            elif name in INSTANCE_NAMES:
                periph = self.device.peripherals[INSTANCE_NAMES[name]]
                if value != periph.base:
                    self.fail(name, f"{value:#x}, but {periph.name} is at {periph.base:#010x}")
            elif name.endswith("_IRQN"):
                assert isinstance(value, int)
                self.check_interrupt(name, value)
            elif macro.params is not None or isinstance(value, Address):
                self.check_register_macro(name, prefix, rest)
            elif re.fullmatch(r"\(?\s*\w+(\s*\|\s*\w+)+\s*\)?", macro.body) and all(
                w in self.checked for w in re.findall(r"\w+", macro.body)
            ):
                continue  # an OR of macros that are checked themselves
            elif any(name.startswith(p + "_") for p in FIELD_CODES):
                code_prefix = next(p for p in FIELD_CODES if name.startswith(p + "_"))
                assert isinstance(value, int)
                self.check_code_macro(name, value, *FIELD_CODES[code_prefix])
            elif name in table:
                continue
            else:
                assert isinstance(value, int)
                self.check_field_macro(name, value, prefix, rest.split("_"))
        return self.problems


def load_sources(texts: Mapping[str, str] | None = None) -> dict[str, str]:
    """The register headers' text by file name (a caller may pass edited copies)."""
    if texts is not None:
        return dict(texts)
    return {name: (PORT / name).read_text(encoding="utf-8") for name in REGISTER_HEADERS}


def check(texts: Mapping[str, str] | None = None, device: Device | None = None) -> list[str]:
    """Every problem found in the register headers (default: the port's own)."""
    sources = load_sources(texts)
    macros: dict[str, Macro] = {}
    structs: dict[str, list[tuple[str, int]]] = {}
    for file, text in sources.items():
        macros.update(parse_macros(text, file))
        structs.update(parse_structs(text))
    svd = device or svd_device()
    merged = Device({**svd.peripherals, **core_device().peripherals}, svd.interrupts)
    return Checker(macros, structs, merged).run()
