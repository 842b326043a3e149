"""Unit-to-unit spread follows hardware/definitions/params.toml [tolerances]; layer thicknesses
move the model the physical way; session conditions are deterministic and distinct."""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.hardware.generated import board
from spectratac.twin import Scene, UnitParams, generate_session
from spectratac.twin.forward import deformation, expected_output
from spectratac.twin.ft import wrench
from spectratac.twin.session import TEMPERATURE_OFFSET_SD_C, SessionConditions
from spectratac.twin.stack import LayerStack
from spectratac.twin.unit import TOLERANCES

N_UNITS = 400


@pytest.fixture(scope="module")
def units() -> list[UnitParams]:
    return [UnitParams.from_seed(s) for s in range(N_UNITS)]


def _within(sample: np.ndarray, sigma: float) -> None:
    """Sample std within the 99.9 % band of a normal std estimate around `sigma`."""
    n = sample.size
    half = 3.3 * sigma / np.sqrt(2 * (n - 1))
    assert abs(float(np.std(sample, ddof=1)) - sigma) < half, (np.std(sample), sigma)
    assert abs(float(np.mean(sample))) < 3.3 * sigma / np.sqrt(n)


def test_layer_thicknesses_spread_as_the_tolerances(units: list[UnitParams]) -> None:
    nominal = LayerStack.board()
    _within(np.array([u.pcb_mm for u in units]) - nominal.pcb_mm, board.TOLERANCES_BOARD_THICKNESS)
    _within(np.array([u.pdms_mm for u in units]) - nominal.pdms_mm, board.TOLERANCES_PDMS_THICKNESS)
    _within(np.array([u.skin_mm for u in units]) - nominal.skin_mm, board.TOLERANCES_SKIN_THICKNESS)


def test_component_spreads_follow_the_tolerances(units: list[UnitParams]) -> None:
    nom = UnitParams.nominal()
    _within(np.log([u.led_gain for u in units]).ravel(), board.TOLERANCES_LED_INTENSITY)
    _within(
        np.array([u.led_wavelength_shift_nm for u in units]).ravel(),
        board.TOLERANCES_LED_WAVELENGTH,
    )
    _within(
        np.array([u.sensor_xy - nom.sensor_xy for u in units]).ravel(), board.TOLERANCES_PLACEMENT
    )
    _within(np.array([u.led_xy - nom.led_xy for u in units]).ravel(), board.TOLERANCES_PLACEMENT)
    _within(
        np.array([u.contact_offset_xy for u in units]).ravel(), board.TOLERANCES_MOULD_ALIGNMENT
    )
    # Sensor gain scales all 15 channel-colour responses of a sensor together; the per-entry
    # filter spread (3 %) averages down over them.
    log_ratio = np.log([u.spectral / nom.spectral for u in units])  # (units, k, 5, 3)
    _within(
        log_ratio.mean(axis=(2, 3)).ravel(),
        np.hypot(board.TOLERANCES_SENSOR_GAIN, 0.03 / np.sqrt(15)),
    )


def test_modulus_spread_combines_material_and_thickness(units: list[UnitParams]) -> None:
    """E* varies with the mixing ratio (8 %) and, through the thin-layer correction, with the
    elastomer thickness: the thickness part is the same for every unit of the same stack."""
    log_e = np.log([u.e_star_mpa / UnitParams.nominal(u.stack).e_star_mpa for u in units])
    _within(log_e, TOLERANCES["elastomer_modulus"])


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_unit_draw_is_deterministic_and_physical(seed: int) -> None:
    a, b = UnitParams.from_seed(seed), UnitParams.from_seed(seed)
    for name in ("pdms_mm", "skin_mm", "pcb_mm", "e_star_mpa", "optical_height_mm"):
        assert getattr(a, name) == getattr(b, name)
    assert np.array_equal(a.spectral, b.spectral) and np.array_equal(a.direct, b.direct)
    assert a.pdms_mm > 1.0 and a.skin_mm > 0 and a.pcb_mm > 0 and a.max_indent_mm > 0
    assert np.all(a.spectral_paths() > 0)
    a.validate()


def _stack(pdms: float = 2.5, skin: float = 0.5, pcb: float = 1.0) -> UnitParams:
    return UnitParams.nominal(LayerStack(pcb, pdms, skin))


def _counts(u: UnitParams, normal: float, lux: float = 0.0, x: float = 3.0) -> np.ndarray:
    one = np.ones(1)
    return expected_output(
        u, x * one, 0 * one, 0 * one, 0 * one, normal * one, 4.0 * one, np.full((3, 3), 0.25),
        lux=lux,
    )[0]  # fmt: skip


