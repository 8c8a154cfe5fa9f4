"""beam3d: continuum mechanics method (CMM, `continuum`) against the elastic-line method (ELM, `line_strain` +
`line_bending` + `line_torsion`) of paper 001, on small strains, and the ELM curvature against the cable's.

Section b x h = 0.05 x 0.08 m, L = 1 m, E = 2.1e5, nu = 0 (so that the plain and the enhanced continuum energies
coincide in the section terms the spurious-strain formulas below count), G = E/2; I_y = b h^3/12 (bending in the
x-z plane), I_z = h b^3/12 (x-y plane), I_p = I_y + I_z, J = St. Venant's torsion constant of the rectangle.

What we find (asserted below):
- stretch 1e-4: CMM and ELM energies are identical to round-off (both integrate E e^2/2 over b h L).
- bend with curvature kappa = 0.01 1/m (kappa h = 8e-4): line_bending alone equals E I kappa^2 L / 2 to 1e-11.
  Both totals exceed it by the same spurious transverse strain: r_y (or r_z) is interpolated linearly between unit
  vectors, so it shrinks inside the element, |r_y|^2 = 1 - 2 xi (1-xi)(1 - cos kappa L), a transverse Green strain
  whose energy E A L (kappa L)^4 / 240 adds a relative kappa^2 L^4 / (10 d^2) (d = b for z-bending, h for y-bending:
  +0.40 % and +0.16 % here). The line method's line_strain carries the same term, so CMM and ELM agree to 2e-5.
- twist rate tau = 0.01 1/m: both give G J tau^2 L / 2 (the linear section field cannot warp and alone would give
  the polar moment I_p; the continuum form scales its section shear by J / I_p) plus the shrink of both r_y and
  r_z: E A L tau^4 L^4 / 120, relative 2 tau^2 L^4 / (5 (b^2 + h^2)) I_p / J = +0.78 %; CMM and ELM agree to 2e-5.
- line_bending vs the cable's bending on the same circular centreline, EI_y = EI_z = EI: with the section frame's
  r_z along the binormal (r_y in the bending plane) they agree to O(alpha^6) (7e-9 at a 10 deg element). With the
  frame turned by psi about the tangent, interpolated r_y and r_z are no longer orthogonal inside the element; a
  curvature built on r_y and r_z as they are would be low by alpha^2 sin^2(2 psi) / 12 (derived below; 0.25 % at
  10 deg and psi = 0.7, 3.9 % at 40 deg). line_bending projects r_z normal to the tangent and completes an
  orthonormal frame, so it matches the cable for any psi.
"""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import kernels
from ancf_sym.scene import Section

from helpers import evaluate, rotation, straight_state

L, B, H, E, NU = 1.0, 0.05, 0.08, 2.1e5, 0.0
G = E / 2
A, IY, IZ = B * H, B * H**3 / 12, H * B**3 / 12
J = Section.rectangle(B, H).J


def energy(effect, q, p, gauss=None):
    return evaluate(kernels.load("beam3d", effect, gauss), q, p)[0]


def cmm(q):
    return energy("continuum", q, [L, B, H, E, NU, J])


def elm(q):
    """(line_strain, line_bending, line_torsion) energies [J]."""
    return (energy("line_strain", q, [L, B, H, E, NU]), energy("line_bending", q, [L, E * IY, E * IZ]),
            energy("line_torsion", q, [L, G * J]))


def frame_node(r, F):
    return np.concatenate([r, F[:, 0], F[:, 1], F[:, 2]])


def test_axial_stretch():
    s = 1e-4
    q = straight_state("beam3d", L, stretch=s)
    exact = E / 2 * (((1 + s) ** 2 - 1) / 2) ** 2 * A * L
    strain, bend, torsion = elm(q)
    assert bend == 0.0 and torsion == 0.0
    # 1e-10: the strain 1e-4 is formed as (r_x.r_x - 1)/2, whose cancellation amplifies round-off by ~1e4
    assert abs(strain / exact - 1) < 1e-10
    assert abs(cmm(q) / strain - 1) < 1e-10  # the same integral by two kernels, not merely within 1e-3


