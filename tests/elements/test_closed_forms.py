"""Kernel values against closed-form results: uniform stretch, circular arc, mass matrix, gravity.

Tolerances: where the element represents the exact field and the quadrature is exact, only round-off separates
kernel and formula: 1e-12 relative (1e-13 would be 1000 eps; a few hundred flops accumulate). The arc is an
interpolation, with its error derived below.
"""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import kernels, registry

from helpers import L0, evaluate, perturbed_state, rotate_q, rotation, rotation2, straight_state

EA = 3.0e3
EI = 7.0
CABLES = ["cable2d", "cable3d"]
TURN = {"cable2d": rotation2(-0.8), "cable3d": rotation([2, -1, 1], 1.1), "beam3d": rotation([2, -1, 1], 1.1)}
SHIFT = {"cable2d": [0.2, -1.0], "cable3d": [0.2, -1.0, 0.5], "beam3d": [0.2, -1.0, 0.5]}


def gauss_orders(element, effect):
    return registry.EFFECTS[(element, effect)].gauss


def stretched(element, s):
    return rotate_q(element, straight_state(element, L0, stretch=s), TURN[element], SHIFT[element])


# Uniform stretch: r_x = (1 + s) t everywhere, so every strain is constant along the element ------------------

@pytest.mark.parametrize("element", CABLES)
@pytest.mark.parametrize("s", [-0.1, 0.02, 0.15])
def test_uniform_stretch(element, s):
    """Energies, and the nodal forces: the end positions carry -+N t with the axial force N = dU/d(chord)
    (Green and decoupled: EA e (1+s), e = ((1+s)^2 - 1)/2; Biot and the decoupled rod with Biot strain: EA s), the
    slopes carry nothing (int S2' = 0)."""
    dim = registry.ELEMENTS[element].dim
    e_green = ((1 + s) ** 2 - 1) / 2
    q = stretched(element, s)
    t = TURN[element] @ np.eye(dim)[0]
    cases = {"axial_green": (EA * L0 * e_green**2 / 2, EA * e_green * (1 + s)),
             "axial_biot": (EA * L0 * s**2 / 2, EA * s),
             "axial_decoupled": (EA * L0 * e_green**2 / 2, EA * e_green * (1 + s)),
             "axial_decoupled_biot": (EA * L0 * s**2 / 2, EA * s)}
    assert abs(cases["axial_green"][0] - EA * L0 * ((1 + s) ** 2 - 1) ** 2 / 8) < 1e-12 * cases["axial_green"][0]
    for effect, (energy, N) in cases.items():
        for g in gauss_orders(element, effect):
            e, grad, _ = evaluate(kernels.load(element, effect, g), q, [L0, EA])
            assert abs(e / energy - 1) < 1e-12, f"{effect} g{g}: {e} vs {energy}"
            force = np.concatenate([-N * t, np.zeros(dim), N * t, np.zeros(dim)])
            assert np.max(np.abs(grad - force)) < 1e-12 * abs(N), f"{effect} g{g}: {grad} vs {force}"


def test_uniform_stretch_beam_continuum_and_line_strain():
    """Beam, nu = 0: uniaxial Green strain e = ((1+s)^2 - 1)/2 over the volume, U = E e^2 / 2 * b h L."""
    b, h, E = 0.05, 0.08, 2.1e5
    for s in (-0.05, 0.1):
        q = stretched("beam3d", s)
        exact = E / 2 * (((1 + s) ** 2 - 1) / 2) ** 2 * b * h * L0
        for effect, p in (("continuum", [L0, b, h, E, 0.0, 1e-6]), ("line_strain", [L0, b, h, E, 0.0])):
            e = evaluate(kernels.load("beam3d", effect), q, p)[0]
            assert abs(e / exact - 1) < 1e-12, f"{effect}: {e} vs {exact}"


