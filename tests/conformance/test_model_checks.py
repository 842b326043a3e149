"""The on-device decoding checks: which run for which capabilities, and the packaged model."""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import pytest
from spectratac.conformance import MODEL_CHECKS, TestModel
from spectratac.conformance.model_checks import applicable
from spectratac.protocol import crc32c
from spectratac.protocol.framing import CRC_RESIDUE
from spectratac.protocol.generated import messages as m

REPO = Path(__file__).resolve().parents[2]
CAP = m.Capabilities


def _tool():
    return importlib.import_module("tools.vectors.make_conformance_model")


def test_the_packaged_model_is_a_fresh_export() -> None:
    """Regenerate with tools/vectors/make_conformance_model.py after a model format change."""
    tool = _tool()
    assert tool.OUT.read_text(encoding="utf-8") == tool.render()


def test_the_packaged_model_holds_its_own_crc() -> None:
    model = TestModel.packaged()
    raw = json.loads(_tool().OUT.read_text(encoding="utf-8"))
    assert len(model.image) == raw["size"] and model.model_id == raw["model_id"]
    assert crc32c(model.image) == CRC_RESIDUE  # the image ends with the CRC-32C of the rest


@pytest.mark.parametrize(
    ("capabilities", "runs"),
    [
        (0, 0),
        (CAP.CAP_ESTIMATE, 3),  # model info, estimates beside and instead: a built-in model
        (CAP.CAP_ESTIMATE | CAP.CAP_MODEL_UPLOAD, len(MODEL_CHECKS)),
    ],
)
def test_model_checks_run_for_the_capabilities_a_device_reports(
    capabilities: int, runs: int
) -> None:
    assert len(applicable(capabilities)) == runs
