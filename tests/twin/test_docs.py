"""Twin and decode imports stay torch-free; the model card documents every constant.

(Docstring examples of every module run in tests/meta/test_doctests.py.)"""

from __future__ import annotations

import subprocess
import sys

import pytest

pytestmark = pytest.mark.subprocess


def test_twin_and_decode_do_not_import_torch() -> None:
    code = (
        "import sys, spectratac.twin, spectratac.decode, spectratac.twin.rig, "
        "spectratac.twin.oracle, spectratac.studies.twin_fidelity; print('torch' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_model_card_documents_every_unit_constant(repo) -> None:
    from dataclasses import fields

    from spectratac.twin.unit import UnitParams

    card = (repo / "host/spectratac/twin/MODEL.md").read_text()
    missing = [f.name for f in fields(UnitParams) if f"`{f.name}`" not in card]
    assert not missing, f"MODEL.md lacks: {missing}"
