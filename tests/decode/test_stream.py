"""`Decoder.stream` decodes a live (simulated) sensor sample by sample, checking its config."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from spectratac.decode import DecoderConfigError, Estimate
from spectratac.device import Sensor
from spectratac.train import TrainSpec, train

pytestmark = pytest.mark.train

TINY = {"epochs": 3, "hidden": 16, "blocks": 1, "threads": 1, "batch_size": 256}


def test_stream_yields_live_estimates(twin_ds) -> None:
    spec = TrainSpec.paper(targets=("Fx", "Fy", "Fz", "region", "contact"), context=2, **TINY)
    dec = train(twin_ds, spec, progress=False)
    leds = twin_ds.meta["config"]["leds"]
    with Sensor.open("sim://?scene=tour&seed=3&speed=max") as sensor:
        sensor.configure(integration_ms=50, leds=leds)
        sensor.start()
        got = list(itertools.islice(dec.stream(sensor), 40))
        sensor.stop()
    assert len(got) == 40 and all(isinstance(e, Estimate) for e in got)
    assert all(not e.invalid for e in got)
    assert all(np.isfinite(e.force).all() and np.isnan(e.torque).all() for e in got)
    assert all(1 <= e.region <= 9 and 0 <= e.contact_prob <= 1 for e in got)
    times = [e.time for e in got]
    assert times == sorted(times)
    # the same samples through the batch path give the same numbers (float32 tolerance)
    e = got[-1]
    assert e.targets.shape == (3,) and e.std is None


def test_stream_refuses_another_configuration(twin_ds) -> None:
    dec = train(twin_ds, TrainSpec.paper(**TINY), progress=False)
    with Sensor.open("sim://?scene=tour&seed=3&speed=max") as sensor:
        sensor.configure(integration_ms=100, leds=twin_ds.meta["config"]["leds"])
        sensor.start()
        with pytest.raises(DecoderConfigError, match="integration_ms: trained 50, got 100"):
            next(dec.stream(sensor))
        sensor.stop()


class ReplaySensor:
    """Plays dataset rows back as Sensor samples (what Decoder.stream consumes)."""

    def __init__(self, ds, n: int) -> None:
        from spectratac.device.records import Sample

        self.config = ds.meta["config"]
        self.samples = [
            Sample(
                int(ds.t_end[i] * 1e6),
                int(ds.t_start[i] * 1e6),
                float(ds.t_end[i]),
                i,
                int(ds.step[i]),
                1,
                tuple(map(tuple, ds.counts[i].tolist())),
                tuple(ds.status[i].tolist()),
            )
            for i in range(n)
        ]

    def get_config(self) -> dict:
        return self.config

    def __iter__(self):
        return iter(self.samples)


def test_stream_equals_batch_prediction_with_context_and_baseline(twin_ds) -> None:
    spec = TrainSpec.paper(context=3, context_dilated=True, drift="baseline", uncertainty=True,
                           **TINY)  # fmt: skip
    dec = train(twin_ds, spec, progress=False)
    n = 500
    live = list(dec.stream(ReplaySensor(twin_ds, n)))
    batch = dec.predict(twin_ds, rows=np.arange(n))
    np.testing.assert_allclose(np.stack([e.targets for e in live]), batch.targets,
                               rtol=1e-5, atol=1e-5)  # fmt: skip
    np.testing.assert_allclose(np.stack([e.std for e in live]), batch.std, rtol=1e-4, atol=1e-5)
    assert [e.region for e in live] == batch.region.tolist()
    assert [e.ood for e in live] == batch.ood.tolist()
    assert [e.contact for e in live] == batch.contact.tolist()
