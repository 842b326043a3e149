"""Render the simulator library's C ABI from hardware/definitions/sim_abi.toml: the C header
(firmware/ports/native/generated/stac_sim.h) and the ctypes declarations
(host/spectratac/sim/generated/native_abi.py), so the two sides of the ABI cannot disagree.

The definition writes declarations as in C ("const uint8_t *wr", "uint32_t next[3]"); this
module knows how each C type crosses ctypes: in a call from Python a `const uint8_t *` takes
bytes (c_char_p) and a writable buffer is an address (c_void_p), while a callback receives
indexable pointers (POINTER(c_uint8)).
"""

from __future__ import annotations

import re
import textwrap
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]
DEFINITION = REPO / "hardware" / "definitions" / "sim_abi.toml"
WIDTH = 100

#: C integer type -> (ctypes name, NumPy dtype code, size in bytes)
INTEGERS = {
    "uint8_t": ("c_uint8", "u1", 1),
    "uint16_t": ("c_uint16", "<u2", 2),
    "uint32_t": ("c_uint32", "<u4", 4),
    "uint64_t": ("c_uint64", "<u8", 8),
    "int32_t": ("c_int32", "<i4", 4),
}
DECLARATION = re.compile(
    r"^(?P<const>const\s+)?(?P<base>\w+)\s*(?P<pointer>\*)?\s*(?P<name>\w+)(?P<dims>(\[\d+\])*)$"
)


class AbiDefinitionError(ValueError):
    """The ABI definition cannot be rendered (the message names the item and what to fix)."""


@dataclass(frozen=True)
class Decl:
    """One C declaration: a parameter or a structure field."""

    name: str
    base: str
    const: bool = False
    pointer: bool = False
    dims: tuple[int, ...] = ()
    doc: str = ""

    @classmethod
    def parse(cls, text: str, doc: str = "") -> Decl:
        m = DECLARATION.match(text.strip())
        if m is None:
            raise AbiDefinitionError(
                f"cannot read declaration {text!r}: write it as in C, e.g. 'const uint8_t *wr'"
            )
        dims = tuple(int(n) for n in re.findall(r"\[(\d+)\]", m["dims"]))
        return cls(m["name"], m["base"], bool(m["const"]), bool(m["pointer"]), dims, doc.strip())

    def c(self) -> str:
        const = "const " if self.const else ""
        star = "*" if self.pointer else ""
        return f"{const}{self.base} {star}{self.name}" + "".join(f"[{n}]" for n in self.dims)


@dataclass(frozen=True)
class Item:
    """One entry of the definition, in header order."""

    kind: str
    raw: dict[str, Any]

    @property
    def name(self) -> str:
        return str(self.raw.get("name", ""))

    @property
    def doc(self) -> str:
        return str(self.raw.get("doc", "")).strip()

    def params(self) -> list[Decl]:
        return [Decl.parse(p) for p in self.raw.get("params", [])]

    def fields(self) -> list[Decl]:
        return [Decl.parse(f["decl"], f.get("doc", "")) for f in self.raw.get("fields", [])]


@dataclass(frozen=True)
class Abi:
    prefix: str
    guard: str
    api_macro: str
    doc: str
    items: tuple[Item, ...]

    def of_kind(self, kind: str) -> list[Item]:
        return [i for i in self.items if i.kind == kind]

    def named(self, kind: str) -> dict[str, Item]:
        return {i.name: i for i in self.of_kind(kind)}


KINDS = ("constant", "section", "function_type", "struct", "opaque", "function")


def load(path: Path = DEFINITION) -> Abi:
    raw = tomllib.loads(path.read_text(encoding="utf-8"))
    items = []
    for n, entry in enumerate(raw.get("items", [])):
        if entry.get("kind") not in KINDS:
            raise AbiDefinitionError(
                f"{path.name}: item {n} ({entry.get('name', '?')}) has kind "
                f"{entry.get('kind')!r}; use one of {', '.join(KINDS)}"
            )
        items.append(Item(entry["kind"], entry))
    a = raw["abi"]
    abi = Abi(a["prefix"], a["guard"], a["api_macro"], a["doc"].strip(), tuple(items))
    for struct in abi.of_kind("struct"):
        if "size" in struct.raw:
            _check_layout(struct)
    return abi


def _check_layout(struct: Item) -> None:
    """Natural alignment without implicit padding, and the declared size: then the C struct
    and the NumPy dtype (which never pads) have the same layout."""
    offset, align = 0, 1
    for f in struct.fields():
        if f.pointer or f.base not in INTEGERS:
            raise AbiDefinitionError(f"{struct.name}.{f.name}: only integer fields have a layout")
        size = INTEGERS[f.base][2]
        if offset % size:
            raise AbiDefinitionError(
                f"{struct.name}.{f.name} at offset {offset} would be padded to {size}-byte "
                f"alignment: add an explicit reserved field before it"
            )
        count = 1
        for n in f.dims:
            count *= n
        offset += size * count
        align = max(align, size)
    if offset % align or offset != struct.raw["size"]:
        raise AbiDefinitionError(
            f"{struct.name}: fields take {offset} bytes (alignment {align}), the definition says "
            f"{struct.raw['size']}: fix the fields or the size"
        )


