"""The page's per-sample message and its raw-count thresholds: every channel (IR too) is
sent, the thresholds are the definitions' (never numbers of the page's own), and a session
without a model sends the same message with the estimate's fields null."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from spectratac.apps.live.messages import (
    ESTIMATE_FIELDS,
    estimate_message,
    raw_config,
)
from spectratac.decode.guard import DARK_COUNTS
from spectratac.hardware.generated import veml3328
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.protocol.generated.messages import SensorStatus

SHAPE = (vocab.N_SENSORS, len(vocab.CHANNELS))


def test_raw_config_carries_the_definitions_thresholds() -> None:
    raw = raw_config()
    assert raw["full_scale"] == veml3328.FULL_SCALE
    assert raw["dark_counts"] == DARK_COUNTS
    assert raw["channels"] == list(vocab.CHANNELS) and "IR" in raw["channels"]
    assert raw["sensors"] == vocab.N_SENSORS
    assert {bit for bit, _ in raw["status_bits"]} == {int(b) for b in SensorStatus}
    assert dict((name, bit) for bit, name in raw["status_bits"])["bus fault"] == 2


@settings(max_examples=60, deadline=None)
@given(counts=arrays(np.int64, SHAPE, elements=st.integers(0, veml3328.FULL_SCALE)))
def test_every_count_is_sent_and_flagged_against_the_thresholds(counts: np.ndarray) -> None:
    sample = SimpleNamespace(step=1, counts=counts, status=(0, 2, 8))
    msg = estimate_message(3, None, sample, 0.5, 1.0)
    assert msg["counts"] == counts.reshape(-1).tolist()  # R G B C IR of each sensor
    assert msg["saturated"] == (counts.reshape(-1) >= veml3328.FULL_SCALE).tolist()
    clear = counts[:, vocab.CHANNELS.index("C")]
    assert msg["dark"] == (clear < DARK_COUNTS).tolist()
    assert msg["status"] == [0, 2, 8] and msg["step"] == 1


def test_without_a_model_the_estimate_fields_are_null() -> None:
    sample = SimpleNamespace(step=0, counts=np.full(SHAPE, 500), status=(0, 0, 0))
    msg = estimate_message(0, None, sample, 0.0, 1.0)
    assert all(msg[k] is None for k in ESTIMATE_FIELDS)
    est = SimpleNamespace(force=[0.1, 0.2, -1.0], torque=[np.nan] * 3, region=5,
                          region_prob=0.9, contact=True, ood=False, invalid=False)  # fmt: skip
    decoded = estimate_message(0, est, sample, 0.0, 1.0)
    assert decoded["force"] == [0.1, 0.2, -1.0] and decoded["torque"] == [None] * 3
    assert decoded["counts"] == msg["counts"]
