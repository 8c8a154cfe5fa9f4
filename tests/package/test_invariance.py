"""Rigid-body motion: every ELASTIC effect (registry Effect.elastic) of every element stores no energy and exerts no
force in a rigidly moved, straight, unstretched element, and is objective (frame-indifferent) in a deformed one.

Rigid motion: finite rotation of 40 deg about the skew axis (1, 2, -2) (cable2d: planar 40 deg) and a translation
of (1.3, -0.7, 2.1) m. Beam3d reference: r_x = e_x, r_y = e_y, r_z = e_z at both nodes, all turned by R.

Round-off scale. The state is exact only to eps_mach |q| (|q| ~ a few m after the translation); the strain energy
of that error is ~ |H| (eps |q|)^2 and the force ~ |H| eps |q|, with |H| the largest tangent-stiffness entry at
the same state (EA/L for the axial effects, EI/L^3 for bending, ...). We allow 1000 eps: force <= 1e-13 |H| |q|,
energy <= |H| (1e-13 |q|)^2. A wrong (non-objective) energy gives forces of order |H| * (size of the motion).
"""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import kernels, registry

from helpers import evaluate, params, perturbed_state, rotate_q, rotation, rotation2, straight_state

ELASTIC = [(k["element"], k["effect"], k["gauss"]) for k in kernels.catalogue()
           if registry.EFFECTS[(k["element"], k["effect"])].elastic]
IDS = [f"{el}_{ef}_g{g}" for el, ef, g in ELASTIC]

ANGLE = np.radians(40.0)
SHIFT3 = np.array([1.3, -0.7, 2.1])


def rigid(element: str):
    if registry.ELEMENTS[element].dim == 2:
        return rotation2(ANGLE), SHIFT3[:2]
    return rotation([1, 2, -2], ANGLE), SHIFT3


def test_elastic_effects_are_listed():
    """The classification the tests rely on: all strain energies are elastic, loads are not."""
    names = {(el, ef) for el, ef, _ in ELASTIC}
    for el in ("cable2d", "cable3d"):
        assert {(el, e) for e in ("axial_green", "axial_biot", "axial_decoupled", "bending")} <= names
        assert (el, "gravity") not in names and (el, "moment") not in names
    assert {("beam3d", e) for e in ("continuum", "line_strain", "line_bending", "line_torsion")} <= names


@pytest.mark.parametrize("element,effect,gauss", ELASTIC, ids=IDS)
def test_rigid_motion_of_straight_element_is_free(element, effect, gauss):
    k = kernels.load(element, effect, gauss)
    R, shift = rigid(element)
    q_ref = straight_state(element)
    q = rotate_q(element, q_ref, R, shift)
    p = params(element, effect, q, nu=0.3)
    for state in (q_ref, q):
        e, g, H = evaluate(k, state, p)
        h, s = np.max(np.abs(H)), np.max(np.abs(state))
        assert h > 0, "zero tangent stiffness: the tolerances below would be empty"
        assert abs(e) <= h * (1e-13 * s) ** 2, f"rigid state stores energy {e:.3e} (|H| = {h:.3e})"
        assert np.max(np.abs(g)) <= 1e-13 * h * s, f"rigid state exerts force {np.max(np.abs(g)):.3e} (|H| = {h:.3e})"
        # the infinitesimal rigid modes (translations, and rotations about the axes) are in the null space of H
        for mode in rigid_modes(element, state):
            assert np.max(np.abs(H @ mode)) <= 1e-12 * h * np.max(np.abs(mode)), "tangent stiffness resists a rigid mode"


def rigid_modes(element: str, q: np.ndarray):
    """Velocity vectors of the nodal coordinates for unit translations and unit rotations about the origin."""
    dim = registry.ELEMENTS[element].dim
    per_node = 2 if element.startswith("cable") else 4
    blocks = q.reshape(-1, dim)
    modes = []
    for a in range(dim):
        v = np.zeros_like(blocks)
        v[::per_node, a] = 1.0
        modes.append(v.ravel())
    if dim == 2:
        W = [np.array([[0.0, -1.0], [1.0, 0.0]])]
    else:
        W = [np.cross(np.eye(3), e) for e in np.eye(3)]  # skew matrices (x -> e x x) up to sign
    for w in W:
        modes.append((blocks @ w.T).ravel())  # positions and gradient vectors all turn with the body
    return modes


@pytest.mark.parametrize("element,effect,gauss", ELASTIC, ids=IDS)
def test_energy_is_objective_in_deformed_states(element, effect, gauss):
    """U(R q + c) = U(q) and grad U(R q + c) = R grad U(q) for a curved, stretched state: the energy sees only the
    shape. Same expressions evaluated on rotated numbers, so equal to round-off (1e-11 relative)."""
    k = kernels.load(element, effect, gauss)
    R, shift = rigid(element)
    q = perturbed_state(element, np.random.default_rng(3), amplitude=0.25, stretch=0.1)
    p = params(element, effect, q, nu=0.3)
    e, g, H = evaluate(k, q, p)
    e2, g2, H2 = evaluate(k, rotate_q(element, q, R, shift), p)
    assert abs(e2 - e) <= 1e-11 * abs(e)
    assert np.max(np.abs(g2 - rotate_q(element, g, R))) <= 1e-11 * np.max(np.abs(g))
    blocks = np.kron(np.eye(q.size // R.shape[0]), R)  # the nodal rotation as one matrix
    assert np.max(np.abs(H2 - blocks @ H @ blocks.T)) <= 1e-11 * np.max(np.abs(H))
