"""The layout sweep of issue 13 (scripts/sweep_bearing_layout.py): its generated layouts contain
the bundled ones, and its overlap measure agrees with the bundled scenes' non-overlap."""
from __future__ import annotations

import math

import numpy as np
import pytest

from scripts.sweep_bearing_layout import corridor_cameras, fovy_deg, hall_cameras, layout_scene, overlap_share
from trackroom.scenes.loader import load_scene


def _fovx_deg(scene_name: str) -> float:
    return math.degrees(load_scene(scene_name).cameras[0].fovx)


def test_fovy_gives_the_horizontal_field_of_view():
    for fovx in (40.0, 58.0, 90.0, 120.0):
        sc = layout_scene("corridor", 2, fovx, 1.2)
        assert math.degrees(sc.cameras[0].fovx) == pytest.approx(fovx, abs=1e-3)
    assert fovy_deg(2 * math.degrees(math.atan(4 / 3 * math.tan(math.radians(15))))) == pytest.approx(30.0)


@pytest.mark.parametrize("layout,scene,n,pos_tol,yaw_tol", [("hall", "bearing_hall", 4, 1e-9, 0.5),
                                                             ("corridor", "bearing_corridor", 3, 1e-9, 1e-9)])
def test_sweep_cells_contain_the_bundled_layouts(layout, scene, n, pos_tol, yaw_tol):
    """N = 4 at bearing_hall's field of view is bearing_hall's pinwheel (yaws within half a degree:
    the file rounds them); N = 3 at bearing_corridor's is bearing_corridor."""
    fov = _fovx_deg(scene)
    cams = (hall_cameras if layout == "hall" else corridor_cameras)(n, fov)
    bundled = load_scene(scene).cameras
    assert len(cams) == len(bundled)
    for c, b in zip(cams, bundled):
        assert np.allclose(c["position"], b.position, atol=pos_tol + 1e-4)
        d = (c["yaw_deg"] - math.degrees(b.yaw) + 180) % 360 - 180
        assert abs(d) <= yaw_tol + 1e-3


def test_overlap_share():
    assert overlap_share(load_scene("bearing_hall"))[0] == 0.0
    assert overlap_share(load_scene("bearing_corridor"))[0] == 0.0
    two, one = overlap_share(layout_scene("hall", 8, 120.0, 1.2))
    assert two > 0.5 and one == pytest.approx(1.0)