# --- C --------------------------------------------------------------------------------------

BANNER_C = """\
/* GENERATED by tools/codegen/generate.py from hardware/definitions/sim_abi.toml. Do not edit
 * by hand: change the definition and run `make regen` (a test fails if this file drifts). */
"""


def _comment(text: str, indent: str = "") -> list[str]:
    """A block comment: `/* text */` on one line when it fits, else one line per source line."""
    lines = text.strip().splitlines()
    if len(lines) == 1 and len(indent) + len(lines[0]) + 6 <= WIDTH:
        return [f"{indent}/* {lines[0]} */"]
    out = [f"{indent}/* {lines[0]}"]
    out += [f"{indent} *" + (f" {line}" if line else "") for line in lines[1:]]
    out[-1] += " */"
    return out


def _call(head: str, params: list[str], tail: str, indent: str = "") -> list[str]:
    """`head(p1, p2, ...)tail`, wrapped at WIDTH with continuation lines under the first param."""
    first = indent + head + "("
    pieces = [p + ", " for p in params[:-1]] + [(params[-1] if params else "void") + ")" + tail]
    lines = [first]
    for piece in pieces:
        if lines[-1] != first and len(lines[-1]) + len(piece.rstrip()) > WIDTH:
            lines.append(" " * len(first))
        lines[-1] += piece
    return [line.rstrip() for line in lines]


def _with_trailing(code: str, doc: str, indent: str) -> list[str]:
    """A declaration with its doc as a trailing comment when that fits, else the doc above."""
    if not doc:
        return [indent + code]
    one = f"{indent}{code} /* {doc} */"
    if "\n" not in doc and len(one) <= WIDTH:
        return [one]
    return [*_comment(doc, indent), indent + code]


def _render_field(abi: Abi, f: Decl) -> list[str]:
    types = abi.named("function_type")
    if f.base not in types:
        return _with_trailing(f.c() + ";", f.doc, "    ")
    ft = types[f.base]  # a function pointer member, written out in place
    code = _call(f"{ft.raw['returns']} (*{f.name})", [p.c() for p in ft.params()], ";", "    ")
    return [*_comment(f.doc, "    "), *code] if f.doc else code


def _render_item(abi: Abi, item: Item) -> list[str]:
    """The C lines of one item (without the blank line that may separate it)."""
    above = _comment(item.doc) if item.doc else []
    if item.kind == "section":
        return above
    if item.kind == "constant":
        v = int(item.raw["value"])
        literal = (f"0x{v:04X}" if item.raw.get("hex") else str(v)) + (
            "" if item.raw.get("signed") else "u"
        )
        return _with_trailing(f"#define {abi.prefix.upper()}_{item.name} {literal}", item.doc, "")
    if item.kind == "opaque":
        return _with_trailing(f"typedef struct {item.raw['tag']} {item.name};", item.doc, "")
    if item.kind == "function_type":
        params = [p.c() for p in item.params()]
        return above + _call(f"typedef {item.raw['returns']} (*{item.name})", params, ";")
    if item.kind == "function":
        params = [p.c() for p in item.params()]
        return above + _call(f"{abi.api_macro} {item.raw['returns']} {item.name}", params, ";")
    out = [*above, f"typedef struct {item.raw['tag']} {{"]
    for n, f in enumerate(item.fields()):
        lines = _render_field(abi, f)
        out += ["", *lines] if n > 0 and len(lines) > 1 else lines
    out.append(f"}} {item.name};")
    if "size" in item.raw:
        out += [
            "#ifndef __cplusplus",
            f"_Static_assert(sizeof({item.name}) == {item.raw['size']}u, "
            f'"{item.name} layout is part of the ABI");',
            "#endif",
        ]
    return out


def render_header(abi: Abi) -> str:
    out = [
        BANNER_C.rstrip("\n"),
        *_comment(abi.doc),
        f"#ifndef {abi.guard}",
        f"#define {abi.guard}",
        "",
        "#include <stdint.h>",
        "",
        "#ifdef __cplusplus",
        'extern "C" {',
        "#endif",
        "",
        "#if defined(__GNUC__)",
        f'#define {abi.api_macro} __attribute__((visibility("default")))',
        "#else",
        f"#define {abi.api_macro}",
        "#endif",
    ]
    previous = ""
    for item in abi.items:
        if item.kind == "function_type" and item.raw.get("inline"):
            continue  # written out where a structure member uses it
        lines = _render_item(abi, item)
        # Runs of one-line constants and of undocumented functions stay together; a section
        # comment introduces what follows it.
        together = previous == "section" or (
            item.kind == previous and item.kind in ("constant", "function") and len(lines) == 1
        )
        out += lines if together else ["", *lines]
        previous = item.kind
    out += ["", "#ifdef __cplusplus", "}", "#endif", f"#endif /* {abi.guard} */", ""]
    return "\n".join(out)


