"""The network's training loop in torch: loss, batches, schedule, weight averaging.

Imported by `train` and `finetune` when a network is fitted; torch is imported inside
`fit_network` only.

The loss is the paper's masked multitask objective, generalised to any target subset:
component-weighted L1 on zero-anchored scaled targets (paper weights Fx 1, Fy 1, Fz 0.5,
Tx 0.1, Ty 0.1, Tz 0.2; 1 for other targets; rows whose target_valid is False excluded),
plus cross-entropy over classes on rows labelled 1..K, plus binary cross-entropy on
in_contact with a contact head, plus a Laplace NLL for the uncertainty head (on a detached
mean, so that asking for uncertainty never changes the point estimates' loss). AdamW with a
One-Cycle learning-rate schedule.

Each step is kept cheap (the paper network's step is mostly its matrix products): the rows are
packed into tensors once, each epoch shuffles them with one gather and its batches are slices
of that; gain augmentation scales per-row parts computed once (train/gain.py) with the
epoch's factors drawn at once; the optimiser is torch's fused AdamW (one kernel per step).
Nothing is converted from NumPy or recomputed per batch. With a class head and temporal
context, `region_history_swap` teaches the class head on rows given another row's history
(HistorySwap), so that the region is read from the evidence of the moment.

>>> paper_weight("Fz"), paper_weight("Tz"), paper_weight("pressure")
(0.5, 0.2, 1.0)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac import threads
from spectratac.decode.paper_features import EPS
from spectratac.train.plan import Plan
from spectratac.train.spec import TrainSpec

PAPER_LOSS_WEIGHTS = {"Fx": 1.0, "Fy": 1.0, "Fz": 0.5, "Tx": 0.1, "Ty": 0.1, "Tz": 0.2}
HUBER_DELTA = 0.1  # in scaled target units
SKIP_RIDGE = 1e-2  # the skip's start: L2 penalty per row on z-scored features
Progress = bool | Callable[[int, float], None]


def paper_weight(name: str) -> float:
    return PAPER_LOSS_WEIGHTS.get(name, 1.0)


def loss_weights(spec: TrainSpec, targets: tuple[str, ...]) -> list[float]:
    """Regression loss weight per target: the loss's own, then spec.loss_weights.

    >>> loss_weights(TrainSpec.paper(loss_weights=(("Fz", 2.0),)), ("Fx", "Fz", "Tz"))
    [1.0, 2.0, 0.2]
    """
    own = [paper_weight(t) if spec.loss == "paper" else 1.0 for t in targets]
    given = dict(spec.loss_weights)
    return [given.get(t, w) for t, w in zip(targets, own, strict=True)]


def batch_sizes(n: int, batch_size: int) -> list[int]:
    """Sizes of the ceil(n / batch_size) batches of one epoch, as equal as possible: a short
    remainder batch would make one noisy optimiser step per epoch (measured with a 1-row
    remainder: blocked MAE Fx 0.18 -> 0.27 N).

    >>> batch_sizes(2049, 1024), batch_sizes(5, 1024)
    ([683, 683, 683], [5])
    """
    steps = -(-n // max(1, batch_size))
    return [n // steps + (1 if i < n % steps else 0) for i in range(steps)]


def average_decay(requested: float, total_steps: int) -> float:
    """Decay of the weight average: the requested one, capped so that the average's time
    scale 1 / (1 - decay) is at most a tenth of the run; on a short run a fixed decay would
    keep the untrained early weights in it (measured: Fz MAE 0.68 -> 1.2 N).

    >>> average_decay(0.999, 100_000), round(average_decay(0.999, 200), 3)
    (0.999, 0.95)
    """
    return min(requested, 1.0 - 10.0 / max(total_steps, 11))


def fit_network(
    spec: TrainSpec,
    p: Plan,
    data: dict[str, Any],
    fit_rows: NDArray[np.intp],
    val_rows: NDArray[np.intp],
    progress: Progress,
    start: dict[str, NDArray[Any]] | None = None,
    trainable: Callable[[str], bool] | None = None,
) -> tuple[dict, list, list]:
    """Optimise the network on `fit_rows`. `start`: initial weights (fine-tuning) instead of a
    fresh initialisation; `trainable`: which parameters (by name) the optimiser updates."""
    # Before torch's first import: its OpenMP pool reads the thread variables once.
    share = threads.apply(threads.current().workers).threads
    import torch

    from spectratac.decode.export.torch_net import Net

    torch.manual_seed(spec.seed)
    torch.set_num_threads(spec.threads or share)
    gen = torch.Generator().manual_seed(spec.seed)
    rng = np.random.default_rng(spec.seed)
    heads = p.heads
    sl = heads.slices()
    net = Net(spec.arch, p.features.n_features, heads.n_out, spec.dropout, skip=spec.skip)
    if spec.skip and start is None:
        with torch.no_grad():
            net.skip.weight.copy_(torch.from_numpy(skip_init(data, fit_rows, heads.n_out)))
    if start is not None:
        net.load_state_dict({k: torch.as_tensor(np.asarray(v)) for k, v in start.items()})
    for name, param in net.named_parameters():
        param.requires_grad_(trainable is None or trainable(name))

    y_shape = np.shape(data["y"])
    nz, ny = p.features.n_features, int(np.prod(y_shape[1:], dtype=np.int64))

    def tensors(idx: NDArray[np.intp]) -> dict[str, torch.Tensor]:
        # the float columns packed in one matrix: a batch is then two gathers, not five
        z = np.asarray(data["z"][idx], np.float32)
        y = np.asarray(data["y"][idx], np.float32).reshape(idx.size, ny)
        packed = np.concatenate(
            [
                z,
                y,
                np.asarray(data["y_ok"][idx], np.float32)[:, None],
                np.asarray(data["contact"][idx], np.float32)[:, None],
            ],
            axis=1,
        )
        label = np.where(data["label"][idx] > 0, data["label"][idx] - 1, -100)
        return {"packed": torch.from_numpy(packed), "label": torch.as_tensor(label)}

    def unpack(t: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        m = t["packed"]
        return {
            "z": m[:, :nz],
            "y": m[:, nz : nz + ny],
            "y_ok": m[:, nz + ny],
            "contact": m[:, nz + ny + 1],
            "label": t["label"],
        }

    tr, va = tensors(fit_rows), unpack(tensors(val_rows))
    jitter = GainJitter(data["gain"], fit_rows) if spec.gain_jitter > 0 else None
    swap = HistorySwap.of(spec, p) if heads.n_classes else None
    w = torch.tensor(loss_weights(spec, heads.regression), dtype=torch.float32)
    ce = torch.nn.CrossEntropyLoss(ignore_index=-100, reduction="sum")
    bce = torch.nn.BCEWithLogitsLoss()

    def loss_of(out: torch.Tensor, b: dict[str, torch.Tensor]) -> torch.Tensor:
        total = out.new_zeros(())
        if heads.n_reg:
            err = out[:, sl["targets"]] - b["y"]
            if spec.loss == "huber":
                e = torch.nn.functional.huber_loss(
                    err, torch.zeros_like(err), reduction="none", delta=HUBER_DELTA
                )
            else:
                e = err.abs()
            m = b["y_ok"][:, None]
            denom = heads.n_reg * torch.clamp(b["y_ok"].sum(), min=1.0)
            total = total + (w * e * m).sum() / denom
            if heads.uncertainty:
                nll = laplace_nll(err.detach(), out[:, sl["std"]])
                total = total + (nll * m).sum() / denom
        if heads.n_classes:
            lab = b["label"]
            total = total + ce(out[:, sl["classes"]], lab) / max(int((lab >= 0).sum()), 1)
        if heads.contact:
            logit = out[:, sl["contact"]][:, 0]
            if "contact_ok" in b:  # rows whose history was swapped teach the region only
                ok = b["contact_ok"]
                e = torch.nn.functional.binary_cross_entropy_with_logits(
                    logit, b["contact"], reduction="none"
                )
                total = total + (e * ok).sum() / torch.clamp(ok.sum(), min=1.0)
            else:
                total = total + bce(logit, b["contact"])
        return total

    n = tr["packed"].shape[0]
    sizes = batch_sizes(n, spec.batch_size)
    steps = len(sizes)
    params = [q for q in net.parameters() if q.requires_grad]
    # fused: one C++ kernel updates every parameter per step; on the CPU, foreach=True loops
    # over the tensors op by op (measured: about 3x the optimiser's time per step)
    opt = torch.optim.AdamW(params, lr=spec.lr, weight_decay=spec.weight_decay, fused=True)
    sched = torch.optim.lr_scheduler.OneCycleLR(
        opt, max_lr=spec.lr, total_steps=spec.epochs * steps
    )
    bar = None
    if progress is True:
        from spectratac.progress import bar as progress_bar

        bar = progress_bar(total=spec.epochs, desc="train", unit="epoch", leave=False)
    history: list[float] = []
    val_history: list[float] = []
    best: dict[str, Any] | None = None
    avg = None
    if spec.weight_average > 0:  # an exponential moving average of the weights, per step
        from torch.optim.swa_utils import AveragedModel, get_ema_multi_avg_fn

        decay = average_decay(spec.weight_average, spec.epochs * steps)
        avg = AveragedModel(net, multi_avg_fn=get_ema_multi_avg_fn(decay))
    try:
        for epoch in range(spec.epochs):
            perm = torch.randperm(n, generator=gen)
            net.train()
            total = 0.0
            # one gather per epoch; each batch below is a contiguous slice of it
            shuffled = {k: torch.split(v[perm], sizes) for k, v in tr.items()}
            if jitter is not None:  # the parts in epoch order, and the epoch's gains
                parts = [torch.split(v, sizes) for v in jitter.take(perm)]
                factors = torch.split(jitter.factors(n, spec.gain_jitter, rng), sizes)
            for i, size in enumerate(sizes):
                batch = unpack({k: v[i] for k, v in shuffled.items()})
                z = batch["z"]
                if jitter is not None:  # the same rows seen by a unit of another gain
                    z = jitter.z([v[i] for v in parts], factors[i])
                if swap is not None:  # region from the evidence now, not the press's history
                    z, batch = swap.apply(z, batch, gen)
                if spec.input_noise > 0:  # regularises against press-specific detail
                    z = z + spec.input_noise * torch.randn(z.shape, generator=gen)
                loss = loss_of(net(z), batch)
                opt.zero_grad(set_to_none=True)
                loss.backward()
                opt.step()
                sched.step()
                if avg is not None:
                    avg.update_parameters(net)
                total += float(loss.detach()) * size
            history.append(total / n)
            if va["z"].shape[0]:
                model = avg.module if avg is not None else net
                model.eval()
                with torch.no_grad():
                    val_history.append(float(loss_of(model(va["z"]), va)))
                if spec.best_val and val_history[-1] <= min(val_history):
                    best = numpy_weights(model)
            if bar is not None:
                bar.set_postfix(loss=f"{history[-1]:.4f}")
                bar.update(1)
            elif callable(progress):
                progress(epoch + 1, history[-1])
    finally:
        if bar is not None:
            bar.close()
    final = avg.module if avg is not None else net
    return (best if best is not None else numpy_weights(final)), history, val_history


class HistorySwap:
    """Region labels taught on the evidence of the moment, not on the press's history.

    A network with temporal context shares one trunk between forces, which need the history
    (the elastomer creeps), and the region, which the skin's light pattern now decides. Left
    alone, the region head leans on the history too, and its decision drifts as a long press
    ages and the moving averages catch up (the demo's blocked split: best() misread presses
    late in their hold that the recipe without context read right). So in each batch a share
    `spec.region_history_swap` of the labelled rows gets the history features (lag and
    moving-average deltas) of another row of the batch, and on those rows only the class
    loss counts: the network cannot tell them from real rows, so it learns a region that the
    history does not move, while forces keep learning from the untouched rows. Training
    only: inference is unchanged.
    """

    def __init__(self, share: float, columns: NDArray[np.intp], n_features: int) -> None:
        import torch

        self.share = share
        self.history = torch.zeros(n_features, dtype=torch.bool)  # the columns to swap
        self.history[torch.as_tensor(columns, dtype=torch.long)] = True

    @classmethod
    def of(cls, spec: TrainSpec, p: Plan) -> HistorySwap | None:
        """The swap for `spec`, or None when it is off or the features carry no history."""
        cols = history_columns(p.features, p.layout)
        if spec.region_history_swap <= 0 or cols.size == 0:
            return None
        return cls(spec.region_history_swap, cols, p.features.n_features)

    def apply(self, z: Any, batch: dict[str, Any], gen: Any) -> tuple[Any, dict[str, Any]]:
        """(features, batch) with the history of a share of the labelled rows swapped and
        their regression and contact losses turned off."""
        import torch

        n = z.shape[0]
        pick = (batch["label"] >= 0) & (torch.rand(n, generator=gen) < self.share)
        src = torch.where(pick, torch.randint(0, n, (n,), generator=gen), torch.arange(n))
        # one row gather and one select: a fraction of the step's time (a copy of the picked
        # rows' history columns through advanced indexing took three times as long)
        z = torch.where(self.history, z[src], z)
        keep = (~pick).to(z.dtype)
        return z, {**batch, "y_ok": batch["y_ok"] * keep, "contact_ok": keep}


def history_columns(features: Any, layout: Any) -> NDArray[np.intp]:
    """Feature columns that read the past (lag and moving-average deltas): the linear
    features with a weight on the assembled vector's lag or moving-average blocks."""
    base = layout.base
    past = slice(base, base * (1 + len(layout.lags) + len(layout.emas)))
    return np.flatnonzero(np.any(np.asarray(features.L)[:, past] != 0, axis=1)).astype(np.intp)


