"""Fits side by side (spectratac.train.parallel): the models are those of the same fits run
one by one in this process, the work really happens in the workers, the caller hears of
every epoch, and a fit's error reaches the caller as itself."""

from __future__ import annotations

import os

import numpy as np
import pytest
from spectratac import threads
from spectratac.dataset import Dataset
from spectratac.decode.errors import DecoderDataError
from spectratac.train import TrainSpec
from spectratac.train.parallel import FitJob, FitPool, fit_threads, workers_for

pytestmark = pytest.mark.train

SMALL = {"epochs": 2, "hidden": 16, "blocks": 1, "seed": 3}


@pytest.fixture(scope="module")
def twin() -> Dataset:
    from spectratac.sim import twin_dataset
    from spectratac.twin import builtin_scenes, generate_session

    scene = builtin_scenes.calibration_session(seed=0, duration_s=60.0)
    return twin_dataset.from_twin_session(generate_session(scene, seed=0), scene)


def _jobs(ds: Dataset) -> list[FitJob]:
    rows = np.arange(int(0.8 * ds.n))
    # best() has every costly part: context, drift, augmentation, gain jitter, averaging
    return [FitJob(TrainSpec.best(**SMALL), rows), FitJob(TrainSpec.paper(**SMALL), rows[::2])]


def test_fits_in_two_workers_give_the_models_of_the_same_fits_run_here(twin: Dataset) -> None:
    runs = {}
    for workers in (2, 1):
        with FitPool(len(_jobs(twin)), workers) as pool:
            index = [pool.submit(twin, job) for job in _jobs(twin)]
            runs[workers] = [pool.result(i) for i in index]
    here, there = runs[1], runs[2]
    assert {f.pid for f in here} == {os.getpid()}
    assert os.getpid() not in {f.pid for f in there}
    for a, b in zip(here, there, strict=True):
        wa, wb = a.decoder.runtime.weights, b.decoder.runtime.weights
        assert sorted(wa) == sorted(wb)
        for name in wa:
            np.testing.assert_array_equal(wa[name], wb[name], err_msg=name)
        assert a.decoder.meta["spec"] == b.decoder.meta["spec"]


def test_every_fit_has_the_threads_it_has_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    # a fit's figures depend on its threads: a fit run beside others keeps those of a fit
    # run alone (the demo's table stays what one fit after another gave)
    monkeypatch.delenv(threads.ENV, raising=False)
    assert fit_threads(cpus=2) == threads.decide(2, 1).threads == 2
    assert (workers_for(4, cpus=1), workers_for(4, cpus=2), workers_for(4, cpus=16)) == (1, 2, 4)


def test_the_users_thread_count_wins(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(threads.ENV, "1")
    assert fit_threads(cpus=2) == 1
    assert workers_for(jobs=4, cpus=2) == 2


def test_the_caller_hears_every_epoch_of_every_fit(twin: Dataset) -> None:
    heard: dict[int, list[int]] = {}
    with FitPool(2, 2) as pool:
        index = [pool.submit(twin, job) for job in _jobs(twin)]
        for i in index:
            pool.result(i, lambda job, epoch: heard.setdefault(job, []).append(epoch))
    assert heard == {0: [1, 2], 1: [1, 2]}


def test_a_fits_error_reaches_the_caller_as_itself(twin: Dataset) -> None:
    with FitPool(2, 2) as pool:
        bad = pool.submit(twin, FitJob(TrainSpec.paper(**SMALL), np.arange(1)))
        with pytest.raises(DecoderDataError, match="at least 2 training rows"):
            pool.result(bad)
