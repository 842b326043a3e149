"""A firmware with a built-in model: tools/firmware/builtin_model.py's C array compiled in with
STAC_BUILTIN_MODEL (target builtin-tests of tools/firmware/build.toml, ASan + UBSan) decodes
without an upload and comes back after MODEL_CLEAR; the tool's command line writes the array."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import pytest

from .conftest import OUT, listed_c_tests, run_c_test
from .model_fixture import (
    BUILTIN_FIXTURE,
    builtin_model_tool,
    fixture_image,
    render_builtin_fixture,
)

pytestmark = [pytest.mark.firmware, pytest.mark.subprocess]

NAMES = [
    "builtin_model_is_used_without_an_upload",
    "builtin_model_steps_aside_for_an_upload_and_returns",
]


@pytest.fixture(scope="module")
def builtin_binary(native_build: ModuleType) -> Path:
    return native_build.build("builtin-tests", OUT)


def test_every_builtin_test_is_listed(builtin_binary: Path) -> None:
    assert listed_c_tests(builtin_binary) == NAMES


@pytest.mark.parametrize("name", NAMES)
def test_builtin(builtin_binary: Path, name: str) -> None:
    run_c_test(builtin_binary, name)


def test_builtin_fixture_is_the_current_export() -> None:
    assert BUILTIN_FIXTURE.read_text() == render_builtin_fixture()


def test_tool_writes_an_image_file_as_it_is(tmp_path: Path) -> None:
    image = fixture_image()
    src, out = tmp_path / "m.stmi", tmp_path / "out" / "builtin.c"
    src.write_bytes(image)
    assert builtin_model_tool().main([str(src), "-o", str(out), "--symbol", "m"]) == 0
    text = out.read_text()
    assert f"const uint8_t m[{len(image)}] = {{" in text
    values = [int(v, 16) for v in text.split("= {")[1].split("};")[0].replace(",", " ").split()]
    assert bytes(values) == image


def test_tool_encodes_a_stac_file(tmp_path: Path) -> None:
    import numpy as np
    from spectratac.dataset import SPECTRATAC_INPUTS, Dataset
    from spectratac.decode import Decoder
    from spectratac.decode.export.model_image import encode

    ds = Dataset.generic(
        np.arange(1.0, 37.0).reshape(3, 12) * 10.0,
        np.zeros((3, 1)),
        list(SPECTRATAC_INPUTS),
        ["Fz"],
    )
    dec = Decoder.untrained(ds, features="paper33", arch=("mlp", 8, 1))
    model = dec.save(tmp_path / "m.stac")
    out = tmp_path / "builtin.c"
    assert builtin_model_tool().main([str(model), "-o", str(out), "--weights", "i8"]) == 0
    image = encode(Decoder.load(model), weights="i8")
    assert f"const uint32_t stac_builtin_model_size = {len(image)}u;" in out.read_text()


def test_tool_refuses_a_bad_symbol_and_a_missing_file(tmp_path: Path) -> None:
    tool = builtin_model_tool()
    with pytest.raises(ValueError, match="not a C identifier"):
        tool.render(b"\x00", "1bad", "x")
    assert tool.main([str(tmp_path / "missing.stac"), "-o", str(tmp_path / "o.c")]) == 2
