"""The decoder networks in torch: the module training fits and the graph the ONNX and
TorchScript exports trace.

Importing this module imports torch: only the exporters (inside their functions) and the
training loop (spectratac.train.torch_loop) do. Parameter names match
`spectratac.decode.networks`, whose NumPy forward is the reference.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from torch import nn

from spectratac.decode.networks import LN_EPS, SKIP, Arch
from spectratac.decode.paper_features import EPS


class Block(nn.Module):
    def __init__(self, h: int, dropout: float = 0.0) -> None:
        super().__init__()
        self.norm = nn.LayerNorm(h, eps=LN_EPS)
        self.fc1 = nn.Linear(h, h)
        self.fc2 = nn.Linear(h, h)
        self.act = nn.GELU(approximate="tanh")
        self.drop = nn.Dropout(dropout)  # training only; identity in eval and export

    def forward(self, v: torch.Tensor) -> torch.Tensor:
        return v + self.fc2(self.drop(self.act(self.fc1(self.norm(v)))))


class Net(nn.Module):
    """linear | mlp | resmlp over z-scored features, one fused head; `skip` adds a bias-free
    linear path from the features to the outputs (networks.SKIP)."""

    def __init__(
        self, arch: Arch, n_in: int, n_out: int, dropout: float = 0.0, skip: bool = False
    ) -> None:
        super().__init__()
        kind, hidden, blocks = arch
        self.kind = kind
        self.has_skip = skip
        if skip:
            self.skip = nn.Linear(n_in, n_out, bias=False)
        self.act = nn.GELU(approximate="tanh")
        if kind == "mlp":
            dims = [n_in] + [hidden] * blocks
            self.layers = nn.ModuleList(nn.Linear(dims[i], dims[i + 1]) for i in range(blocks))
            self.head = nn.Linear(dims[-1], n_out)
        elif kind == "resmlp":
            self.stem = nn.Linear(n_in, hidden)
            self.blocks = nn.ModuleList(Block(hidden, dropout) for _ in range(blocks))
            self.norm = nn.LayerNorm(hidden, eps=LN_EPS)
            self.head = nn.Linear(hidden, n_out)
        else:
            self.head = nn.Linear(n_in, n_out)

    def forward(self, z: torch.Tensor) -> torch.Tensor:
        x = z
        if self.kind == "mlp":
            for layer in self.layers:
                x = self.act(layer(x))
        elif self.kind == "resmlp":
            x = self.act(self.stem(x))
            for b in self.blocks:
                x = b(x)
            x = self.norm(x)
        out = self.head(x)
        if self.has_skip:
            out = out + self.skip(z)
        return out


class Exported(nn.Module):
    """Assembled vector (N, D) -> physical outputs (N, O): features, normalisation, network
    and output transform in one graph, built from a `Runtime`."""

    def __init__(self, rt: Any, dtype: torch.dtype = torch.float32) -> None:
        super().__init__()
        fs = rt.features

        def buf(name: str, a: np.ndarray) -> None:
            self.register_buffer(name, torch.as_tensor(np.asarray(a), dtype=dtype))

        buf("center", rt.center)
        buf("Lt", fs.L.T)
        buf("Pt", fs.P.T)
        buf("Qt", fs.Q.T)
        buf("mean", rt.scaler.mean)
        buf("inv_std", 1.0 / rt.scaler.std)
        buf("y_scale", rt.y_scale)
        buf("std_mul", rt.y_scale * rt.std_scale)
        self.has_rat = fs.P.shape[0] > 0
        self.register_buffer("mon", torch.as_tensor(np.asarray(fs.M), dtype=torch.long))
        self.has_mon = fs.M.shape[0] > 0
        self.eps = EPS
        skip = SKIP in rt.weights
        self.net = Net(rt.arch, fs.n_features, rt.heads.n_out, skip=skip).to(dtype)
        state = {k: torch.as_tensor(v, dtype=dtype) for k, v in rt.weights.items()}
        self.net.load_state_dict(state)
        self.net.requires_grad_(False)  # an inference graph: no autograd bookkeeping
        sl = rt.heads.slices()
        self.r = sl["targets"].stop
        self.s = (sl["std"].start, sl["std"].stop)
        self.c = (sl["classes"].start, sl["classes"].stop)
        self.k = (sl["contact"].start, sl["contact"].stop)

    def forward(self, u: torch.Tensor) -> torch.Tensor:
        f = (u - self.center) @ self.Lt
        if self.has_rat:
            rat = (u @ self.Pt) / (torch.abs(u) @ self.Qt + self.eps)
            f = torch.cat([f, rat], dim=1)
        if self.has_mon:  # index -1 picks the appended 1: an unused factor slot
            padded = torch.cat([f, torch.ones_like(f[:, :1])], dim=1)
            f = torch.cat([f, torch.prod(padded[:, self.mon], dim=2)], dim=1)
        raw = self.net((f - self.mean) * self.inv_std)
        parts = [raw[:, : self.r] * self.y_scale]
        if self.s[1] > self.s[0]:
            parts.append(torch.exp(raw[:, self.s[0] : self.s[1]]) * self.std_mul)
        if self.c[1] > self.c[0]:
            parts.append(torch.softmax(raw[:, self.c[0] : self.c[1]], dim=1))
        if self.k[1] > self.k[0]:
            parts.append(0.5 * (1.0 + torch.tanh(0.5 * raw[:, self.k[0] : self.k[1]])))
        return torch.cat(parts, dim=1)
