"""Fine meshes: the coarse-mesh start (statics_coarse) and element-local positions in the kernels (statics_eval).

Paper 000's cantilever (L = 3 m, E = 20 GPa, gravity, clamped). Its tip converges like h^4 in the element size:
between 1000 and 10 000 elements it moves by less than 2e-12 m (measured, bench/STATICS_RESULTS.md), so the solution
on any mesh from 1000 elements on is the converged tip to far below the 1e-9 m asked of every answer.
"""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import Material, Scene, Section
from ancf_sym.statics import coarse as statics_coarse
from ancf_sym.model.assembly import Assembly
from ancf_sym.model.mesh import Probe
from ancf_sym.statics import StaticProblem

L = 3.0


def cantilever(n: int, axial: str = "green", offset: float = 0.0) -> Scene:
    s = Scene(dim=2, gravity=(0, -9.81))
    s.member("beam", [(offset, offset), (offset + L, offset)], n, Material(E=20e9, density=7200),
             Section(area=7.854e-5, I=4.909e-10), axial=axial)
    s.clamp("beam", "start")
    return s


def test_interpolation_reproduces_the_coarse_cubic():
    """Every fine element lies inside one coarse element: the fine nodes' positions and slopes taken from the coarse
    Hermite cubic make the fine mesh carry that same cubic, so r and r_x agree at any material point (not only at
    the nodes), to round-off of the coordinates (~1 m here: 1e-12 leaves three digits for the sums)."""
    coarse, fine = Assembly(cantilever(5)), Assembly(cantilever(50))
    rng = np.random.default_rng(1)
    xc = coarse.x0 + 0.3 * rng.standard_normal(coarse.n)  # any coarse state, not only an equilibrium
    xf = statics_coarse.interpolate(coarse, xc, fine)
    for s in np.linspace(0.0, L, 37):
        pc, pf = Probe(coarse.mesh.members["beam"], s, 2), Probe(fine.mesh.members["beam"], s, 2)
        assert np.allclose(pf.r(xf), pc.r(xc), rtol=0, atol=1e-12)
        assert np.allclose(pf.rx(xf), pc.rx(xc), rtol=0, atol=1e-12)


def test_coarse_scene_keeps_named_nodes():
    """A node index on a coarsened member names the same material point on the coarse mesh (node i -> i / 10); a
    node that is not a coarse node means there is no coarse start (None), never a load moved elsewhere."""
    s = cantilever(2000)
    s.force("beam", at=1000, force=(0.0, -1.0))
    c = statics_coarse.coarse_scene(s)
    assert c.members["beam"].elements == 200 and c.loads[0].at == 100 and s.loads[0].at == 1000
    s.force("beam", at=1005, force=(0.0, -1.0))
    assert statics_coarse.coarse_scene(s) is None
    assert statics_coarse.coarse_scene(cantilever(statics_coarse.COARSE_ABOVE - 10)) is None


@pytest.mark.parametrize("axial", ["green", "biot"])
def test_coarse_start_agrees_with_the_straight_start(axial, monkeypatch):
    """2000 elements from the 200-element solution reach the same equilibrium as Newton from the straight beam:
    tips within 1e-9 m (each answer lies within ~tol^2 L of the discrete solution). From the interpolated start
    the fine mesh only corrects what 200 elements do not resolve (the tips differ by ~1e-9 relative): Newton's
    quadratic convergence needs at most 3 updates from there to 1e-10 (8-12 from the straight beam)."""
    r = StaticProblem(cantilever(2000, axial)).solve()
    start = r.attempts[0]["coarse_start"]
    assert r.success and start["used"] and start["elements"] == {"beam": 200}, r.attempts
    assert r.attempts[0]["iterations"] <= 3
    monkeypatch.setattr(statics_coarse, "COARSE_ABOVE", 10**9)
    direct = StaticProblem(cantilever(2000, axial)).solve()
    assert direct.success and "coarse_start" not in direct.attempts[0]
    assert np.linalg.norm(r.tip("beam") - direct.tip("beam")) < 1e-9


def test_translated_scene_same_shape():
    """An elastic energy does not change under a translation: the cantilever clamped 10 km from the origin has the
    same shape relative to its clamp. With absolute positions in the kernels (600 elements, span / l ~ 2e6) the
    residual's round-off swamped the nodal loads and the solve was refused (measured); element-local positions
    keep it to the short element's own scale. 1e-9 m: the accuracy asked of every answer."""
    ref = StaticProblem(cantilever(600)).solve()
    far = StaticProblem(cantilever(600, offset=1e4)).solve()
    assert far.success, far.attempts
    assert np.linalg.norm((far.tip("beam") - 1e4) - ref.tip("beam")) < 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("axial", ["green", "biot"])
def test_hundred_thousand_elements_converged_tip(axial):
    """100 000 elements (eps x the tangent's condition number ~1 here: from the straight beam Newton's first update
    came out 0.004 instead of 2.54 and the solve was refused) are solved from the 10 000-element start, and the tip is
    the converged one: within 1e-9 m of the 2000-element solution (the tip moves by < 2e-12 m between 1000 and
    10 000 elements, module docstring)."""
    ref = StaticProblem(cantilever(2000, axial)).solve()
    r = StaticProblem(cantilever(100_000, axial)).solve()
    assert r.success and r.attempts[0]["coarse_start"]["used"], r.attempts
    assert r.increment <= 1e-10 and r.energy_decrement <= 1e-10
    assert np.linalg.norm(r.tip("beam") - ref.tip("beam")) < 1e-9
