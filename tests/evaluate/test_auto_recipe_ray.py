"""`search` on Ray: trials as tasks on a local Ray instance started by the test."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from spectratac.decode import TrainSpec
from spectratac.evaluate.auto_recipe import Candidate, search
from spectratac.sim.generic_skin import generic_skin

pytestmark = [pytest.mark.train, pytest.mark.subprocess, pytest.mark.slow]


@pytest.fixture()
def ray_head(tmp_path):
    """A Ray head on this machine (`ray start --head`, its own temp dir), stopped after."""
    ray_bin = os.path.join(os.path.dirname(sys.executable), "ray")
    tmp = tmp_path / "ray"
    port = "6391"
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}
    subprocess.run(
        [ray_bin, "start", "--head", f"--port={port}", "--num-cpus=2", f"--temp-dir={tmp}",
         "--include-dashboard=false", "--disable-usage-stats"],
        check=True, capture_output=True, env=env, timeout=180,
    )  # fmt: skip
    try:
        yield f"127.0.0.1:{port}"
    finally:
        import ray

        ray.shutdown()
        subprocess.run([ray_bin, "stop", "--force"], capture_output=True, env=env, timeout=120)


def test_trials_run_as_ray_tasks(ray_head) -> None:
    ds = generic_skin(sessions=4, session_s=3.0, seed=5)
    ridge = TrainSpec(features="generic", model="ridge", targets=("Fz",))
    space = [Candidate("linear", "classical", ridge),
             Candidate("poly2", "classical", TrainSpec.from_dict({**ridge.to_dict(),
                                                                  "degree": 2}))]  # fmt: skip
    res = search(ds, 120.0, space=space, folds=2, ray_address=ray_head)
    assert res.report["runner"] == "ray" and res.report["workers"] == 2
    assert [c["status"] for c in res.report["candidates"]] == ["done", "done"]
    assert res.decoder.predict(ds).targets.shape == (ds.n, 1)