def test_uniaxial_stress_beam_continuum_and_line_strain():
    """Beam, nu = 0.3, uniform stretch with the section contracted to uniaxial stress: Green strains E_xx = e,
    E_yy = E_zz = -nu e (St. Venant-Kirchhoff's S_yy = lambda tr E + 2 G E_yy = 0), so U = E e^2 / 2 * b h L exactly:
    the enhanced continuum form keeps the full 3D law on the centreline, where the Poisson coupling acts.
    1e-12: one quadrature of a constant density, round-off only."""
    b, h, E, nu = 0.05, 0.08, 2.1e5, 0.3
    for s in (-0.05, 0.1):
        e = ((1 + s) ** 2 - 1) / 2
        c = np.sqrt(1 - 2 * nu * e)  # |r_y| = |r_z| with (|r_y|^2 - 1)/2 = -nu e
        q = stretched("beam3d", s)
        for node in (0, 12):
            q[node + 6:node + 12] *= c
        exact = E / 2 * e**2 * b * h * L0
        for effect, p in (("continuum", [L0, b, h, E, nu, 1e-6]), ("line_strain", [L0, b, h, E, nu])):
            got = evaluate(kernels.load("beam3d", effect), q, p)[0]
            assert abs(got / exact - 1) < 1e-12, f"{effect}: {got} vs {exact}"


# Circular arc -------------------------------------------------------------------------------------------------

def arc_state(element, R, alpha):
    """Nodes on a circle of radius R at -+alpha/2, unit tangents: one element of arc length L = R alpha."""
    r = lambda phi: np.array([R * np.sin(phi), R * np.cos(phi) - R])
    t = lambda phi: np.array([np.cos(phi), -np.sin(phi)])
    q = np.concatenate([r(-alpha / 2), t(-alpha / 2), r(alpha / 2), t(alpha / 2)])
    if element == "cable3d":
        q3 = np.zeros(12)
        q3.reshape(4, 3)[:, :2] = q.reshape(4, 2)
        q = rotate_q("cable3d", q3, TURN["cable3d"], SHIFT["cable3d"])
    return q


@pytest.mark.parametrize("element", CABLES)
def test_circular_arc_bending(element):
    """U -> EI L / (2 R^2). Error, derived by series expansion in the element angle alpha (sympy) of the cubic
    Hermite interpolant of the arc: kappa^2 R^2 = 1 + alpha^2 (xi^2 - xi + 1/6) + O(alpha^4); the alpha^2 term
    integrates to zero over the element, so U / U_exact = 1 + alpha^4 / 240 + O(alpha^6), i.e. +3.9e-6 at 10 deg.
    We assert that value within 5 % of itself (the O(alpha^6) remainder is -0.2 % of it at 10 deg, -2 % at 40 deg),
    and the fourth-order rate from 20 to 10 deg."""
    R = 2.0
    errs = {}
    for deg in (20.0, 10.0):
        a = np.radians(deg)
        L = R * a
        e = evaluate(kernels.load(element, "bending"), arc_state(element, R, a), [L, EI])[0]
        errs[deg] = e / (EI * L / (2 * R**2)) - 1
        assert abs(errs[deg] / (a**4 / 240) - 1) < 0.05, f"{deg} deg: relative error {errs[deg]:.4e}, " \
                                                          f"predicted {a**4 / 240:.4e}"
    assert 15.0 < errs[20.0] / errs[10.0] < 17.0  # 2^4


# Mass matrix --------------------------------------------------------------------------------------------------

RHO_A = 2.5
B, H, RHO = 0.05, 0.08, 7800.0


def mass(element, L=L0):
    p = [L, RHO_A] if element.startswith("cable") else [L, B, H, RHO]
    return kernels.mass_matrix(element, p)


def line_density(element):
    return RHO_A if element.startswith("cable") else RHO * B * H


def translation_rate(element, v):
    dim = registry.ELEMENTS[element].dim
    per_node = 2 if element.startswith("cable") else 4
    qd = np.zeros((2 * per_node, dim))
    qd[::per_node] = v
    return qd.ravel()


@pytest.mark.parametrize("element", ["cable2d", "cable3d", "beam3d"])
def test_mass_rigid_translation(element):
    """Kinetic energy of a rigid translation is m |v|^2 / 2 with m = rho A L, exactly; for each axis the sum of
    the translational entries (u^T M u with u = ones on that axis' position DOFs) is the total mass."""
    M = mass(element)
    dim = registry.ELEMENTS[element].dim
    m = line_density(element) * L0
    assert np.allclose(M, M.T, rtol=0, atol=1e-15 * np.abs(M).max())
    assert np.linalg.eigvalsh(M).min() > 0  # positive definite (every DOF carries mass: slopes via rho A)
    for a in range(dim):
        u = translation_rate(element, np.eye(dim)[a])
        assert abs(u @ M @ u / m - 1) < 1e-12
    v = np.array([1.5, -0.4, 2.2])[:dim]
    qd = translation_rate(element, v)
    assert abs(0.5 * qd @ M @ qd / (0.5 * m * v @ v) - 1) < 1e-12


