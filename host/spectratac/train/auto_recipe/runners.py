"""Where trials run: in this process, in local worker processes, or on a Ray cluster.

All three have one interface: `submit(job)` starts a trial, `done(timeout)` returns the
finished ones as (job, result or the exception it raised). Local workers each get the dataset
once (at start-up) and their share of the CPUs under the thread policy (`spectratac.threads`:
one thread each for two trials on two cores), so that trials do not fight over the cores.
Ray is imported only by `RayRunner` (`--ray ADDRESS`).
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
from typing import Any

from spectratac import threads
from spectratac.dataset.schema import Dataset
from spectratac.train.auto_recipe.trial import TrialJob, run_trial

Finished = list[tuple[TrialJob, dict[str, Any] | BaseException]]


class InlineRunner:
    """Runs each trial at submission, in this process (one worker)."""

    name = "inline"
    workers = 1

    def __init__(self, ds: Dataset) -> None:
        self.ds = ds
        self._done: Finished = []

    def submit(self, job: TrialJob) -> None:
        try:
            self._done.append((job, run_trial(self.ds, job)))
        except Exception as exc:  # a failing candidate is reported, the search goes on
            self._done.append((job, exc))

    def done(self, timeout: float | None = None) -> Finished:
        out, self._done = self._done, []
        return out

    @property
    def busy(self) -> int:
        return 0

    def close(self) -> None:
        """Nothing to release."""


_WORKER_DS: Dataset | None = None


def _init_worker(ds: Dataset, workers: int) -> None:
    global _WORKER_DS
    _WORKER_DS = ds
    threads.apply(workers)  # this worker's share, before its trials import torch


def _run_in_worker(job: TrialJob) -> dict[str, Any]:
    assert _WORKER_DS is not None, "worker started without its dataset"
    return run_trial(_WORKER_DS, job)


class LocalRunner:
    """Trials in `workers` local processes (spawned: no torch state is inherited)."""

    name = "local"

    def __init__(self, ds: Dataset, workers: int) -> None:
        self.workers = max(1, workers)
        # Spawned children inherit this environment: their share from the first import on.
        threads.apply(self.workers)
        ctx = multiprocessing.get_context("spawn")
        self._pool = cf.ProcessPoolExecutor(
            self.workers, mp_context=ctx, initializer=_init_worker, initargs=(ds, self.workers)
        )
        self._running: dict[cf.Future[dict[str, Any]], TrialJob] = {}

    def submit(self, job: TrialJob) -> None:
        self._running[self._pool.submit(_run_in_worker, job)] = job

    def done(self, timeout: float | None = None) -> Finished:
        if not self._running:
            return []
        finished, _ = cf.wait(self._running, timeout, return_when=cf.FIRST_COMPLETED)
        out: Finished = []
        for fut in finished:
            job = self._running.pop(fut)
            exc = fut.exception()
            out.append((job, exc if exc is not None else fut.result()))
        return out

    @property
    def busy(self) -> int:
        return len(self._running)

    def close(self) -> None:
        for fut in self._running:
            fut.cancel()
        self._pool.shutdown(wait=True, cancel_futures=True)
        threads.apply(1)  # the workers are gone: this process computes alone again


class RayRunner:
    """Trials as Ray tasks (one CPU each) on the cluster at `address` ("auto", "local" for a
    new local instance, or host:port); the dataset is put in the object store once."""

    name = "ray"

    def __init__(self, ds: Dataset, address: str) -> None:
        import ray

        self._ray = ray
        if not ray.is_initialized():
            kw: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
            if address == "local":
                ray.init(**kw)
            else:
                ray.init(address=address, **kw)
        self.workers = max(1, int(ray.cluster_resources().get("CPU", 1)))
        self._ds_ref = ray.put(ds)
        self._task = ray.remote(num_cpus=1)(run_trial)
        self._running: dict[Any, TrialJob] = {}

    def submit(self, job: TrialJob) -> None:
        self._running[self._task.remote(self._ds_ref, job)] = job

    def done(self, timeout: float | None = None) -> Finished:
        if not self._running:
            return []
        ready, _ = self._ray.wait(list(self._running), num_returns=1, timeout=timeout)
        out: Finished = []
        for ref in ready:
            job = self._running.pop(ref)
            try:
                out.append((job, self._ray.get(ref)))
            except Exception as exc:  # the task's own error, re-raised by ray.get
                out.append((job, exc))
        return out

    @property
    def busy(self) -> int:
        return len(self._running)

    def close(self) -> None:
        for ref in self._running:
            self._ray.cancel(ref)
        self._running.clear()