@pytest.mark.parametrize("plane", ["xy", "xz"])
def test_small_curvature_bend(plane):
    kappa = 0.01
    axis, d, I = ([0, 0, 1], B, IZ) if plane == "xy" else ([0, -1, 0], H, IY)
    axis = np.array(axis, float)

    def node(phi):  # point of the arc at angle phi, frame turned with the tangent (no twist)
        F = rotation(axis, phi)
        r = (np.sin(phi) * np.eye(3)[0] + (1 - np.cos(phi)) * np.cross(axis, np.eye(3)[0])) / kappa
        return frame_node(r, F)

    q = np.concatenate([node(0.0), node(kappa * L)])
    exact = E * I * kappa**2 * L / 2
    strain, bend, torsion = elm(q)
    assert abs(bend / exact - 1) < 1e-9, f"line_bending {bend} vs EI kappa^2 L/2 {exact}"
    assert torsion < 1e-20 * exact  # no twist
    spurious = kappa**2 * L**4 / (10 * d**2)  # transverse strain of the shrinking interpolated section vector
    assert abs(strain / exact / spurious - 1) < 0.01, f"line_strain share {strain / exact:.4e} vs {spurious:.4e}"
    total_elm, total_cmm = strain + bend + torsion, cmm(q)
    assert abs(total_elm / (exact * (1 + spurious)) - 1) < 1e-4
    assert abs(total_cmm / (exact * (1 + spurious)) - 1) < 1e-4
    assert abs(total_cmm / total_elm - 1) < 1e-4, f"CMM {total_cmm} vs ELM {total_elm}"


def test_small_twist():
    tau = 0.01
    q = np.concatenate([frame_node(np.zeros(3), np.eye(3)),
                        frame_node(np.array([L, 0, 0]), rotation([1, 0, 0], tau * L))])
    exact = G * J * tau**2 * L / 2
    strain, bend, torsion = elm(q)
    assert bend < 1e-20 * exact
    assert abs(torsion / exact - 1) < 1e-4, f"line_torsion {torsion} vs G J tau^2 L/2 {exact}"
    spurious = 2 * tau**2 * L**4 / (5 * (B**2 + H**2)) * (IY + IZ) / J  # r_y and r_z both shrink
    assert abs(strain / exact / spurious - 1) < 0.01
    total_elm, total_cmm = strain + bend + torsion, cmm(q)
    assert abs(total_elm / (exact * (1 + spurious)) - 1) < 1e-4
    assert abs(total_cmm / (exact * (1 + spurious)) - 1) < 1e-4
    assert abs(total_cmm / total_elm - 1) < 1e-4, f"CMM {total_cmm} vs ELM {total_elm}"


def arc_pair(alpha, psi, R=2.0):
    """Beam and cable states of one element on a circle of radius R, angle alpha, in a tilted plane; the beam's
    section frame (r_y, r_z) is orthonormal to the tangent at the nodes, turned by psi about it (psi = 0: r_z along
    the binormal)."""
    T = rotation([1, 2, -2], 0.9)

    def node(phi):
        F = T @ rotation([0, 0, 1], phi) @ rotation([1, 0, 0], psi)
        return frame_node(T @ np.array([R * np.sin(phi), R - R * np.cos(phi), 0.0]), F)

    qb = np.concatenate([node(-alpha / 2), node(alpha / 2)])
    qc = np.concatenate([qb[0:3], qb[3:6], qb[12:15], qb[15:18]])
    return qb, qc


@pytest.mark.parametrize("gauss", [5, 7])
@pytest.mark.parametrize("alpha_deg", [10.0, 40.0])
def test_line_bending_matches_cable_bending(gauss, alpha_deg):
    """Why the frame must be orthonormalised: on the arc r_xx is along the principal normal n; interpolating unit
    vectors gives |n_i|^2 = m = 1 - delta, delta = 2 xi (1 - xi)(1 - cos alpha), and with the raw r_y, r_z
    kappa_ELM^2 / kappa^2 = m (sin^2 psi / (sin^2 psi m + cos^2 psi) + cos^2 psi / (cos^2 psi m + sin^2 psi))
                          = 1 - delta sin^2(2 psi) / 2 + O(delta^2), i.e. U_ELM / U_cable = 1 - alpha^2 sin^2(2 psi)/12.
    With e_z = unit(P r_z), e_y = t x e_z, kappa_y^2 + kappa_z^2 = |P r_xx|^2 / |r_x|^4 = the cable's kappa^2 at every
    point whatever psi: equal to round-off (1e-9 allows for the cancellations at a 10 deg element)."""
    EI, R = 7.0, 2.0
    alpha = np.radians(alpha_deg)
    Lh = R * alpha
    for psi in (0.0, 0.7, 1.3):
        qb, qc = arc_pair(alpha, psi, R)
        beam = energy("line_bending", qb, [Lh, EI, EI], gauss)
        cable = evaluate(kernels.load("cable3d", "bending", gauss), qc, [Lh, EI])[0]
        assert abs(beam / cable - 1) < 1e-9, f"psi = {psi}: {beam} vs {cable}, raw-frame error would be " \
                                             f"{-alpha**2 * np.sin(2 * psi) ** 2 / 12:.2e}"