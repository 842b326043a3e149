"""The model images of the C tests: the one they upload and decode with
(tests/firmware/c/model_fixture.c), an untrained paper33 ResMLP decoder for one LED step, and
the same decoder with float16 weights as the built-in model of the builtin-tests program
(tests/firmware/c/builtin/stac_builtin_model.c). Made the same way every time, so that a test
can check the committed C arrays against a fresh export."""

from __future__ import annotations

import importlib
from pathlib import Path
from types import ModuleType

import numpy as np

REPO = Path(__file__).resolve().parents[2]
C_FIXTURE = REPO / "tests" / "firmware" / "c" / "model_fixture.c"
BUILTIN_FIXTURE = REPO / "tests" / "firmware" / "c" / "builtin" / "stac_builtin_model.c"
SYMBOL = "test_model_image"


def fixture_image(weights: str = "f32") -> bytes:
    from spectratac.dataset import SPECTRATAC_INPUTS, Dataset
    from spectratac.decode import Decoder
    from spectratac.decode.export.model_image import encode

    ds = Dataset.generic(
        np.arange(1.0, 37.0).reshape(3, 12) * 100.0,
        np.zeros((3, 1)),
        list(SPECTRATAC_INPUTS),
        ["Fz"],
    )
    return encode(Decoder.untrained(ds, features="paper33"), weights=weights)


def builtin_model_tool() -> ModuleType:
    return importlib.import_module("tools.firmware.builtin_model")


def render_fixture() -> str:
    return builtin_model_tool().render(fixture_image(), SYMBOL, "tests/firmware/model_fixture.py")


def render_builtin_fixture() -> str:
    return builtin_model_tool().render(
        fixture_image("f16"), "stac_builtin_model", "tests/firmware/model_fixture.py"
    )


if __name__ == "__main__":
    C_FIXTURE.write_text(render_fixture())
    BUILTIN_FIXTURE.write_text(render_builtin_fixture())
    print(f"wrote {C_FIXTURE} and {BUILTIN_FIXTURE}")
