"""The generator computes what it computed before its speed-up: every golden case
(`golden_sessions.py`, saved from the older, slower code) comes out again from the same seed,
floats within 1e-9 relative (of the value, or of the array's scale where the value is a
near-cancellation such as a torque about zero), integers and flags exactly."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from tests.twin.golden_sessions import CASES, GOLDEN_PATH, arrays

RTOL = 1e-9


@pytest.fixture(scope="module")
def golden() -> dict[str, np.ndarray[Any, Any]]:
    with np.load(GOLDEN_PATH) as z:
        return {k: z[k] for k in z.files}


def assert_same(name: str, got: np.ndarray[Any, Any], want: np.ndarray[Any, Any]) -> None:
    assert got.shape == want.shape and got.dtype == want.dtype, (
        f"{name}: {got.dtype}{got.shape}, golden {want.dtype}{want.shape}"
    )
    if np.issubdtype(want.dtype, np.floating):
        scale = float(np.max(np.abs(want))) if want.size else 0.0
        np.testing.assert_allclose(got, want, rtol=RTOL, atol=RTOL * scale, err_msg=name)
    else:
        np.testing.assert_array_equal(got, want, err_msg=name)


@pytest.mark.parametrize("case", sorted(CASES))
def test_session_matches_golden(case: str, golden: dict[str, np.ndarray[Any, Any]]) -> None:
    session = CASES[case]()
    names = []
    for name, arr in arrays(session):
        assert_same(f"{case}/{name}", arr, golden[f"{case}/{name}"])
        names.append(name)
    assert {k for k in golden if k.startswith(f"{case}/")} == {f"{case}/{n}" for n in names}


def test_golden_cases_reach_their_branches(golden: dict[str, np.ndarray[Any, Any]]) -> None:
    """The cases exercise what they claim: contact, saturation, overlapping F/T segments."""
    assert golden["calibration/in_contact"].any() and not golden["calibration/in_contact"].all()
    assert golden["saturating/saturated"].any()
    assert not golden["idle/in_contact"].any()
    # 10 Hz F/T under 50 ms windows: consecutive windows share F/T samples.
    assert len(np.unique(golden["cold_start/ft_window"][:, 0])) < len(
        golden["cold_start/ft_window"]
    )
    remounted = golden["remounted/t_start"]
    assert np.allclose(np.diff(remounted), 0.110)  # 100 ms windows, 10 ms gaps
    assert set(golden["remounted/step"].tolist()) == {0, 1, 2}