class GainJitter:
    """Gain augmentation in torch for the training rows `rows` of a GainView: its per-row
    parts become tensors once; a batch's jittered features are then a few element-wise
    operations on its slice of them (in float64, as GainView.z computes them, then float32)."""

    def __init__(self, view: Any, rows: NDArray[np.intp]) -> None:
        import torch

        # float64 once here, not per batch: z() computes in float64, and converting every
        # batch's slice cost a fresh allocation per step (half the demo's page faults)
        parts = [a for a in view.parts(rows) if a is not None]
        self.parts = [torch.from_numpy(np.asarray(a, np.float64)) for a in parts]
        self.has_rat = len(self.parts) == 3
        self.c_lin = torch.from_numpy(np.asarray(view.c_lin, np.float64))
        self.mon = torch.from_numpy(np.asarray(view.mon, np.int64))
        self.mean = torch.from_numpy(np.asarray(view.mean, np.float64))
        self.std = torch.from_numpy(np.asarray(view.std, np.float64))

    def take(self, idx: Any) -> list[Any]:
        """The parts of the rows at positions `idx` (a tensor into `rows`)."""
        return [a[idx] for a in self.parts]

    @staticmethod
    def factors(n: int, g: float, rng: np.random.Generator) -> Any:
        """One gain per row from [1 - g, 1 + g] for an epoch of `n` rows, drawn at once (the
        same stream as drawing them batch by batch)."""
        import torch

        return torch.from_numpy(rng.uniform(1.0 - g, 1.0 + g, size=(n, 1)))

    def z(self, parts: list[Any], factor: Any) -> Any:
        """z-scored features (float32 tensor) of rows with parts `parts` (from `take`) under
        `factor` ((rows, 1) float64 tensor): GainView.z's closed form."""
        import torch

        f = factor * parts[0].double() + (factor - 1.0) * self.c_lin
        if self.has_rat:
            rat = factor * parts[1].double() / (factor * parts[2].double() + EPS)
            f = torch.cat([f, rat], dim=1)
        if self.mon.shape[0]:
            padded = torch.cat([f, torch.ones_like(f[:, :1])], dim=1)
            f = torch.cat([f, torch.prod(padded[:, self.mon], dim=-1)], dim=1)
        return ((f - self.mean) / self.std).float()