def test_thicker_pdms_spreads_the_guided_light() -> None:
    """No contact: the adjacent paths dim as the slab thickens (light spreads over it)."""
    thin, thick = _counts(_stack(pdms=2.3), 0.0), _counts(_stack(pdms=2.7), 0.0)
    assert np.all(thick[:, :4] < thin[:, :4])


def test_thicker_elastomer_indents_deeper_and_changes_counts_more() -> None:
    thin, thick = _stack(pdms=2.3), _stack(pdms=2.7)
    f = np.array([5.0])
    d_thin = deformation(thin, 0 * f, 0 * f, f, np.array([4.0]))[0]
    d_thick = deformation(thick, 0 * f, 0 * f, f, np.array([4.0]))[0]
    assert d_thick[0] > d_thin[0]
    assert thick.max_indent_mm > thin.max_indent_mm and thick.e_star_mpa < thin.e_star_mpa
    change_thin = np.abs(_counts(thin, 5.0) / _counts(thin, 0.0) - 1).sum()
    change_thick = np.abs(_counts(thick, 5.0) / _counts(thick, 0.0) - 1).sum()
    assert change_thick != pytest.approx(change_thin, rel=0.01)


def test_thicker_skin_leaks_less_ambient_light() -> None:
    def leak(u: UnitParams) -> np.ndarray:
        return _counts(u, 0.0, lux=100_000.0) - _counts(u, 0.0)

    thin, thick = leak(_stack(skin=0.45)), leak(_stack(skin=0.55))
    assert np.all(thick[:, :4] < thin[:, :4])


def test_thicker_pcb_lengthens_the_torque_lever() -> None:
    z = np.zeros(1)
    fx = np.array([2.0])

    def ty(u: UnitParams) -> float:
        return float(wrench(fx, z, z, z, z, z, z, z, unit=u)[0, 4])

    assert ty(_stack(pcb=1.1)) > ty(_stack(pcb=0.9)) > 0


def test_session_conditions_are_deterministic_and_distinct() -> None:
    draws = {(u, k): SessionConditions.draw(u, k, 0) for u in range(4) for k in range(4)}
    assert draws[(2, 3)] == SessionConditions.draw(2, 3, 0)
    assert SessionConditions.draw(2, 3, 1) != draws[(2, 3)]
    mounts = {c.mount_offset_mm for c in draws.values()}
    scenes = {c.scene_seed for c in draws.values()}
    assert len(mounts) == len(scenes) == len(draws)
    temps = np.array([c.temperature_offset_c for c in draws.values()])
    assert 0.3 * TEMPERATURE_OFFSET_SD_C < temps.std() < 3 * TEMPERATURE_OFFSET_SD_C


def test_ageing_grows_with_the_session_index() -> None:
    c = [SessionConditions.draw(5, k) for k in range(6)]
    assert c[0].led_output_factor == 1.0 and c[0].modulus_factor == 1.0
    assert all(a.led_output_factor > b.led_output_factor for a, b in itertools.pairwise(c))
    assert all(a.modulus_factor < b.modulus_factor for a, b in itertools.pairwise(c))


def test_bad_session_indices_are_refused() -> None:
    from spectratac.twin.errors import TwinError

    with pytest.raises(TwinError, match="session_index"):
        SessionConditions.draw(0, -1)


def test_session_conditions_reach_the_data() -> None:
    """A tilted re-mount makes the F/T read a lateral force under a pure normal press; the
    temperature offset and LED ageing move the no-contact counts."""
    base = UnitParams.from_seed(3)
    cond = replace(
        SessionConditions.draw(3, 4),
        mount_tilt_deg=(0.0, 1.0),
        temperature_offset_c=3.0,
        ft_bias=(0.0,) * 6,
    )
    scene = Scene.single_press(normal_n=8.0, hold_s=3.0)
    plain = generate_session(scene, seed=1, unit=base)
    moved = generate_session(cond.apply_scene(scene), seed=1, unit=cond.apply_unit(base))
    hold = plain.force[:, 2] < -7.9
    fx_plain = plain.ft_window[hold, 0].mean()
    fx_tilted = moved.ft_window[hold, 0].mean()
    assert abs(fx_tilted - fx_plain - (-8.0 * np.sin(np.deg2rad(1.0)))) < 0.03
    assert np.array_equal(plain.force, moved.force)  # the applied load is the same
    idle = ~plain.in_contact
    assert moved.counts[idle, :, 3].mean() < plain.counts[idle, :, 3].mean()
    assert cond.apply_scene(scene).env.temperature_c[0] == scene.env.temperature_c[0] + 3.0
