"""Batching and weight averaging of the training loop (regressions: a 1-row remainder batch
and a fixed averaging decay both ruined short runs)."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.train.torch_loop import average_decay, batch_sizes

pytestmark = pytest.mark.train


@settings(deadline=None)  # no wall-clock limit: the machine is shared (up to 200k sizes)
@given(st.integers(1, 200_000), st.integers(1, 4096))
def test_batches_cover_every_row_once_in_near_equal_sizes(n: int, batch_size: int) -> None:
    sizes = batch_sizes(n, batch_size)
    assert sum(sizes) == n
    assert len(sizes) == -(-n // batch_size)  # as many optimiser steps as plain batching
    assert max(sizes) <= batch_size
    assert max(sizes) - min(sizes) <= 1  # no short remainder batch


def test_a_one_row_remainder_is_spread_over_the_epoch() -> None:
    assert min(batch_sizes(47_105, 1024)) >= 1000  # 46 x 1024 + 1 before the fix


@given(st.floats(0.0, 0.9999), st.integers(1, 10_000_000))
def test_weight_average_spans_at_most_a_tenth_of_the_run(requested: float, steps: int) -> None:
    d = average_decay(requested, steps)
    assert d <= requested
    assert d < 1.0
    if steps >= 11:
        assert 1.0 / (1.0 - d) <= steps / 10 + 1e-6
    if requested <= 1.0 - 10.0 / max(steps, 11):
        assert d == requested  # long runs keep the decay asked for
