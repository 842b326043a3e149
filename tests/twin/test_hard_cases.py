"""Hard-case scenes stay finite and flag saturation."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.twin import builtin_scenes, generate_session
from spectratac.twin.builtin_scenes import hard_cases

CASES = hard_cases()


@pytest.mark.parametrize("name", sorted(CASES))
def test_hard_case_is_finite_and_flags_saturation(name: str) -> None:
    case = CASES[name]
    s = generate_session(case.scene, seed=2, **case.settings)
    for field in ("ft", "ft_window", "force", "contact_xy", "t_start", "t_end"):
        assert np.all(np.isfinite(getattr(s, field))), field
    assert s.counts.dtype == np.uint16
    # A sensor is flagged exactly when one of its channels reads full scale.
    np.testing.assert_array_equal(s.saturated, np.any(s.counts == 65535, axis=2))
    if case.expect_saturation:
        assert s.saturated.any()
    if name == "near_dark":
        assert s.counts[:, :, :4].max() < 200 and not s.saturated.any()
    if name == "rim_contact":
        assert s.in_contact.any() and np.all(s.region == -1)
    if name == "over_range":
        assert -s.force[:, 2].min() > 25.0


def test_over_range_indentation_saturates_smoothly(nominal) -> None:
    from spectratac.twin.mechanics import indentation

    f = np.linspace(0, 100, 201)
    d, _a = indentation(f, np.full_like(f, 4.0), nominal)
    assert np.all(np.isfinite(d)) and np.all(np.diff(d) >= 0)
    assert d.max() < nominal.max_indent_mm


def test_drift_session_is_finite() -> None:
    s = generate_session(builtin_scenes.drift_session(120.0), seed=0)
    assert np.all(np.isfinite(s.ft)) and not s.saturated.any()
