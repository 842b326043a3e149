"""The thread policy (spectratac.threads): its decisions, and that every process honours it:
trial workers of the auto recipe get one thread each on two CPUs, and streaming through the
CLI (which applies the policy) still never imports torch."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from spectratac import threads
from spectratac.sim.generic_skin import generic_skin
from spectratac.train import TrainSpec
from spectratac.train.auto_recipe.runners import LocalRunner
from spectratac.train.auto_recipe.trial import TrialJob


@pytest.mark.parametrize(
    ("cpus", "workers", "override", "expected", "source"),
    [
        (2, 1, None, 2, "share"),  # alone on two CPUs: both
        (2, 2, None, 1, "share"),  # the auto recipe's two trials: one each
        (2, 3, None, 1, "share"),  # more workers than CPUs: never below one
        (1, 1, None, 1, "share"),  # taskset to one CPU
        (8, 3, None, 2, "share"),  # the remainder stays free
        (0, 0, None, 1, "share"),  # nonsense counts are clamped, not trusted
        (2, 2, "3", 3, threads.ENV),  # the user's number wins
        (2, 1, " 1 ", 1, threads.ENV),
        (2, 1, "", 2, "share"),  # set but empty: as if unset
    ],
)
def test_decisions(cpus, workers, override, expected, source) -> None:
    p = threads.decide(cpus, workers, override)
    assert (p.threads, p.source) == (expected, source)
    assert p.env() == {v: str(expected) for v in threads.LIBRARY_VARS}


@pytest.mark.parametrize("bad", ["0", "-2", "two", "1.5"])
def test_a_bad_override_says_what_to_give(bad) -> None:
    with pytest.raises(threads.ThreadsConfigError, match="positive integer"):
        threads.decide(2, 1, bad)


def test_children_inherit_the_share_and_a_sleeping_wait_policy() -> None:
    p, env = threads.child_env(2, {"PATH": "/bin"})
    assert p.workers == 2 and env["PATH"] == "/bin"
    assert env["OMP_NUM_THREADS"] == env["MKL_NUM_THREADS"] == str(p.threads)
    assert env["OMP_WAIT_POLICY"] == "PASSIVE"
    _, env = threads.child_env(2, {"OMP_WAIT_POLICY": "ACTIVE", threads.ENV: "4"})
    assert env["OMP_WAIT_POLICY"] == "ACTIVE" and env["OMP_NUM_THREADS"] == "4"


def test_the_share_counts_only_cpus_this_process_may_use() -> None:
    assert threads.usable_cpus() == len(os.sched_getaffinity(0))


@pytest.mark.train
@pytest.mark.subprocess
def test_each_trial_process_of_the_local_runner_gets_its_share(monkeypatch) -> None:
    """One trial per CPU at once: one torch thread each, not torch's default of one per core
    each (two such processes on two cores ran 180x slower than one thread each)."""
    monkeypatch.delenv(threads.ENV, raising=False)
    workers = max(2, threads.usable_cpus())
    ds = generic_skin(sessions=2, session_s=2.0, seed=1)
    spec = TrainSpec.paper(features="generic", targets=("Fz",), model="mlp", hidden=8,
                           blocks=1, epochs=1)  # fmt: skip
    rows = np.arange(ds.n)
    folds = [(rows[: ds.n // 2], rows[ds.n // 2 :])]
    runner = LocalRunner(ds, workers=workers)
    try:
        for name in map(str, range(workers)):
            runner.submit(TrialJob(name, spec.to_dict(), folds, 0, {"Fz": 1.0}))
        results = []
        while runner.busy:
            results += runner.done(timeout=300)
    finally:
        runner.close()
    assert len(results) == workers, "the trials did not all finish within 300 s each"
    for job, res in results:
        assert not isinstance(res, BaseException), f"trial {job.name} failed: {res}"
        assert res["threads"] == 1, f"trial {job.name} ran torch on {res['threads']} threads"


@pytest.mark.subprocess
def test_streaming_through_the_cli_applies_the_policy_without_torch() -> None:
    code = (
        "import os, sys\n"
        "from spectratac.cli import main\n"
        "rc = main(['stream', 'sim://?scene=idle&speed=max', '--count', '3', '--format', 'csv'])\n"
        "print(rc, 'torch' in sys.modules, os.environ['OMP_NUM_THREADS'], file=sys.stderr)\n"
    )
    env = {k: v for k, v in os.environ.items() if k not in threads.LIBRARY_VARS}
    env[threads.ENV] = "1"
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300
    )
    assert out.returncode == 0, out.stderr
    assert out.stderr.split()[-3:] == ["0", "False", "1"]
