"""What the generator makes of the protocol, part and board definitions means what they say.

Definitions (hardware/definitions/): messages.toml (the protocol), veml3328.toml (the sensor
chip), stm32f411_pinmap.toml (board.h), params.toml (the geometry) and vocabulary.toml (regions,
channels, axes). That the committed outputs equal a fresh run is tests/meta/test_generated.py's
job (one drift test for all).
"""

from __future__ import annotations

import doctest
import importlib
import shutil
import subprocess
import tomllib
from pathlib import Path
from types import ModuleType

import pytest
from spectratac.hardware.generated import board, veml3328
from spectratac.protocol.generated import messages

pytestmark = pytest.mark.subprocess

DEFINITIONS = "hardware/definitions"


@pytest.fixture
def codegen() -> dict[str, ModuleType]:
    """The generator's modules."""
    return {n: importlib.import_module(f"tools.codegen.{n}") for n in ("definition", "part")}


def _definition_copy(repo: Path, tmp_path: Path, text: str) -> Path:
    """messages.toml with `text`, placed so that its relative [parts] paths still resolve."""
    shutil.copytree(repo / DEFINITIONS, tmp_path / DEFINITIONS)
    path = tmp_path / DEFINITIONS / "messages.toml"
    path.write_text(text, "utf-8")
    return path


def test_python_module_matches_definition(repo: Path) -> None:
    raw = tomllib.loads((repo / DEFINITIONS / "messages.toml").read_text(encoding="utf-8"))
    assert (
        raw["protocol"]["major"],
        raw["protocol"]["minor"],
    ) == (messages.PROTOCOL_MAJOR, messages.PROTOCOL_MINOR)
    assert {m["name"]: m["id"] for m in raw["messages"]} == {
        cls.NAME: cls.TYPE_ID for cls in messages.MESSAGES
    }
    for cls in messages.MESSAGES:
        assert len(cls().pack()) == cls.PAYLOAD_SIZE <= messages.MAX_PAYLOAD


def test_hash_ignores_docs_but_not_wire_changes(
    repo: Path, tmp_path: Path, codegen: dict[str, ModuleType]
) -> None:
    load = codegen["definition"].load
    text = (repo / DEFINITIONS / "messages.toml").read_text(encoding="utf-8")
    assert load(repo / DEFINITIONS / "messages.toml").hash == messages.DEFINITION_HASH
    doc_edit = _definition_copy(repo, tmp_path / "doc", text.replace("Echo of the", "Copy of the"))
    assert load(doc_edit).hash == messages.DEFINITION_HASH
    wire_edit = _definition_copy(
        repo, tmp_path / "wire", text.replace("max = 10000", "max = 20000")
    )
    assert load(wire_edit).hash != messages.DEFINITION_HASH


def test_a_part_change_reaches_the_protocol(
    repo: Path, tmp_path: Path, codegen: dict[str, ModuleType]
) -> None:
    """CONFIGURE's integration times are the chip's: editing the part changes the wire hash."""
    text = (repo / DEFINITIONS / "messages.toml").read_text(encoding="utf-8")
    path = _definition_copy(repo, tmp_path, text)
    part_file = tmp_path / DEFINITIONS / "veml3328.toml"
    part_text = part_file.read_text(encoding="utf-8")
    part_file.write_text(part_text.replace("[50, 100, 200, 400]", "[25, 50, 100, 200]"), "utf-8")
    d = codegen["definition"].load(path)
    field = next(f for m in d.messages if m.name == "CONFIGURE" for f in m.fields)
    assert field.allowed == (25, 50, 100, 200)
    errors = {v.name: v for v in d.enums["error"][1]}
    assert errors["BAD_INTEGRATION_TIME"].action == "Choose one of 25, 50, 100, 200 ms."
    assert d.hash != messages.DEFINITION_HASH


def test_protocol_takes_integration_times_from_the_chip() -> None:
    assert messages.Configure.FIELDS[0].allowed == veml3328.INTEGRATION_MS
    assert (
        "Choose one of 50, 100, 200, 400 ms."
        in messages.ERROR_TEXT[messages.Error.BAD_INTEGRATION_TIME]
    )


@pytest.mark.parametrize(
    ("reference", "message"),
    [
        ('allowed = "veml3328.IT"', None),
        ('allowed = "chip.IT"', "unknown part 'chip'"),
        ('allowed = "veml3328.SPEED"', "no CONF field 'SPEED'"),
        ('allowed = "veml3328.SENS"', "lists no values"),
        ('allowed = "50 or 100"', "give a list or a 'part.FIELD' reference"),
    ],
)
def test_bad_part_references_are_named(
    repo: Path,
    tmp_path: Path,
    codegen: dict[str, ModuleType],
    reference: str,
    message: str | None,
) -> None:
    text = (repo / DEFINITIONS / "messages.toml").read_text(encoding="utf-8")
    assert 'allowed = "veml3328.IT"' in text
    path = _definition_copy(repo, tmp_path, text.replace('allowed = "veml3328.IT"', reference))
    if message is None:
        assert codegen["definition"].load(path).hash == messages.DEFINITION_HASH
        return
    with pytest.raises(codegen["definition"].DefinitionError, match=message):
        codegen["definition"].load(path)


