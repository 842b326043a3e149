"""The search space of `--recipe auto`: classical baselines first, then networks, cheap first.

Every candidate is a `TrainSpec` built from the data's features and targets plus a few
changes. The classical ones (linear and polynomial ridge, closed form) are always tried and
always reported; the networks span the paper's ResMLP, smaller and larger ones, temporal
context, the drift baseline and training-only regularisation; on SpectraTac features also
`TrainSpec.best()` (rotation and mirror augmentation: six times the training).

>>> [c.name for c in candidates("generic", ("Fz",))][:3]
['linear', 'linear+drift', 'poly2']
>>> c = candidates("generic", ("Fz",))[-1]
>>> c.family, c.spec.model
('network', 'resmlp')
>>> candidates("paper33", ("Fz",))[-1].spec.augment
'rotate+mirror'
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from spectratac.train.spec import TrainSpec

NETWORK_EPOCHS = 30


@dataclass(frozen=True)
class Candidate:
    name: str
    family: str  # "classical" | "network"
    spec: TrainSpec

    @property
    def classical(self) -> bool:
        return self.family == "classical"


def _ridge(features: str, targets: tuple[str, ...], **kw: Any) -> TrainSpec:
    return TrainSpec(features=features, model="ridge", targets=targets, **kw)


def _net(features: str, targets: tuple[str, ...], **kw: Any) -> TrainSpec:
    base: dict[str, Any] = {"threads": 0, "epochs": NETWORK_EPOCHS}
    return TrainSpec.paper(features=features, targets=targets, **{**base, **kw})


def candidates(
    features: str, targets: tuple[str, ...], regression: tuple[str, ...] | None = None
) -> list[Candidate]:
    """The candidates for data with feature kind `features` decoding `targets`; the classical
    ones decode the regression targets `regression` (default: all of `targets`)."""
    reg = tuple(targets if regression is None else regression)
    ctx = {"context": 8, "context_ema": (10.0, 40.0, 160.0), "drift": "baseline"}
    out = []
    if reg:
        for degree, label in ((1, "linear"), (2, "poly2"), (3, "poly3")):
            out.append(Candidate(label, "classical", _ridge(features, reg, degree=degree)))
            if degree < 3:  # cubic over the paper's and the baseline's 57: 34,219 monomials
                out.append(
                    Candidate(
                        f"{label}+drift",
                        "classical",
                        _ridge(features, reg, degree=degree, drift="baseline"),
                    )
                )
    nets = [
        ("mlp64x2", {"model": "mlp", "hidden": 64, "blocks": 2}),
        ("mlp64x2+drift", {"model": "mlp", "hidden": 64, "blocks": 2, "drift": "baseline"}),
        ("resmlp64x2+context", {"hidden": 64, "blocks": 2, **ctx}),
        (
            "resmlp64x2+context+reg",
            {
                "hidden": 64,
                "blocks": 2,
                "weight_decay": 0.05,
                "input_noise": 0.05,
                "weight_average": 0.999,
                **ctx,
            },
        ),
        ("paper", {}),
        ("resmlp128x2+context", {"blocks": 2, "batch_size": 256, "weight_decay": 0.05, **ctx}),
    ]
    out += [Candidate(n, "network", _net(features, targets, **kw)) for n, kw in nets]
    if features == "paper33":  # SpectraTac: our best recipe, with the symmetry augmentation
        out.append(Candidate("best", "network", TrainSpec.best(targets=targets, threads=0)))
    return out
