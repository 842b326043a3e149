"""TorchScript export of the stateless decoder: `torch.jit.load(path)(u)` with u float32
(N, D) assembled vectors gives the (N, O) physical outputs."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any


def export_torchscript(dec: Any, path: Path) -> Path:
    import torch

    from spectratac.decode.export.torch_net import Exported

    module = Exported(dec.runtime).eval()
    example = torch.zeros((2, dec.runtime.n_inputs), dtype=torch.float32)
    extra = {"outputs": ",".join(dec.heads.output_names())}
    with torch.no_grad(), warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # TorchScript is deprecated
        traced = torch.jit.trace(module, (example,), check_trace=False)
        torch.jit.save(traced, str(path), _extra_files=extra)
    return path
