"""Initial velocities per member (ancf_sym.dynamics.initial): the kinetic energies of rigid motions and of a linear velocity
field are exact on cubic Hermite elements (the fields are reproduced exactly and the mass matrix is exact): 1e-12
relative; a rigid rotation carries no strain rate, so the elastic power grad U . v vanishes to round-off
(1e-9 of |grad U| |v|) even in a bent, stretched state."""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section
from ancf_sym.dynamics import initial
from ancf_sym.model.assembly import Assembly

RHO, D, L = 1000.0, 0.01, 1.2


def _asm(dim=2, element=None):
    sc = Scene(dim=dim)
    sec = Section.rectangle(0.02, 0.03) if element == "beam3d" else Section.circle(D)
    sc.member("rod", [[0.0] * dim, [L] + [0.0] * (dim - 1)], 6, Material(E=2e9, density=RHO, poisson=0.3), sec,
              element=element)
    return Assembly(sc), RHO * sec.area * L


def _kinetic(asm, v):
    return 0.5 * v @ (asm.mass_matrix() @ v)


@pytest.mark.parametrize("dim,element", [(2, None), (3, None), (3, "beam3d")])
def test_uniform_and_rigid_rotation(dim, element):
    asm, m = _asm(dim, element)
    vel = np.arange(1, dim + 1, dtype=float)
    v = initial.velocities(asm, uniform={"rod": vel})
    assert _kinetic(asm, v) == pytest.approx(0.5 * m * vel @ vel, rel=1e-12)
    omega = 2.0 if dim == 2 else [0.0, 0.0, 2.0]
    centre = [L / 2] + [0.0] * (dim - 1)
    v = initial.velocities(asm, rotation={"rod": (omega, centre)})
    inertia = m * L**2 / 12
    if element == "beam3d":  # the section turns too: + rho I_z about the axis through the section
        inertia += RHO * L * 0.03 * 0.02**3 / 12
    assert _kinetic(asm, v) == pytest.approx(0.5 * inertia * 4.0, rel=1e-12)


def test_rotation_has_no_strain_rate():
    asm, _ = _asm(2)
    rng = np.random.default_rng(1)
    x = asm.x0 + 0.05 * rng.standard_normal(asm.n)
    v = initial.velocities(asm, x, rotation={"rod": (1.5, [0.3, -0.2])})
    g = asm.evaluate(x, hessian=False).gradient
    assert abs(g @ v) < 1e-9 * np.linalg.norm(g) * np.linalg.norm(v)


def test_linear_field():
    asm, m = _asm(2)
    a = 0.7
    v = initial.velocities(asm, field={"rod": (lambda s: [0.0, a * s], lambda s: [0.0, a])})
    assert _kinetic(asm, v) == pytest.approx(0.5 * m / L * a**2 * L**3 / 3, rel=1e-12)


def test_bad_input():
    asm, _ = _asm(2)
    with pytest.raises(SceneError, match="member 'bar' does not exist"):
        initial.velocities(asm, uniform={"bar": [1, 0]})
    with pytest.raises(SceneError, match=r"uniform\['rod'\] must be 2 finite numbers"):
        initial.velocities(asm, uniform={"rod": [1, 0, 0]})
    with pytest.raises(SceneError, match="omega, centre"):
        initial.velocities(asm, rotation={"rod": 1.0})