@pytest.mark.parametrize("element", ["cable2d", "cable3d", "beam3d"])
def test_mass_rigid_rotation_about_transverse_axis(element):
    """Rigid rotation with rate w about the z axis through node 0 of the straight element along x: the velocity
    field w e_z x r is linear in the coordinates, represented exactly, so T = w^2/2 int rho (x^2 + y^2) dV exactly:
    cable rho A L^3 / 3 (a line), beam rho b h L^3 / 3 + rho h b^3 L / 12 (plus the section's extent in y)."""
    dim = registry.ELEMENTS[element].dim
    q = straight_state(element)
    W = np.array([[0.0, -1.0], [1.0, 0.0]]) if dim == 2 else np.array([[0, -1.0, 0], [1.0, 0, 0], [0, 0, 0]])
    qd = (q.reshape(-1, dim) @ W.T).ravel()
    M = mass(element)
    w = 1.0
    J = RHO_A * L0**3 / 3 if element.startswith("cable") else RHO * (B * H * L0**3 / 3 + H * B**3 * L0 / 12)
    assert abs(0.5 * qd @ M @ qd / (0.5 * J * w**2) - 1) < 1e-12


def test_beam_mass_rotation_about_axis():
    """beam3d spinning about its own axis (x) with rate w: centreline and r_x at rest, r_y' = w e_z, r_z' = -w e_y;
    T = rho (I_y + I_z) L w^2 / 2, I_y = b h^3 / 12, I_z = h b^3 / 12 (area moments of the b x h section)."""
    w = 3.0
    node = np.concatenate([np.zeros(3), np.zeros(3), w * np.array([0, 0, 1.0]), w * np.array([0, -1.0, 0])])
    qd = np.concatenate([node, node])
    M = mass("beam3d")
    exact = RHO * (B * H**3 / 12 + H * B**3 / 12) * L0 * w**2 / 2
    assert abs(0.5 * qd @ M @ qd / exact - 1) < 1e-12


# Gravity ------------------------------------------------------------------------------------------------------

G = {"cable2d": np.array([0.3, -9.81]), "cable3d": np.array([0.3, -9.81, 1.7]), "beam3d": np.array([0.3, -9.81, 1.7])}


@pytest.mark.parametrize("element", ["cable2d", "cable3d", "beam3d"])
def test_gravity(element):
    """Straight element: U = -rho A L g . r_centre (r_centre = midpoint). Any state: int r dx of the cubic Hermite
    curve is L (r0 + r1)/2 + L^2 (r_x0 - r_x1)/12, so U = -rho A g . that, and grad U is constant (load vector)."""
    dim = registry.ELEMENTS[element].dim
    g = G[element]
    k = kernels.load(element, "gravity")
    p = np.concatenate([[L0, RHO_A], g])
    q = stretched(element, 0.1)
    nodes = q.reshape(-1, dim)
    per_node = 2 if element.startswith("cable") else 4
    r0, t0, r1, t1 = nodes[0], nodes[1], nodes[per_node], nodes[per_node + 1]
    e = evaluate(k, q, p)[0]
    exact = -RHO_A * L0 * g @ ((r0 + r1) / 2)
    assert abs(e / exact - 1) < 1e-12

    q = perturbed_state(element, np.random.default_rng(5), amplitude=0.3)
    nodes = q.reshape(-1, dim)
    r0, t0, r1, t1 = nodes[0], nodes[1], nodes[per_node], nodes[per_node + 1]
    e, grad, _ = evaluate(k, q, p)
    exact = -RHO_A * g @ (L0 * (r0 + r1) / 2 + L0**2 * (t0 - t1) / 12)
    assert abs(e - exact) < 1e-12 * RHO_A * L0 * np.linalg.norm(g) * np.abs(q).max()
    grad2 = evaluate(k, 2 * q + 1.0, p)[1]
    assert np.allclose(grad, grad2, rtol=0, atol=1e-13 * np.abs(grad).max())