def test_part_definition_matches_generated_python(
    repo: Path, codegen: dict[str, ModuleType]
) -> None:
    part = codegen["part"]
    chip = part.load(repo / DEFINITIONS / "veml3328.toml")
    assert doctest.testmod(part).failed == 0
    assert {f"REG_{r.name}": r.address for r in chip.registers} == {
        name: value for name, value in vars(veml3328).items() if name.startswith("REG_")
    }
    assert (chip.defined_bits, chip.window_bits) == (veml3328.CONF_DEFINED, veml3328.CONF_WINDOW)


def test_overlapping_conf_fields_are_refused(
    repo: Path, tmp_path: Path, codegen: dict[str, ModuleType]
) -> None:
    text = (repo / DEFINITIONS / "veml3328.toml").read_text(encoding="utf-8")
    bad = tmp_path / "veml3328.toml"
    bad.write_text(text.replace("bit = 6\n", "bit = 5\n"), "utf-8")
    with pytest.raises(codegen["part"].PartError, match=r"CONF\.SENS: bits 0x0020 overlap"):
        codegen["part"].load(bad)


def test_board_geometry_matches_params(repo: Path) -> None:
    params = tomllib.loads((repo / DEFINITIONS / "params.toml").read_text(encoding="utf-8"))
    for table, values in params.items():
        for key, value in values.items():
            got = getattr(board, f"{table.upper()}_{key.upper()}")
            assert got == (tuple(value) if isinstance(value, list) else value), (table, key)


def test_generated_c_compiles_warning_free(repo: Path, tmp_path: Path) -> None:
    probe = tmp_path / "probe.c"
    probe.write_text(
        '#include "veml3328_regs.h"\n'
        "static const unsigned k_it[VEML3328_CONF_IT_COUNT] = VEML3328_CONF_IT_VALUES;\n"
        "unsigned probe(unsigned code) { return k_it[code & 3u] + VEML3328_REG_ID; }\n",
        "utf-8",
    )
    for source in (repo / "firmware/core/generated/stac_messages.c", probe):
        result = subprocess.run(
            [
                "gcc",
                "-std=c11",
                "-Wall",
                "-Wextra",
                "-Werror",
                "-pedantic",
                f"-I{repo / 'firmware/core/generated'}",
                "-c",
                str(source),
                "-o",
                str(tmp_path / "m.o"),
            ],
            capture_output=True,
            text=True,
        )
        assert result.returncode == 0, result.stderr


def test_fields_of_a_later_minor_give_each_sender_its_layout(
    repo: Path, tmp_path: Path, codegen: dict[str, ModuleType]
) -> None:
    """A field appended in the current minor is zero-filled for older senders only;
    out-of-order or future `since` values are refused."""
    definition = codegen["definition"]
    text = (repo / DEFINITIONS / "messages.toml").read_text(encoding="utf-8")
    minor = tomllib.loads(text)["protocol"]["minor"]
    log_text = '{ name = "text", type = "char", shape = [64], doc = "ASCII text, NUL-padded." },'
    source = f'{{ name = "source", type = "u16", since = {minor}, doc = "Origin." }},'
    newer = text.replace(log_text, log_text + "\n  " + source)
    d = definition.load(_definition_copy(repo, tmp_path / "ok", newer))
    log = next(m for m in d.messages if m.name == "LOG")
    size = messages.Log.PAYLOAD_SIZE
    assert [log.size_at(minor - 1), log.size_at(minor), log.payload_size] == [
        size,
        size + 2,
        size + 2,
    ]
    bad = newer.replace(source, source.replace(f"since = {minor}", f"since = {minor + 1}"))
    with pytest.raises(definition.DefinitionError, match="'since' values must be minor"):
        definition.load(_definition_copy(repo, tmp_path / "bad", bad))


