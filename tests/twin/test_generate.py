"""Session generation: shapes, timing, the F/T stream, labels, settings and input checks."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.twin import Scene, Session, TwinError, builtin_scenes, generate_session


def test_calibration_protocol_shape(short_cal: tuple[Scene, Session]) -> None:
    sc, s = short_cal
    assert len(s) == round((sc.duration_s - 0.05) / 0.05) + 1  # 20 Hz back-to-back windows
    assert s.counts.shape == (len(s), 3, 5) and s.counts.dtype == np.uint16
    assert s.ft.shape == (s.ft_t.shape[0], 6)
    np.testing.assert_allclose(np.diff(s.ft_t), 1e-3)
    assert set(np.unique(s.region)) <= {-1, *vocab.REGIONS}
    assert s.in_contact.mean() > 0.5 and (s.region > 0).mean() > 0.3
    # Labels only on contacts; every region visited.
    assert np.all(s.in_contact[s.region > 0])
    assert set(np.unique(s.region[s.region > 0])) == set(vocab.REGIONS)
    assert np.abs(s.force[:, 2]).max() <= 10.0 * 1.25 + 0.1
    assert np.abs(s.force[:, :2]).max() <= 3.0 + 1e-9


def test_ft_window_is_the_stream_average(short_cal: tuple[Scene, Session]) -> None:
    _, s = short_cal
    for i in (0, 123, len(s) - 1):
        inside = (s.ft_t >= s.t_start[i] - 1e-9) & (s.ft_t < s.t_end[i] - 1e-9)
        np.testing.assert_allclose(s.ft_window[i], s.ft[inside].mean(axis=0), atol=1e-9)


def test_ft_torques_follow_the_lever_arm(short_cal: tuple[Scene, Session]) -> None:
    _, s = short_cal
    i = int(np.argmax(-s.force[:, 2]))
    x, y = s.contact_xy[i] * 1e-3
    fz = s.force[i, 2]
    # Mz = x Fy - y Fx; Mx ~ y Fz - z Fy within the F/T noise and the deformation.
    mz = x * s.force[i, 1] - y * s.force[i, 0]
    assert s.ft_window[i, 5] == pytest.approx(mz, abs=2e-3)
    assert np.sign(s.ft_window[i, 3] + 0.0122 * s.force[i, 1]) == np.sign(y * fz) or abs(y) < 1e-3


def test_multi_step_led_sequence() -> None:
    steps = np.zeros((3, 3, 3))
    for j in range(3):
        steps[j, j, :] = 0.5  # one LED at a time
    s = generate_session(builtin_scenes.idle(3.0), seed=0, led_steps=steps)
    assert s.step.tolist()[:6] == [0, 1, 2, 0, 1, 2]
    c = s.counts[:, :, 3].astype(float)
    # Sensor 0 is next to LEDs 0 and 2 (60° away) and opposite LED 1.
    by_step = [c[s.step == k, 0].mean() for k in range(3)]
    assert by_step[1] < 0.6 * min(by_step[0], by_step[2])


def test_default_counts_sit_mid_range() -> None:
    s = generate_session(builtin_scenes.idle(2.0), seed=0)
    clear = s.counts[:, :, 3]
    assert 15_000 < clear.mean() < 40_000
    assert not s.saturated.any()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"integration_ms": 60}, "integration_ms"),
        ({"gain": 3.0}, "gain"),
        ({"dg": 3}, "dg"),
        ({"led_steps": np.ones((2, 3))}, "led_steps"),
        ({"led_steps": np.full((3, 3), 1.2)}, r"\[0, 1\]"),
        ({"seed": -1}, "seed"),
        ({"gap_ms": -5.0}, "gap_ms"),
    ],
)
def test_bad_settings_raise_clear_errors(kwargs: dict, match: str) -> None:
    with pytest.raises(TwinError, match=match):
        generate_session(builtin_scenes.idle(1.0), **kwargs)


def test_bad_scenes_raise_clear_errors() -> None:
    with pytest.raises(TwinError, match="duration_s"):
        builtin_scenes.idle(0.0)
    with pytest.raises(TwinError, match="region"):
        builtin_scenes.single_press(region=12)
    with pytest.raises(TwinError, match="shorter than one"):
        generate_session(builtin_scenes.idle(0.01))


def test_save_npz_roundtrip(tmp_path, short_cal: tuple[Scene, Session]) -> None:
    _, s = short_cal
    path = tmp_path / "s.npz"
    s.save_npz(path)
    z = np.load(path)
    np.testing.assert_array_equal(z["counts"], s.counts)
    assert int(z["integration_ms"]) == 50
