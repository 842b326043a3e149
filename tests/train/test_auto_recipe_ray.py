"""`search` on Ray: trials as tasks on a local Ray instance started by the test (its raylet
and workers are subprocess.Popen children of ray.init)."""

from __future__ import annotations

import os
import shutil
import tempfile

import pytest
from spectratac.sim.generic_skin import generic_skin
from spectratac.train import TrainSpec
from spectratac.train.auto_recipe import Candidate, search

pytestmark = [pytest.mark.train, pytest.mark.subprocess, pytest.mark.slow]


@pytest.fixture()
def ray_local():
    """A local Ray instance owned by this test (its own short temp dir: Ray's socket paths
    must stay under 108 characters), on the loopback address, shut down after."""
    import ray

    tmp = tempfile.mkdtemp(prefix="ray", dir="/tmp")
    os.environ["RAY_USAGE_STATS_ENABLED"] = "0"
    ray.init(num_cpus=2, include_dashboard=False, _temp_dir=tmp,
             _node_ip_address="127.0.0.1", log_to_driver=False)  # fmt: skip
    try:
        yield "local"
    finally:
        ray.shutdown()
        shutil.rmtree(tmp, ignore_errors=True)


def test_trials_run_as_ray_tasks(ray_local) -> None:
    ds = generic_skin(sessions=4, session_s=3.0, seed=5)
    ridge = TrainSpec(features="generic", model="ridge", targets=("Fz",))
    space = [Candidate("linear", "classical", ridge),
             Candidate("poly2", "classical", TrainSpec.from_dict({**ridge.to_dict(),
                                                                  "degree": 2}))]  # fmt: skip
    res = search(ds, 120.0, space=space, folds=2, ray_address=ray_local)
    assert res.report["runner"] == "ray" and res.report["workers"] == 2
    assert [c["status"] for c in res.report["candidates"]] == ["done", "done"]
    assert res.decoder.predict(ds).targets.shape == (ds.n, 1)
