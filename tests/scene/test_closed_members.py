"""Closed members: belt paths around pulleys and loops whose last element ends on the first node.

Facts checked:
- belt_path length = the closed form of an open belt, 2 sqrt(D^2 - (R1 - R2)^2) + pi (R1 + R2) + 2 (R1 - R2)
  asin((R1 - R2) / D) (exact geometry: 1e-12 relative);
- the mesh closes (last element on node 0), its reference length is the path's / (1 + prestrain);
- a ring sampled from a full circle with prestrain eps carries the Green axial energy 1/2 EA eps_G^2 L with
  eps_G = ((1 + eps)^2 - 1) / 2 and the bending energy 1/2 EI kappa^2 L, kappa = 1 / (R (1 + eps)) per unit of
  reference length ... measured on cubic Hermite elements: with 24 elements the arc is followed to O(h^4)
  (h = 2 pi / 24: h^4 ~ 1e-3), so 1e-3 relative; the axial energy at the nodes is exact, between them the Hermite
  arc's stretch differs by O(h^4) too.
- bad paths are refused naming the piece.
"""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym.scene import closed
from ancf_sym.model.assembly import Assembly
from ancf_sym.scene import Material, Scene, SceneError, Section


def test_belt_path_length_matches_closed_form():
    R1, R2, D = 0.3, 0.12, 1.1
    path = closed.belt_path([((0.0, 0.0), R1), ((D, 0.0), R2)])
    total = closed.check_path(path)
    exact = 2 * np.sqrt(D**2 - (R1 - R2) ** 2) + np.pi * (R1 + R2) + 2 * (R1 - R2) * np.arcsin((R1 - R2) / D)
    assert total == pytest.approx(exact, rel=1e-12)
    pts, tans, _ = closed.sample(path, 40)
    # every node lies on a pulley rim or on a straight span tangent to both, with a unit tangent
    assert np.allclose(np.linalg.norm(tans, axis=1), 1.0)


def _ring(eps: float, n: int = 24, R: float = 0.5):
    sc = Scene(dim=2)
    mat, sec = Material(E=2e9, density=1200.0), Section(area=1e-4, I=1e-9)
    path = [("arc", (0.0, 0.0), R, -np.pi / 2, 2 * np.pi)]
    m = sc.loop("belt", path, n, mat, sec, prestrain=eps)
    return sc, m, mat, sec


def test_loop_mesh_closes_with_the_prestrained_length():
    sc, m, mat, sec = _ring(0.01)
    asm = Assembly(sc)
    mm = asm.mesh.members["belt"]
    assert mm.n_nodes == 24 and tuple(mm.elem_nodes[-1]) == (23, 0)
    assert mm.elem_length.sum() == pytest.approx(2 * np.pi * 0.5 / 1.01, rel=1e-12)
    assert m.length == pytest.approx(2 * np.pi * 0.5 / 1.01, rel=1e-12)


@pytest.mark.parametrize("eps", [0.0, 0.02])
def test_ring_energies(eps):
    R = 0.5
    sc, m, mat, sec = _ring(eps, R=R)
    asm = Assembly(sc)
    ev = asm.evaluate(asm.x0, hessian=False)
    L = 2 * np.pi * R / (1 + eps)
    EA, EI = mat.E * sec.area, mat.E * sec.bending_inertia
    eg = ((1 + eps) ** 2 - 1) / 2
    kappa = 1 / R  # geometric curvature: |r_x x r_xx| / |r_x|^3 is independent of the parametrisation speed
    assert ev.energies["bending"] == pytest.approx(0.5 * EI * kappa**2 * L, rel=1e-3)
    if eps:
        assert ev.energies["axial"] == pytest.approx(0.5 * EA * eg**2 * L, rel=1e-3)
    else:
        assert ev.energies["axial"] < 1e-3 * ev.energies["bending"]


def test_bad_paths_are_refused():
    sc = Scene(dim=2)
    mat, sec = Material(E=2e9, density=1200.0), Section(area=1e-4, I=1e-9)
    with pytest.raises(SceneError, match="piece 0"):
        sc.loop("a", [("line", (0, 0), (1, 0))], 8, mat, sec)  # does not close
    with pytest.raises(SceneError, match="piece 1"):
        sc.loop("b", [("line", (0, 0), (1, 0)), ("arc", (1, 0.5), -0.5, -np.pi / 2, np.pi)], 8, mat, sec)
    with pytest.raises(SceneError, match="overlap"):
        closed.belt_path([((0, 0), 0.5), ((0.2, 0), 0.1)])
    with pytest.raises(SceneError, match="elements"):
        sc.loop("c", closed.belt_path([((0, 0), 0.2), ((1, 0), 0.2)]), 2, mat, sec)
