"""The decoder's assembled input vector: what one row of the network's input holds.

A sample lit by LED step s carries only that step's C counts. The assembled vector of a
sample is the latest sample of every step (S x C, step-major), then the same vector at each
past lag (temporal context), then exponential moving averages of it with time constants
`emas` (samples; slow context such as elastomer creep), then the running no-contact
baseline (drift compensation):

    u = [x_t, x_{t-lag1}, ..., ema_tau1, ..., b_t]   length D = S*C*(1 + lags + emas + drift)

Everything after assembly (features, normalisation, network) is stateless and is what the
exports (ONNX, TorchScript, C, NumPy runtime) compute.

>>> lay = Layout(channels=("a", "b"), steps=2, lags=(1,), drift=True)
>>> lay.base, lay.size
(4, 12)
>>> lay.names()[:5]
['a@0', 'b@0', 'a@1', 'b@1', 'a@0[t-1]']
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Layout:
    channels: tuple[str, ...]  # per-sample input names (C)
    steps: int = 1  # LED steps in the sequence (S)
    lags: tuple[int, ...] = ()  # temporal context lags in samples
    drift: bool = False  # running baseline appended
    emas: tuple[float, ...] = ()  # time constants (samples) of moving averages appended
    # the skin at rest and the direction a press moves it (decode.rest_signature); empty:
    # the baseline starts on the first sample, as models made before it did
    rest: tuple[float, ...] = ()
    press: tuple[float, ...] = ()

    @property
    def base(self) -> int:
        """Length of one assembled sample, S*C."""
        return self.steps * len(self.channels)

    @property
    def size(self) -> int:
        return self.base * (1 + len(self.lags) + len(self.emas) + int(self.drift))

    @property
    def trivial(self) -> bool:
        """True when the assembled vector is just the sample (no steps, context or baseline)."""
        return self.steps == 1 and not self.lags and not self.emas and not self.drift

    def step_names(self) -> list[str]:
        if self.steps == 1:
            return list(self.channels)
        return [f"{c}@{s}" for s in range(self.steps) for c in self.channels]

    def names(self) -> list[str]:
        cur = self.step_names()
        out = list(cur)
        for lag in self.lags:
            out += [f"{n}[t-{lag}]" for n in cur]
        for tau in self.emas:
            out += [f"ema{tau:g}:{n}" for n in cur]
        if self.drift:
            out += [f"base:{n}" for n in cur]
        return out

    def to_dict(self) -> dict[str, Any]:
        return {
            "channels": list(self.channels),
            "steps": self.steps,
            "lags": list(self.lags),
            "drift": self.drift,
            "emas": list(self.emas),
            "rest": list(self.rest),
            "press": list(self.press),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Layout:
        return cls(
            tuple(d["channels"]),
            int(d["steps"]),
            tuple(d["lags"]),
            bool(d["drift"]),
            tuple(float(t) for t in d.get("emas", ())),
            tuple(float(v) for v in d.get("rest", ())),
            tuple(float(v) for v in d.get("press", ())),
        )
