"""Training the paper's recipe (torch is imported inside `train_paper_recipe` only).

Loss: component-weighted L1 on zero-anchored scaled targets,
L_F = 1/(6N) sum_i sum_j w_j |y~_ij - y^_ij| with w = [1, 1, 0.5, 0.1, 0.1, 0.2], plus
cross-entropy over the nine regions on samples whose label is not -1. AdamW with a One-Cycle
learning-rate schedule.

>>> TrainConfig().loss_weights
(1.0, 1.0, 0.5, 0.1, 0.1, 0.2)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.decode.features import FeatureError, features33
from spectratac.decode.model import N_OUT, N_REGIONS, PaperDecoder
from spectratac.decode.scaling import Standardizer, ZeroAnchoredScaler

PAPER_LOSS_WEIGHTS = (1.0, 1.0, 0.5, 0.1, 0.1, 0.2)


@dataclass(frozen=True)
class TrainConfig:
    hidden: int = 128
    blocks: int = 3
    epochs: int = 30
    batch_size: int = 1024
    max_lr: float = 3e-3
    weight_decay: float = 1e-4
    loss_weights: tuple[float, ...] = PAPER_LOSS_WEIGHTS
    seed: int = 0
    threads: int = 2


def check_training_data(
    raw12: ArrayLike, ft: ArrayLike, region: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    x = np.asarray(raw12, dtype=np.float64)
    y = np.asarray(ft, dtype=np.float64)
    lab = np.asarray(region).astype(np.int64)
    n = x.shape[0]
    if x.ndim != 2 or x.shape[1] != 12:
        raise FeatureError(f"raw12 must be (N, 12), got {x.shape}")
    if y.shape != (n, N_OUT):
        raise FeatureError(f"ft targets must be (N, 6) matching raw12, got {y.shape}")
    if lab.shape != (n,):
        raise FeatureError(f"region labels must be (N,), got {lab.shape}")
    if not np.all((lab == -1) | ((lab >= 1) & (lab <= N_REGIONS))):
        raise FeatureError("region labels must be 1..9, or -1 for 'no valid region'")
    if not np.all(np.isfinite(y)):
        raise FeatureError("ft targets contain NaN or inf")
    if n < 2:
        raise FeatureError("need at least 2 training samples")
    return x, y, lab


def train_paper_recipe(
    raw12: ArrayLike,
    ft: ArrayLike,
    region: ArrayLike,
    config: TrainConfig | None = None,
    progress: Callable[[int, float], None] | None = None,
) -> PaperDecoder:
    """Train the shared-backbone ResMLP on (N, 12) raw counts, (N, 6) F/T, (N,) labels.

    `progress(epoch, mean_loss)` is called after each epoch. Returns a NumPy `PaperDecoder`.
    """
    import torch
    from torch import nn

    cfg = config or TrainConfig()
    x, y, lab = check_training_data(raw12, ft, region)
    feats = features33(x)
    xs = Standardizer.fit(feats)
    ys = ZeroAnchoredScaler.fit(y)
    torch.manual_seed(cfg.seed)
    torch.set_num_threads(max(1, cfg.threads))
    gen = torch.Generator().manual_seed(cfg.seed)

    class Block(nn.Module):
        def __init__(self, h: int) -> None:
            super().__init__()
            self.norm = nn.LayerNorm(h)
            self.fc1 = nn.Linear(h, h)
            self.fc2 = nn.Linear(h, h)
            self.act = nn.GELU(approximate="tanh")

        def forward(self, v: torch.Tensor) -> torch.Tensor:
            return v + self.fc2(self.act(self.fc1(self.norm(v))))

    class ResMLP(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            h = cfg.hidden
            self.stem = nn.Linear(feats.shape[1], h)
            self.act = nn.GELU(approximate="tanh")
            self.blocks = nn.ModuleList(Block(h) for _ in range(cfg.blocks))
            self.norm = nn.LayerNorm(h)
            self.head_ft = nn.Linear(h, N_OUT)
            self.head_region = nn.Linear(h, N_REGIONS)

        def forward(self, v: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
            v = self.act(self.stem(v))
            for b in self.blocks:
                v = b(v)
            v = self.norm(v)
            return self.head_ft(v), self.head_region(v)

    model = ResMLP()
    xt = torch.as_tensor(xs.transform(feats), dtype=torch.float32)
    yt = torch.as_tensor(ys.transform(y), dtype=torch.float32)
    lt = torch.as_tensor(np.where(lab > 0, lab - 1, -100), dtype=torch.long)
    w = torch.as_tensor(cfg.loss_weights, dtype=torch.float32)
    n = xt.shape[0]
    steps = -(-n // cfg.batch_size)
    opt = torch.optim.AdamW(model.parameters(), lr=cfg.max_lr, weight_decay=cfg.weight_decay)
    sched = torch.optim.lr_scheduler.OneCycleLR(
        opt, max_lr=cfg.max_lr, total_steps=cfg.epochs * steps
    )
    ce = nn.CrossEntropyLoss(ignore_index=-100, reduction="sum")
    history: list[float] = []
    for epoch in range(cfg.epochs):
        perm = torch.randperm(n, generator=gen)
        total = 0.0
        model.train()
        for s in range(steps):
            idx = perm[s * cfg.batch_size : (s + 1) * cfg.batch_size]
            pred_ft, logits = model(xt[idx])
            loss_f = (w * (pred_ft - yt[idx]).abs()).mean()
            labels = lt[idx]
            valid = int((labels >= 0).sum())
            loss_l = ce(logits, labels) / max(valid, 1)
            loss = loss_f + loss_l
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            sched.step()
            total += float(loss.detach()) * idx.shape[0]
        history.append(total / n)
        if progress is not None:
            progress(epoch + 1, history[-1])
    state = model.state_dict()
    weights = {k: v.detach().cpu().numpy().astype(np.float32) for k, v in state.items()}
    return PaperDecoder(
        weights=weights,
        x_scaler=xs,
        y_scaler=ys,
        meta={"recipe": "paper", "config": asdict(cfg), "n_train": int(n)},
        history=history,
    )
