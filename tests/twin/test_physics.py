"""Physical properties of the forward model (noise-free unless the property is about noise)."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.twin import UnitParams, builtin_scenes, generate_session, region_centre
from spectratac.twin.electronics import INTEGRATION_MS, SensorConfig
from spectratac.twin.forward import expected_output


def _out(u: UnitParams, x, y, fx, fy, fn, duty, cfg=None) -> np.ndarray:
    a = [np.atleast_1d(np.asarray(v, dtype=float)) for v in (x, y, fx, fy, fn)]
    r = np.full(a[0].shape, 4.0)
    return expected_output(u, *a, r, duty, cfg)


@pytest.mark.parametrize("region", [1, 2, 5, 6, 9])
def test_more_force_more_change(nominal: UnitParams, white: np.ndarray, region: int) -> None:
    x, y = region_centre(region)
    forces = np.array([0.0, 0.5, 1.0, 2.0, 4.0, 7.0, 10.0])
    out = _out(nominal, np.full(7, x), np.full(7, y), 0 * forces, 0 * forces, forces, white)
    change = np.linalg.norm((out[:, :, :4] / out[0, :, :4] - 1.0).reshape(7, -1), axis=1)
    assert np.all(np.diff(change) > 0), change


def test_rotating_contact_by_120_degrees_permutes_sensors(
    nominal: UnitParams, white: np.ndarray
) -> None:
    rng = np.random.default_rng(0)
    n = 20
    x, y = rng.uniform(-6, 6, n), rng.uniform(-6, 6, n)
    fx, fy = rng.uniform(-2, 2, n), rng.uniform(-2, 2, n)
    fn = rng.uniform(0.5, 9, n)
    base = _out(nominal, x, y, fx, fy, fn, white)
    c, s = np.cos(np.deg2rad(120.0)), np.sin(np.deg2rad(120.0))
    xr, yr = x * c - y * s, x * s + y * c  # about the board centre
    fxr, fyr = fx * c - fy * s, fx * s + fy * c
    rot = _out(nominal, xr, yr, fxr, fyr, fn, white)
    # Sensor k sees at the rotated contact what sensor k-1 saw at the original one.
    np.testing.assert_allclose(rot, np.roll(base, 1, axis=1), rtol=1e-9)


def test_reversing_shear_reverses_the_asymmetry(nominal: UnitParams, white: np.ndarray) -> None:
    # Asymmetry: the clear channel's sensor-to-sensor pattern with the common mode removed.
    def asym(fx: float, fy: float) -> np.ndarray:
        c = _out(nominal, 0.0, 0.0, fx, fy, 5.0, white)[0, :, 3]
        return c - c.mean()

    assert np.allclose(asym(0.0, 0.0), 0.0, atol=1e-6)
    for fx, fy in [(2.0, 0.0), (0.0, 2.0), (-1.5, 1.0)]:
        plus, minus = asym(fx, fy), asym(-fx, -fy)
        big = np.abs(plus) > 0.05 * np.abs(plus).max()
        np.testing.assert_array_equal(np.sign(plus[big]), -np.sign(minus[big]))
        assert np.corrcoef(plus, minus)[0, 1] < -0.99
        # The sensor downstream of the shear brightens most.
        assert np.argmax(plus) == np.argmax(nominal.sensor_xy @ np.array([fx, fy]))


def test_no_contact_gives_the_baseline_within_noise(nominal: UnitParams, white: np.ndarray):
    s = generate_session(builtin_scenes.idle(20.0), seed=4, unit=nominal)
    expect = _out(nominal, 0.0, 0.0, 0.0, 0.0, 0.0, white, None)[0]
    mean = s.counts.mean(axis=0)
    sd = s.counts.std(axis=0)
    n = len(s)
    # Mean within 5 standard errors plus the light leakage; spread near shot + read + flicker.
    assert np.all(np.abs(mean - expect) < 5 * sd / np.sqrt(n) + 5.0 + 0.002 * expect)
    predicted = np.sqrt(expect / nominal.electrons_per_count + nominal.read_noise_counts**2)
    assert np.all(sd[:, :4] > 0.7 * predicted[:, :4])
    assert np.all(sd[:, :4] < 3.0 * predicted[:, :4] + nominal.led_flicker * expect[:, :4] * 3)
    assert not s.in_contact.any() and np.all(s.region == -1)


def test_doubling_integration_time_doubles_counts_until_saturation(nominal: UnitParams):
    means = {}
    for it in INTEGRATION_MS:
        s = generate_session(builtin_scenes.idle(2.0), seed=1, unit=nominal, integration_ms=it)
        means[it] = s.counts.astype(float).mean(axis=0)
        if it == 400:
            sat = s
    for a, b in ((50, 100), (100, 200)):
        below = 2.2 * means[a] < 65535  # channels that do not reach full scale at `b`
        ratio = means[b][below] / means[a][below]
        np.testing.assert_allclose(ratio, 2.0, rtol=0.03)
    assert np.all(means[200][:, 3] == 65535)  # clear (~27k at 50 ms) clips at 200 ms
    # At 400 ms the clear channel (~27k at 50 ms) would need ~215k: it clips and is flagged.
    assert np.all(sat.counts[:, :, 3] == 65535)
    assert sat.saturated.all()
    assert sat.counts.max() == 65535


def test_gain_and_sensitivity_scale_counts(nominal: UnitParams, white: np.ndarray) -> None:
    base = _out(nominal, 0, 0, 0, 0, 0, white, SensorConfig())[0]
    g2 = _out(nominal, 0, 0, 0, 0, 0, white, SensorConfig(gain=2.0))[0]
    low = _out(nominal, 0, 0, 0, 0, 0, white, SensorConfig(sens_low=True))[0]
    np.testing.assert_allclose(g2 / base, 2.0, rtol=1e-9)
    assert np.all(low[:, :4] / base[:, :4] < 0.34) and np.all(low[:, :4] / base[:, :4] > 0.33)


def test_same_seed_same_data_and_different_seed_differs() -> None:
    sc = builtin_scenes.single_press(3, 6.0, (1.0, -1.0))
    a = generate_session(sc, seed=11)
    b = generate_session(sc, seed=11)
    c = generate_session(sc, seed=12)
    for name in ("counts", "ft", "ft_window", "force", "saturated", "region"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert not np.array_equal(a.counts, c.counts)


def test_units_differ_between_seeds_and_stay_physical() -> None:
    a, b = UnitParams.from_seed(1), UnitParams.from_seed(2)
    assert not np.allclose(a.direct, b.direct)
    for u in (a, b):
        assert np.all(u.direct > 0) and u.e_star_mpa > 0 and np.all(u.led_gain > 0)


def test_thermal_drift_session_drifts_without_contact() -> None:
    s = generate_session(builtin_scenes.drift_session(600.0), seed=0)
    c = s.counts[:, :, 0].astype(float)  # red droops the most with junction temperature
    early, late = c[:50].mean(), c[-50:].mean()
    assert late < early * 0.99
    assert not s.in_contact.any()
    assert np.allclose(s.force, 0.0)
