"""Does the held-out figure `spectratac train` prints predict the error on later sessions?

Twin sessions of one unit with ageing and re-mounting drift (`sim.twin_dataset.population`:
`SessionConditions`), in time order: a decoder is trained on the first `--train` sessions
and the figure `train` prints as the MAE to expect on a new session
(`HeldOutCheck.expected`: forward chaining) is set beside the error then measured on the
`--next` sessions that follow; the round-robin held-out figure is shown beside it. Target
(issue 22): the printed figure within 1.3x of the next sessions' error.

    PYTHONPATH=host python tools/bench/heldout_forward.py [--json] [--model ridge|paper]
"""

from __future__ import annotations

import numpy as np
from benchlib import Figure, parser, report
from spectratac.sim.twin_dataset import population
from spectratac.train import TrainSpec, fit

FORCES = ("Fx", "Fy", "Fz")


def main() -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--train", type=int, default=6, help="sessions trained on")
    p.add_argument("--next", type=int, default=2, help="later sessions scored")
    p.add_argument("--session-s", type=float, default=30.0)
    p.add_argument("--model", choices=("ridge", "paper"), default="ridge")
    p.add_argument("--epochs", type=int, default=10, help="--model paper")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args()
    ds = population([args.seed], args.train + args.next, args.session_s, seed=args.seed)
    spec = (
        TrainSpec(model="ridge", targets=FORCES)
        if args.model == "ridge"
        else TrainSpec.paper(epochs=args.epochs, targets=FORCES)
    )
    ses = np.asarray(ds.session, np.int64)
    first = ds.subset(np.flatnonzero(ses < args.train))
    trained = fit(first, spec, progress=False)
    expected, source = trained.check.expected()
    later = np.flatnonzero(ses >= args.train)
    est = trained.decoder.predict(ds, later)
    y = ds.targets[later][:, [ds.target_names.index(t) for t in FORCES]]
    cols = [trained.decoder.target_names.index(t) for t in FORCES]
    truth = np.nanmean(np.abs(est.targets[:, cols] - y), axis=0)
    figures = []
    for i, t in enumerate(FORCES):
        nxt = float(truth[i])
        figures.append(
            Figure(f"{t} printed figure ({args.model})", expected[t], "N MAE",
                   f"{t} MAE on the next {args.next} sessions", nxt, expected[t] / nxt,
                   {"source": source, "round_robin": trained.check.heldout_mae[t],
                    "round_robin_ratio": trained.check.heldout_mae[t] / nxt}),
        )  # fmt: skip
    report(figures, args.json)


if __name__ == "__main__":
    main()
