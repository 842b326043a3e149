"""ONNX export of the stateless decoder (torch's exporter; needs the `train` extra).

Input "u": float32 (N, D) assembled vectors (see spectratac.decode.layout); output "y":
float32 (N, O) physical outputs named in the model's metadata ("outputs").
"""

from __future__ import annotations

import json
import logging
import warnings
from pathlib import Path
from typing import Any

OPSET = 18


def export_onnx(dec: Any, path: Path) -> Path:
    import onnx
    import torch

    from spectratac.decode.export.torch_net import Exported

    module = Exported(dec.runtime).eval()
    example = torch.zeros((2, dec.runtime.n_inputs), dtype=torch.float32)
    batch = torch.export.Dim("batch", min=1)
    quiet = logging.getLogger("torch.onnx")
    level = quiet.level
    quiet.setLevel(logging.ERROR)  # "torchvision is not installed" notes are noise here
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        program = torch.onnx.export(
            module,
            (example,),
            input_names=["u"],
            output_names=["y"],
            dynamic_shapes={"u": {0: batch}},
            opset_version=OPSET,
            dynamo=True,
            verbose=False,
        )
    quiet.setLevel(level)
    model = program.model_proto
    info = {
        "inputs": dec.layout.names(),
        "outputs": dec.heads.output_names(),
        "unit_id": dec.unit_id,
        "config": dec.config,
    }
    for k, v in info.items():
        entry = model.metadata_props.add()
        entry.key, entry.value = k, json.dumps(v)
    onnx.save(model, str(path))
    return path
