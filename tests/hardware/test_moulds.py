"""Mould STLs: watertight, and the sizes they cast (measured on slices) are the stack's."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest
import trimesh
from conftest import REPO, openscad_missing

from tools.hardware import moulds
from tools.hardware.params import Geometry

pytestmark = pytest.mark.kicad

MOULD = REPO / "hardware" / "mould"


def mesh(name: str, folder: Path = MOULD / "stl") -> trimesh.Trimesh:
    m = trimesh.load_mesh(folder / f"{name}.stl")
    assert isinstance(m, trimesh.Trimesh)
    return m


def loop_radii(m: trimesh.Trimesh, z: float) -> list[tuple[float, float, float]]:
    """Each closed loop of the slice at height z: (min radius, max radius, centroid angle)."""
    section = m.section(plane_origin=[0, 0, z], plane_normal=[0, 0, 1])
    assert section is not None, f"no material at z={z}"
    out = []
    for loop in section.discrete:
        r = np.hypot(loop[:, 0], loop[:, 1])
        # Area centroid (shoelace): vertex means are biased by uneven vertex spacing.
        x, y = loop[:, 0], loop[:, 1]
        cross = x * np.roll(y, -1) - np.roll(x, -1) * y
        cx = ((x + np.roll(x, -1)) * cross).sum() / (3 * cross.sum())
        cy = ((y + np.roll(y, -1)) * cross).sum() / (3 * cross.sum())
        out.append((float(r.min()), float(r.max()), math.degrees(math.atan2(cy, cx)) % 360))
    return out


def circles(m: trimesh.Trimesh, z: float) -> list[float]:
    """Diameters of the slice's circular loops, sorted (STL floats scatter radii by ~5 µm)."""
    return sorted(2 * hi for lo, hi, _ in loop_radii(m, z) if hi - lo < 0.02)


@pytest.mark.parametrize("part", moulds.PARTS)
def test_watertight(part: str) -> None:
    m = mesh(part)
    assert m.is_watertight and m.is_winding_consistent and m.volume > 0


def test_pdms_mould_casts_the_light_guide(geo: Geometry) -> None:
    m = mesh("pdms_mould")
    top = geo.mould_floor + geo.pdms_thickness
    assert m.bounds[0][2] == pytest.approx(0) and m.bounds[1][2] == pytest.approx(top)
    # Above the pocket bosses: a ring whose inside is the PDMS disc (board minus skin wall).
    inner, outer = circles(m, top - 0.2)
    assert inner == pytest.approx(2 * geo.pdms_radius, abs=0.02) == pytest.approx(18.2)
    assert outer == pytest.approx(2 * (geo.pdms_radius + geo.mould_wall), abs=0.02)
    # Through the bosses: six blocks on the part ring, mirrored because the disc casts upside
    # down, sensor-sized ones where the sensors go.
    blocks = [lp for lp in loop_radii(m, geo.mould_floor + 0.3) if lp[1] - lp[0] > 0.02]
    assert len(blocks) == 6
    for want in ((-a) % 360 for a in geo.sensor_angles + geo.led_angles):
        assert min(abs((a - want + 180) % 360 - 180) for _, _, a in blocks) < 0.1, want
    for lo, hi, _ in blocks:
        assert lo < geo.ring_radius < hi
    # Pocket depth: sensor bosses stand as tall as the sensor body plus the extra depth.
    sensor_top = geo.mould_floor + geo.sensor_body[2] + geo.pocket_extra_depth
    assert len([lp for lp in loop_radii(m, sensor_top - 0.05) if lp[1] - lp[0] > 0.02]) == 3
    assert not [lp for lp in loop_radii(m, sensor_top + 0.05) if lp[1] - lp[0] > 0.02]
    assert geo.pdms_thickness - geo.sensor_body[2] - geo.pocket_extra_depth >= 1.0, (
        "at least 1 mm of PDMS over the tallest part"
    )


def test_skin_mould_casts_a_cup_of_board_diameter(geo: Geometry) -> None:
    cavity, core = mesh("skin_cavity"), mesh("skin_core")
    skin_h = geo.height - geo.board_thickness
    assert cavity.bounds[1][2] == pytest.approx(geo.mould_floor + skin_h)
    inner, _ = circles(cavity, geo.mould_floor + skin_h / 2)
    assert inner == pytest.approx(19.2, abs=0.02)
    # The core's plug: PDMS-disc diameter, and short enough to leave the skin's top layer.
    plug = circles(core, geo.mould_floor + 0.5)
    assert plug == [pytest.approx(2 * geo.pdms_radius, abs=0.02)]
    plug_h = core.bounds[1][2] - geo.mould_floor
    assert skin_h - plug_h == pytest.approx(geo.skin_top)
    assert (inner - plug[0]) / 2 == pytest.approx(geo.skin_wall, abs=0.01)
    # The lid rests on the cavity's rim: same outer diameter.
    assert circles(core, geo.mould_floor / 2)[-1] == pytest.approx(
        circles(cavity, geo.mould_floor / 2)[-1]
    )


def test_fixture_takes_the_whole_stack(geo: Geometry) -> None:
    m = mesh("fixture")
    depth = m.bounds[1][2] - geo.mould_floor
    assert depth == pytest.approx(geo.height)
    bore, outer = circles(m, geo.mould_floor + depth / 2)
    assert bore == pytest.approx(19.2 + 2 * geo.fixture_clearance, abs=0.02)
    assert outer > bore
    hole, _ = circles(m, geo.mould_floor / 2)
    assert hole == pytest.approx(2 * geo.eject_hole_radius, abs=0.02)


def test_scad_parameters_come_from_params_toml(geo: Geometry) -> None:
    assert (MOULD / "params.scad").read_text() == moulds.scad_params(geo), "run `make hardware`"


@pytest.mark.skipif(openscad_missing() is not None, reason=openscad_missing() or "")
def test_openscad_regenerates_the_committed_stls(geo: Geometry, tmp_path: Path) -> None:
    shutil.copy(moulds.SCAD, tmp_path / moulds.SCAD.name)
    moulds.write_params(geo, tmp_path)
    for path in moulds.export_stls(tmp_path, tmp_path / "stl"):
        fresh, committed = mesh(path.stem, tmp_path / "stl"), mesh(path.stem)
        assert np.allclose(fresh.bounds, committed.bounds)
        assert fresh.volume == pytest.approx(committed.volume, rel=1e-9), path.name
