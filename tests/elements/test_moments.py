"""End moments on cables: a clamped cantilever under an end moment M bends into a circular arc, tip rotation
M L / EI (pure bending; EA/EI = 1e6 keeps stretch negligible). Tolerance 1e-4 rad: 8 cubic elements on an arc of
1 rad interpolate the circle to ~(1/8)^4 / 240 relative in energy; the axial/bending coupling adds ~1e-6."""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section, solve_static

EI, EA, L, M = 2.0, 2.0e6, 1.0, 2.0  # M L / EI = 1 rad


def cantilever(dim: int, moment):
    s = Scene(dim=dim)
    pts = [(0, 0), (L, 0)] if dim == 2 else [(0, 0, 0), (L, 0, 0)]
    s.member("c", pts, 8, Material(E=1.0, density=1.0), Section(area=EA, I=EI), axial="biot", gravity=False)
    s.clamp("c", "start")
    s.moment("c", "end", moment)
    return solve_static(s)


# the tangent turns from x towards: +y for a moment about +z; +z for a moment about -y ((-y) x x = +z)
@pytest.mark.parametrize("dim,moment,towards", [(2, M, 1), (3, (0.0, 0.0, M), 1), (3, (0.0, -M, 0.0), 2)])
def test_end_moment_bends_a_circular_arc(dim, moment, towards):
    r = cantilever(dim, moment)
    assert r.success, r.status
    t = r.slopes("c")[-1]
    angle = np.arctan2(t[towards], t[0])
    assert abs(angle - M * L / EI) < 1e-4, angle
    if dim == 3:
        assert abs(t[3 - towards]) < 1e-9 * np.linalg.norm(t)  # stays in the plane normal to the moment
    kappa = r.along("c")["curvature"]
    assert np.allclose(kappa, M / EI, rtol=2e-3)


def test_moment_along_a_cable3d_axis_is_refused():
    with pytest.raises(SceneError, match="no torsion"):
        cantilever(3, (M, 0.0, 0.0))
