"""Contact kernels against their closed forms (the derivative checks are in test_derivatives through the catalogue).

A straight element lying in the ground at uniform depth delta: the Gauss rule integrates a constant exactly, so the
energy is L (k/2 delta^2 + 2/5 kh delta^2.5) and the total normal force L (k delta + kh delta^1.5) to round-off
(1e-12 relative). Sliding along the ground at speed s: total friction force mu f_n s / sqrt(s^2 + eps^2) against the
motion, and no friction force on a member at rest or spinning rigidly with a drum (relative velocity zero).
"""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import kernels, registry

L = 0.8
K, KH, T, C, MU, EPS = 2.0e3, 5.0e3, 0.01, 3.0, 0.4, 0.05


def _straight(element: str, y: float) -> np.ndarray:
    """Element from (0, y) to (L, y) along x, unit slope (beam: r_y = e_y, r_z = e_z)."""
    dim = registry.ELEMENTS[element].dim
    ex, ey = np.eye(dim)[0], np.eye(dim)[1]
    if element == "beam3d":
        node = lambda x: np.concatenate([x * ex + y * ey, ex, ey, np.eye(3)[2]])
    else:
        node = lambda x: np.concatenate([x * ex + y * ey, ex])
    return np.concatenate([node(0.0), node(L)])


def _translation_velocity(element: str, v: np.ndarray) -> np.ndarray:
    """Velocity of the element's coordinates in a rigid translation: positions move at v, gradients stay."""
    q = np.zeros(registry.ELEMENTS[element].ndof)
    dim = len(v)
    per_node = 2 if element.startswith("cable") else 4
    blocks = q.reshape(-1, dim)
    blocks[::per_node] = v
    return q


def _ground_params(element: str, friction: bool) -> np.ndarray:
    dim = registry.ELEMENTS[element].dim
    n = np.eye(dim)[1]  # ground y >= 0
    p = [L, K, KH, T, *n, 0.0]
    return np.array(p + ([C, MU, EPS] if friction else []))


@pytest.mark.parametrize("element", list(registry.ELEMENTS))
def test_uniform_penetration_energy_and_force(element):
    delta = 0.003
    q = _straight(element, T - delta)
    e, g, _ = kernels.load(element, "contact_ground")(q, _ground_params(element, False))
    g = np.asarray(g).ravel()
    assert float(e) == pytest.approx(L * (K / 2 * delta**2 + 0.4 * KH * delta**2.5), rel=1e-12)
    dim = registry.ELEMENTS[element].dim
    per_node = 2 if element.startswith("cable") else 4
    fy = -g.reshape(-1, dim)[::per_node, 1].sum()  # force on the element = -gradient, summed over nodal positions
    assert fy == pytest.approx(L * (K * delta + KH * delta**1.5), rel=1e-12)
    # above the ground: nothing
    e0, g0, H0 = kernels.load(element, "contact_ground")(_straight(element, T + 1e-3), _ground_params(element, False))
    assert float(e0) == 0 and not np.asarray(g0).any() and not np.asarray(H0).any()


@pytest.mark.parametrize("element", list(registry.ELEMENTS))
def test_sliding_friction_is_regularised_coulomb(element):
    delta, s = 0.003, 0.2
    dim = registry.ELEMENTS[element].dim
    q = _straight(element, T - delta)
    ex = np.eye(dim)[0]
    k = kernels.load(element, "contact_ground_friction")
    p = _ground_params(element, True)
    _, g, _ = k(np.concatenate([q, _translation_velocity(element, s * ex)]), p)
    nd = q.size
    f = -np.asarray(g).ravel()[nd:]  # generalized force on the element = -dD/dv
    per_node = 2 if element.startswith("cable") else 4
    fx = f.reshape(-1, dim)[::per_node, 0].sum()
    fn = L * (K * delta + KH * delta**1.5)
    assert fx == pytest.approx(-MU * fn * s / np.hypot(s, EPS), rel=1e-12)
    # the power the friction draws is positive (dissipation)
    v = _translation_velocity(element, s * ex)
    assert f @ v < 0
    # at rest: no force
    _, g0, _ = k(np.concatenate([q, np.zeros(nd)]), p)
    assert not np.asarray(g0).ravel()[nd:].any()


@pytest.mark.parametrize("element", ["cable2d", "cable3d"])
def test_no_friction_when_spinning_with_the_drum(element):
    """A member point on a drum that turns rigidly with it (v = omega a x (r - c)) has zero relative velocity:
    no friction, no damping force, even though it is pressed in. Pulling it against the spin gives a force along
    the spin direction (the drum drags it)."""
    dim = registry.ELEMENTS[element].dim
    R, omega = 0.5, 2.0
    # short straight element tangent to the drum top, pressed in by 2 mm; the drum centre below it
    q = _straight(element, 0.0)
    q = q.copy()
    centre = np.zeros(dim)
    centre[0], centre[1] = L / 2, -(R + T - 0.002)
    # rigid rotation about the drum centre: v = omega e_z x (r - c), r_x' = omega e_z x r_x
    v = np.zeros_like(q)
    blocks, vb = q.reshape(-1, dim), v.reshape(-1, dim)
    for i in range(0, len(blocks), 2):
        d = blocks[i] - centre
        vb[i][:2] = omega * np.array([-d[1], d[0]])
        vb[i + 1][:2] = omega * np.array([-blocks[i + 1][1], blocks[i + 1][0]])
    axis = [] if dim == 2 else [0.0, 0.0, 1.0]
    p = np.array([L, K, KH, T, R, *axis, C, MU, EPS])
    z = np.concatenate([q, centre, [0.0], v, np.zeros(dim), [omega]])
    k = kernels.load(element, "contact_circle_friction")
    n = q.size + dim + 1
    _, g, _ = k(z, p)
    f = np.asarray(g).ravel()
    assert np.abs(f[n:]).max() < 1e-12 * K * L
    # the member at rest on the spinning drum: dragged along the spin (+x at the top for omega > 0 about +z)
    z[n:n + q.size] = 0.0
    _, g, _ = k(z, p)
    fx = -np.asarray(g).ravel()[n:n + q.size].reshape(-1, dim)[::2, 0].sum()
    assert fx < 0  # top of the drum moves in -x for a positive spin about +z: omega e_z x (0, R) = (-omega R, 0)
    assert np.isfinite(fx)