def skip_init(data: dict[str, Any], rows: NDArray[np.intp], n_out: int) -> NDArray[np.float32]:
    """The linear skip's start (n_out, F): least squares of the scaled regression targets on
    the z-scored features over the rows with valid targets; zero for the other outputs. The
    network then learns the residual, and the skip keeps the linear trend it found."""
    z = np.asarray(data["z"][rows], np.float64)
    y = np.asarray(data["y"][rows], np.float64).reshape(rows.size, -1)
    ok = np.asarray(data["y_ok"][rows], bool)
    w = np.zeros((n_out, z.shape[1]), np.float32)
    if ok.any():
        zo, yo = z[ok], y[ok]
        # ridge, not plain least squares: the features are nearly collinear (raw counts and
        # their differences), and an unpenalised fit cancels huge weights against each other,
        # which float32 inference cannot reproduce
        gram = zo.T @ zo + SKIP_RIDGE * zo.shape[0] * np.eye(zo.shape[1])
        w[: y.shape[1]] = np.linalg.solve(gram, zo.T @ yo).T
    return w


def numpy_weights(net: Any) -> dict[str, NDArray[np.float32]]:
    """A torch module's parameters as float32 arrays, by name (the Runtime's weights)."""
    return {k: v.detach().cpu().numpy().astype(np.float32) for k, v in net.state_dict().items()}


def laplace_nll(err: Any, log_std: Any) -> Any:
    """Laplace negative log-likelihood per element (torch tensors), with std = sqrt(2) b."""
    import torch

    log_b = log_std - 0.5 * math.log(2.0)
    return err.abs() * torch.exp(-log_b) + log_b
