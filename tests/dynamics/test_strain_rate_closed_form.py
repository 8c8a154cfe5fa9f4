"""Axial strain-rate damping in closed form (ancf_sym.system.damping._axial_rate_mx) against AD of the vectorized
dissipation: force and both tangents, Green and Biot rates, 2D and 3D, with supports (fixed coordinates)."""
import casadi as ca
import numpy as np
import pytest

from ancf_sym import Material, Scene, Section
from ancf_sym.model.assembly import Assembly
from ancf_sym.system import damping
from ancf_sym.system.step_system import StepSystem
from ancf_sym.util.sparsity import dm


@pytest.mark.parametrize("dim,axial", [(2, "biot"), (2, "green"), (3, "biot"), (3, "green")])
def test_closed_form_matches_ad(dim, axial):
    s = Scene(dim=dim, name="rate")
    end = (2.0, 0.3) if dim == 2 else (2.0, 0.3, -0.2)
    s.member("c", [(0.0,) * dim, end], 6, Material(E=1e9, density=1e3), Section(area=1e-4, I=1e-9), axial=axial)
    s.pin("c", 0)
    s.strain_rate_damping(axial=50.0, members=["c"])
    asm = Assembly(s)
    S = StepSystem.for_scene(asm)
    rng = np.random.default_rng(3)
    x = S.reduce(asm.x0) + 0.05 * rng.standard_normal(S.nf)  # stretched, bent, slopes off unit length
    v = rng.standard_normal(S.nf)
    xf, vf = ca.MX.sym("x", S.nf), ca.MX.sym("v", S.nf)
    X, V = S.x_full_mx(xf), ca.mtimes(dm(S.E), vf)
    ad = ca.Function("ad", [xf, vf], damping.strain_rate_mx(S.strain_rate, xf, X, V, vf))(x, v)
    cf = ca.Function("cf", [xf, vf], damping.strain_rate_mx(S.strain_rate, xf, X, V, vf, E=S.E))(x, v)
    for a, b in zip(ad, cf):
        a, b = np.asarray(ca.densify(a)), np.asarray(ca.densify(b))
        # the same derivative, other operation order: round-off relative to the largest entry
        assert np.abs(a - b).max() <= 1e-12 * np.abs(a).max()