def test_messages_name_the_minor_version_that_added_them(
    repo: Path, tmp_path: Path, codegen: dict[str, ModuleType]
) -> None:
    """`since` on a message: generated into SINCE, shown in MESSAGES.md, hashed, range-checked."""
    assert (messages.Sample.SINCE, messages.Estimate.SINCE, messages.ModelBegin.SINCE) == (0, 1, 1)
    reference = (repo / "protocol/generated/MESSAGES.md").read_text(encoding="utf-8")
    assert "| 0x8A | [ESTIMATE](#estimate) | device → host | 46 | 1.1 |" in reference
    assert "| 0x84 | [SAMPLE](#sample) | device → host | 48 | 1.0 |" in reference
    assert "Type 0x8A. Added in 1.1: a 1.0 peer does not know it." in reference
    definition = codegen["definition"]
    text = (repo / DEFINITIONS / "messages.toml").read_text(encoding="utf-8")
    estimate = 'name = "ESTIMATE"\nid = 0x8A\ndirection = "device_to_host"\nsince = 1'
    assert estimate in text
    unversioned = text.replace(estimate, estimate.replace("\nsince = 1", ""))
    assert definition.load(_definition_copy(repo, tmp_path / "a", unversioned)).hash != (
        messages.DEFINITION_HASH
    )
    minor = tomllib.loads(text)["protocol"]["minor"]
    future = text.replace(estimate, estimate.replace("since = 1", f"since = {minor + 1}"))
    with pytest.raises(definition.DefinitionError, match="ESTIMATE: 'since' values must be minor"):
        definition.load(_definition_copy(repo, tmp_path / "b", future))


def test_the_1_0_subset_keeps_the_released_1_0_hash(codegen: dict[str, ModuleType]) -> None:
    """Every 1.1 addition removed, the definition hashes as 1.0 did: `since` = 0 adds nothing
    to the hash, so a released version's hash never moves (SPEC.md, section 8)."""
    import dataclasses

    from spectratac.protocol.versions import RELEASED_DEFINITION_HASHES

    definition = codegen["definition"]
    d = definition.load(Path(__file__).resolve().parents[2] / DEFINITIONS / "messages.toml")
    new_flags = {"CAP_ESTIMATE", "CAP_MODEL_UPLOAD", "CONFIG_ESTIMATE", "CONFIG_ESTIMATE_ONLY"}
    new_flags |= MINOR_4_FLAGS
    old = dataclasses.replace(
        d,
        protocol=d.protocol | {"minor": 0},
        enums={
            name: (doc, tuple(v for v in vals if name != "error" or v.value < 14))
            for name, (doc, vals) in d.enums.items()
            if name not in MINOR_4_ENUMS
        },
        flags={
            name: (doc, tuple(v for v in values if v.name not in new_flags))
            for name, (doc, values) in d.flags.items()
            if name not in {"estimate_flags", *MINOR_4_FLAG_SETS}
        },
        messages=tuple(
            dataclasses.replace(msg, fields=tuple(f for f in msg.fields if f.since == 0))
            for msg in d.messages
            if msg.since == 0
        ),
    )
    assert definition.wire_hash(old) == RELEASED_DEFINITION_HASHES[0]


#: 1.4's additions besides fields and messages: error codes, enums, flag sets and bits.
MINOR_4_ERRORS = {"BOR_TOO_LOW", "NOT_A_TEST_IMAGE", "BAD_FAULT_KIND"}
MINOR_4_ENUMS = {"fault_kind"}
MINOR_4_FLAG_SETS = {"reset_cause"}
MINOR_4_FLAGS = {"CAP_BOOTLOADER", "CAP_DEBUG_FAULT"}


def subset(definition: ModuleType, minor: int):
    """The current definition with every addition after 1.`minor` removed (fields and
    messages by their `since`, the 1.3 flag EST_NO_REST, 1.4's errors, enums and flags)."""
    import dataclasses

    d = definition.load(Path(__file__).resolve().parents[2] / DEFINITIONS / "messages.toml")
    later = minor < 4
    later_flags = ({"EST_NO_REST"} if minor < 3 else set()) | (MINOR_4_FLAGS if later else set())
    return dataclasses.replace(
        d,
        protocol=d.protocol | {"minor": minor},
        enums={
            name: (doc, tuple(v for v in vals if not (later and v.name in MINOR_4_ERRORS)))
            for name, (doc, vals) in d.enums.items()
            if not (later and name in MINOR_4_ENUMS)
        },
        flags={
            name: (doc, tuple(v for v in values if v.name not in later_flags))
            for name, (doc, values) in d.flags.items()
            if not (later and name in MINOR_4_FLAG_SETS)
        },
        messages=tuple(
            dataclasses.replace(msg, fields=tuple(f for f in msg.fields if f.since <= minor))
            for msg in d.messages
            if msg.since <= minor
        ),
    )


@pytest.mark.parametrize("minor", [1, 2, 3])
def test_older_subsets_keep_their_released_hashes(
    codegen: dict[str, ModuleType], minor: int
) -> None:
    """The later additions removed (1.2: STATUS cycle counts, MODEL_INFO.image_crc; 1.3: TARE
    and EST_NO_REST; 1.4: post-mortem STATUS fields, ENTER_BOOTLOADER, DEBUG_FAULT), the
    definition hashes as the released 1.`minor` did: later minors only
    appended fields, messages and flag bits."""
    from spectratac.protocol.versions import RELEASED_DEFINITION_HASHES

    definition = codegen["definition"]
    assert definition.wire_hash(subset(definition, minor)) == RELEASED_DEFINITION_HASHES[minor]