# --- Python ---------------------------------------------------------------------------------

BANNER_PY = '''\
"""ctypes declarations of the simulator library's C ABI (ports/native/generated/stac_sim.h).

GENERATED by tools/codegen/generate.py from hardware/definitions/sim_abi.toml. Do not edit by
hand: change the definition and run `make regen` (a test fails if this file drifts).
"""
'''


def _ctype(d: Decl, abi: Abi, role: str) -> str:
    """The ctypes spelling of a declaration; role "call": Python passes it to the library,
    "callback": the library passes it to Python, "field": a structure member."""
    types, structs = abi.named("function_type"), abi.named("struct")
    if d.base in types:
        return str(types[d.base].raw["py"])
    if not d.pointer and not d.dims:
        if d.base not in INTEGERS:
            raise AbiDefinitionError(f"{d.c()}: no ctypes equivalent for {d.base}")
        return INTEGERS[d.base][0]
    if d.base == "void":
        return "c_void_p"
    if d.base == "char" and d.const:
        return "c_char_p"
    if d.base in structs:
        cls = structs[d.base].raw.get("py")
        return f"POINTER({cls})" if cls else "c_void_p"  # a dtype-backed struct: an address
    if d.base in abi.named("opaque"):
        return "c_void_p"
    if d.base not in INTEGERS:
        raise AbiDefinitionError(f"{d.c()}: no ctypes equivalent for {d.base}")
    if role == "call" and d.base == "uint8_t":
        return "c_char_p" if d.const else "c_void_p"  # bytes in; a writable buffer's address
    return f"POINTER({INTEGERS[d.base][0]})"


def _restype(name: str) -> str:
    return "None" if name == "void" else INTEGERS[name][0]


def _py_comment(doc: str) -> list[str]:
    return ["#: " + line for line in textwrap.wrap(" ".join(doc.split()), WIDTH - 3)]


def _import_order(name: str) -> tuple[bool, list[Any]]:
    """isort's order: constants first, then numbers compared as numbers (c_uint8 < c_uint16)."""
    return not name.isupper(), [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", name)]


def render_python(abi: Abi) -> str:
    body: list[str] = []
    for c in abi.of_kind("constant"):
        v = int(c.raw["value"])
        body += [*_py_comment(c.doc), f"{c.name} = {f'0x{v:04X}' if c.raw.get('hex') else v}"]
    body.append("")
    for t in abi.of_kind("function_type"):
        args = [_restype(t.raw["returns"]), *(_ctype(p, abi, "callback") for p in t.params())]
        body += [f"#: {t.name}", f"{t.raw['py']} = ctypes.CFUNCTYPE({', '.join(args)})"]
    for s in abi.of_kind("struct"):
        fields = s.fields()
        if "py" in s.raw:
            doc = textwrap.wrap(f"{s.name}: {' '.join(s.doc.split())}", WIDTH - 8)
            doc[0] = '"""' + doc[0]
            doc[-1] += '"""'
            body += ["", "", f"class {s.raw['py']}(ctypes.Structure):"]
            body += ["    " + line for line in doc] + ["", "    _fields_ = ("]
            body += [f'        ("{f.name}", {_ctype(f, abi, "field")}),' for f in fields]
            body += ["    )"]
        if "py_dtype" in s.raw:
            rows = []
            for f in fields:
                code = INTEGERS[f.base][1]
                shape = f", ({', '.join(map(str, f.dims))}{',' if len(f.dims) == 1 else ''})"
                rows.append(f'    ("{f.name}", "{code}"{shape if f.dims else ""}),')
            body += [
                "",
                "",
                *_py_comment(f"{s.name}: {s.doc}"),
                f"{s.raw['py_dtype']} = np.dtype([",
            ]
            body += [*rows, "])"]
    body += [
        "",
        "",
        "#: entry point -> (result type, argument types)",
        "SIGNATURES: dict[str, tuple[Any, list[Any]]] = {",
    ]
    for f in abi.of_kind("function"):
        args = ", ".join(_ctype(p, abi, "call") for p in f.params())
        body.append(f'    "{f.name}": ({_restype(f.raw["returns"])}, [{args}]),')
    body += [
        "}",
        "",
        "",
        "def declare(lib: ctypes.CDLL) -> ctypes.CDLL:",
        '    """Declare the result and argument types of every entry point on a loaded library."""',
        "    for name, (restype, argtypes) in SIGNATURES.items():",
        "        function = getattr(lib, name)",
        "        function.restype = restype",
        "        function.argtypes = argtypes",
        "    return lib",
        "",
    ]
    used = sorted(set(re.findall(r"\b(POINTER|c_\w+)\b", "\n".join(body))), key=_import_order)
    head = [
        BANNER_PY,
        "from __future__ import annotations",
        "",
        "import ctypes",
        f"from ctypes import {', '.join(used)}",
        "from typing import Any",
        "",
        "import numpy as np",
        "",
    ]
    return "\n".join(head + body)
