"""Independent trainings at once: `FitPool` runs `train` jobs in worker processes, one per
CPU up to the number of jobs.

Why: the demo trains four decoders (two recipes, two splits) that do not depend on each
other, and a small network gains only ~1.5x from a second thread, so two processes on two
cores finish the four fits sooner than one process doing them in turn.

A job's model does not depend on how the jobs are spread: every job computes with the
threads it would have alone on this machine (the thread policy's share of one process,
`fit_threads`), in a worker or, with one worker, in this process, so its weights are those
of the same fit run alone, bit for bit (tests/train/test_parallel_fits.py): the threads
change the order of torch's sums, and 40 epochs turn that into other figures. The workers'
threads then outnumber the cores; waiting OpenMP threads sleep (the policy's
OMP_WAIT_POLICY=PASSIVE) rather than spin, so this costs the cores little.
SPECTRATAC_THREADS=1 gives every fit one thread instead (other figures than the default).
Workers are spawned (no torch state is inherited); a job carries its dataset.

>>> fit_threads(cpus=2), workers_for(jobs=4, cpus=2), workers_for(jobs=4, cpus=16)
(2, 2, 4)
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac import threads
from spectratac.dataset.schema import Dataset
from spectratac.train.fitting import train

#: Called with (job index, epochs done) as a job's epochs finish, in the submitting process.
EpochTick = Callable[[int, int], None]


def fit_threads(cpus: int | None = None) -> int:
    """Torch threads of every job: those of a process computing alone (SPECTRATAC_THREADS,
    if set, wins as everywhere)."""
    cpus = threads.usable_cpus() if cpus is None else cpus
    return threads.decide(cpus, 1, os.environ.get(threads.ENV)).threads


def workers_for(jobs: int, cpus: int | None = None) -> int:
    """Worker processes for `jobs` jobs: one per job, at most one per CPU."""
    cpus = threads.usable_cpus() if cpus is None else cpus
    return max(1, min(jobs, cpus))


@dataclass(frozen=True)
class FitJob:
    """One `train(dataset, spec, rows=rows)`."""

    spec: Any
    rows: NDArray[np.intp]


@dataclass(frozen=True)
class Fitted:
    """A job's decoder, its training wall time (s) measured where it ran, and that process."""

    decoder: Any
    seconds: float
    pid: int


_WORKER_TICKS: Any = None


def _init_worker(ticks: Any) -> None:
    global _WORKER_TICKS
    _WORKER_TICKS = ticks
    threads.apply(1)  # each job computes as if alone (see above); before torch is imported


def warm_up() -> None:
    """Import torch and the training loop and run one optimiser step: a process's one-time
    costs (~2 s quiet, 8 s at load 15), paid by each worker while the demo still records."""
    import torch

    from spectratac.train import torch_loop  # noqa: F401  (its imports: AdamW, weight averaging)

    net = torch.nn.Linear(4, 2)
    opt = torch.optim.AdamW(net.parameters(), fused=True)
    net(torch.zeros(8, 4)).sum().backward()
    opt.step()


def _fit(ds: Dataset, job: FitJob, index: int, ticks: Any) -> Fitted:
    def tick(epoch: int, _loss: float) -> None:
        if ticks is not None:
            ticks.put((index, epoch))

    t0 = time.perf_counter()
    decoder = train(ds, job.spec, rows=job.rows, progress=tick)
    return Fitted(decoder, time.perf_counter() - t0, os.getpid())


def _fit_in_worker(ds: Dataset, job: FitJob, index: int) -> Fitted:
    return _fit(ds, job, index, _WORKER_TICKS)


class FitPool:
    """Submit `FitJob`s; `result(i)` waits for the i-th. The workers start (and warm up) at
    construction, so a pool made before the data exists is ready when it does. With one
    worker the jobs run in this process, one by one, when their result is asked for."""

    def __init__(self, jobs: int, workers: int | None = None) -> None:
        self.workers = workers_for(jobs) if workers is None else max(1, workers)
        self._jobs: list[tuple[Dataset, FitJob]] = []
        self._futures: list[cf.Future[Fitted]] = []
        self._done: dict[int, Fitted] = {}
        self._ticks: Any = None
        self._pool: cf.ProcessPoolExecutor | None = None
        if self.workers > 1:
            ctx = multiprocessing.get_context("spawn")
            # put writes to the pipe at once: a job's last tick is there before its result
            self._ticks = ctx.SimpleQueue()
            self._pool = cf.ProcessPoolExecutor(
                self.workers,
                mp_context=ctx,
                initializer=_init_worker,
                initargs=(self._ticks,),
            )
            for _ in range(self.workers):  # a worker is spawned per task no idle one takes
                self._pool.submit(warm_up)

    def submit(self, ds: Dataset, job: FitJob) -> int:
        """Queue `job` on `ds`; its index for `result`."""
        index = len(self._jobs)
        self._jobs.append((ds, job))
        if self._pool is not None:
            self._futures.append(self._pool.submit(_fit_in_worker, ds, job, index))
        return index

    def result(self, index: int, tick: EpochTick | None = None) -> Fitted:
        """The i-th job's result, reporting every job's finished epochs to `tick` meanwhile."""
        if index in self._done:
            return self._done[index]
        if self._pool is None:  # serial: run the jobs in order up to this one
            for i in range(len(self._done), index + 1):
                self._done[i] = _fit(*self._jobs[i], i, _Direct(tick))
            return self._done[index]
        fut = self._futures[index]
        while not fut.done():
            cf.wait([fut], timeout=0.2)
            self._drain(tick)
        self._drain(tick)
        self._done[index] = fut.result()
        return self._done[index]

    def _drain(self, tick: EpochTick | None) -> None:
        while not self._ticks.empty():
            i, epoch = self._ticks.get()
            if tick is not None:
                tick(i, epoch)

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
            self._ticks.close()

    def __enter__(self) -> FitPool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _Direct:
    """The serial path's stand-in for the workers' queue: ticks go straight to `tick`."""

    def __init__(self, tick: EpochTick | None) -> None:
        self.tick = tick

    def put(self, item: tuple[int, int]) -> None:
        if self.tick is not None:
            self.tick(*item)
