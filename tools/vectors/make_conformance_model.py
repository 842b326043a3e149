"""Write host/spectratac/conformance/conformance_model.json: the model image the conformance
suite uploads to a device with CAP_MODEL_UPLOAD (an untrained one-step paper33 decoder, made the
same way every time; tests/conformance checks the committed file against a fresh export).

The conformance suite sits below the decoder in the package's data flow, so it cannot export a
decoder itself: it reads these bytes. Run this after a change of the model image format.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

OUT = Path(__file__).resolve().parents[2] / "host/spectratac/conformance/conformance_model.json"


def build() -> dict[str, Any]:
    from spectratac.dataset import SPECTRATAC_INPUTS, Dataset
    from spectratac.decode import Decoder
    from spectratac.decode.export import model_image

    ds = Dataset.generic(
        np.arange(1.0, 37.0).reshape(3, 12) * 100.0,
        np.zeros((3, 1)),
        list(SPECTRATAC_INPUTS),
        ["Fz"],
    )
    image = model_image.encode(Decoder.untrained(ds, features="paper33"), weights="f32")
    about = model_image.describe(image)
    return {
        "doc": "Written by tools/vectors/make_conformance_model.py; do not edit.",
        "model_id": model_image.model_id(image),
        "led_steps": about["led_steps"],
        "weight_format": about["weight_format"],
        "size": len(image),
        "image_hex": image.hex(),
    }


def render() -> str:
    return json.dumps(build(), indent=2) + "\n"


def main() -> int:
    OUT.write_text(render(), encoding="utf-8")
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
