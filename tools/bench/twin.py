"""Benchmark: generating the 50-minute calibration session (60,000 optical samples plus the
1 kHz F/T stream) against merely allocating its output arrays, side by side in one run.

    python -m tools.bench.twin [--json] [--rounds 3] [--busy 2]

Also times a population dataset (4 units x 3 sessions x 5 minutes, each session with its own
unit, mounting, temperature and ageing) against one session of the same simulated length, in
seconds per simulated minute, and one register-level integration window (three sensors
triggered together) against a bare NumPy call of similar size, the cost the
firmware-in-the-loop device pays per sample. With --busy N the session is generated again
beside N busy-loop processes (with its allocation reference), in the same run. The session's
figure also carries `cpu_s`, the best CPU time of one generation in this process, which a
neighbour's load (a CI run beside it) inflates far less than the wall time.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
from spectratac.sim.twin_dataset import from_twin_session, population
from spectratac.twin import builtin_scenes as scenes
from spectratac.twin import generate_session
from spectratac.twin.electronics import AF, TRIG, SensorConfig
from spectratac.twin.rig import TwinRig

from tools.bench import benchlib


def allocate_like(n: int, m: int) -> int:
    """Allocate (and touch) the arrays a session returns: the floor for any generator."""
    arrays = [
        np.empty(n),
        np.empty(n),
        np.empty(n, np.int16),
        np.empty((n, 3, 5), np.uint16),
        np.empty((n, 3), bool),
        np.empty(m),
        np.empty((m, 6)),
        np.empty((n, 6)),
        np.empty((n, 3)),
        np.empty((n, 2)),
        np.empty(n, bool),
        np.empty(n, np.int8),
    ]
    for a in arrays:
        a.fill(0)
    return n


def cpu_seconds(fn: Callable[[], int]) -> float:
    """CPU time this process spends in one call of `fn`."""
    t0 = time.process_time()
    fn()
    return time.process_time() - t0


def main() -> None:
    p = benchlib.parser(__doc__.splitlines()[0], busy=True)
    p.add_argument("--rounds", type=int, default=3)
    args = p.parse_args()
    scene = scenes.calibration_session(seed=0)
    first = generate_session(scene, seed=0)
    n, m = len(first), first.ft.shape[0]

    def gen() -> int:
        return len(generate_session(scene, seed=0))

    gen_rate, alloc_rate = benchlib.side_by_side(gen, lambda: allocate_like(n, m), args.rounds)
    gen_s, alloc_s = n / gen_rate, n / alloc_rate
    # This process's CPU time for one generation: what a neighbour's load inflates least.
    gen_cpu_s = min(cpu_seconds(gen) for _ in range(args.rounds))
    loaded: list[benchlib.Figure] = []
    if args.busy:
        with benchlib.busy_loops(args.busy):
            busy_rate, busy_alloc = benchlib.side_by_side(
                gen, lambda: allocate_like(n, m), args.rounds
            )
            load = benchlib.loadavg()
        loaded.append(
            benchlib.Figure(
                f"calibration session generation, {benchlib.load_label(args.busy)}",
                n / busy_rate,
                "s",
                "the quiet generation",
                gen_s,
                (n / busy_rate) / gen_s,
                {"allocate_outputs_s": n / busy_alloc, "loadavg": load},
            )
        )

    pop_units, pop_sessions, pop_s = [0, 1, 2, 3], 3, 300.0
    pop_minutes = len(pop_units) * pop_sessions * pop_s / 60.0
    long_scene = scenes.calibration_session(seed=0, duration_s=pop_minutes * 60.0)

    def pop() -> int:
        return population(pop_units, pop_sessions, pop_s).n

    def one_long() -> int:
        return from_twin_session(generate_session(long_scene, seed=0), long_scene).n

    pop_rate, long_rate = benchlib.side_by_side(pop, one_long, args.rounds)
    # Rates are in samples/s; a simulated minute is 1200 samples at 20 Hz.
    pop_per_min, long_per_min = 1200.0 / pop_rate, 1200.0 / long_rate

    rig = TwinRig(scenes.calibration_session(seed=0, duration_s=120.0), seed=0)
    rig.set_led_duties(0, np.full((3, 3), 0.25))
    conf = SensorConfig().to_conf() | AF | TRIG
    write = bytes([0x00, conf & 0xFF, conf >> 8])
    clock = [0]

    def windows() -> int:
        for _ in range(200):
            t = clock[0]
            for dev in rig.sensors:
                dev.transfer(t, write, 0)
            t += 50_000
            for dev in rig.sensors:
                for reg in (0x04, 0x05, 0x06, 0x07, 0x08):
                    dev.transfer(t, bytes([reg]), 2)
            clock[0] = (t + 1_000) % 100_000_000
        return 200

    x = np.random.default_rng(0).random((5, 27))

    def numpy_ref() -> int:
        for _ in range(200):
            (x * x).sum(axis=0)
        return 200

    win_rate, ref_rate = benchlib.side_by_side(windows, numpy_ref, args.rounds)
    benchlib.report(
        [
            benchlib.Figure(
                "calibration session generation",
                gen_s,
                "s",
                "allocate outputs",
                alloc_s,
                gen_s / alloc_s,
                {
                    "samples": n,
                    "ft_samples": m,
                    "budget_s": 1.5,
                    "cpu_s": gen_cpu_s,
                    "loadavg": benchlib.loadavg(),
                },
            ),
            *loaded,
            benchlib.Figure(
                "population dataset, 4 units x 3 sessions x 300 s",
                pop_per_min,
                "s per simulated minute",
                "one session as long, as a dataset",
                long_per_min,
                pop_per_min / long_per_min,
                {"sessions": len(pop_units) * pop_sessions, "simulated_min": pop_minutes},
            ),
            benchlib.Figure(
                "register-level window, 3 sensors",
                1e6 / win_rate,
                "us",
                "numpy (5,27) square+sum",
                1e6 / ref_rate,
                ref_rate / win_rate,
                {"windows_per_s": win_rate},
            ),
        ],
        args.json,
    )


if __name__ == "__main__":
    main()
