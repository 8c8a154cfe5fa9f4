"""Fully parameterised 3D ANCF beam (paper 001, 24 DOF): kinematics and one energy per effect.

Continuum form: the enhanced continuum mechanics split of the St. Venant-Kirchhoff energy (Nachbagauer, Gruber,
Gerstmayr, J. Comput. Nonlinear Dyn. 8 (2013) 021004; the form of Chrono's ANCF 3243 beam with its
ChMaterialBeamANCF): the Poisson coupling acts on the centreline only, so the section field, linear in y and z,
does not Poisson-lock in bending; a torsion factor on the section's shear terms gives St. Venant's G J.

Per node k: r, r_x, r_y, r_z (3-vectors). Material coordinates x in [0, L], y in [-b/2, b/2], z in [-h/2, h/2].
Shape functions (paper 001 eq. 4, with its misprinted s6 corrected to L(-xi^2 + xi^3)):
r = s1 rA + s2 r_xA + s3 r_yA + s4 r_zA + s5 rB + s6 r_xB + s7 r_yB + s8 r_zB.
"""
from __future__ import annotations

import casadi as ca

from ancf_sym.elements import hermite
from ancf_sym.elements.cable import planar_angle
from ancf_sym.elements.quadrature import gauss01


def nodal(q):
    """rA, r_xA, r_yA, r_zA, rB, r_xB, r_yB, r_zB."""
    return tuple(q[3 * i:3 * i + 3] for i in range(8))


def centreline(q, L, xi):
    rA, txA, _, _, rB, txB, _, _ = nodal(q)
    h = hermite.h(xi)
    return h[0] * rA + L * h[1] * txA + h[2] * rB + L * h[3] * txB


def gradients(q, L, xi, y, z):
    """r_x, r_y, r_z at material point (xi*L, y, z)."""
    rA, txA, tyA, tzA, rB, txB, tyB, tzB = nodal(q)
    d = hermite.dh(xi)
    rx = (d[0] * rA + d[2] * rB) / L + d[1] * txA + d[3] * txB + (y * (tyB - tyA) + z * (tzB - tzA)) / L
    ry = (1 - xi) * tyA + xi * tyB
    rz = (1 - xi) * tzA + xi * tzB
    return rx, ry, rz


def line_fields(q, L, xi):
    """Centreline r_x, r_y, r_z, r_xx, r_yx, r_zx at xi."""
    rA, txA, tyA, tzA, rB, txB, tyB, tzB = nodal(q)
    rx, ry, rz = gradients(q, L, xi, 0, 0)
    dd = hermite.ddh(xi)
    rxx = (dd[0] * rA + dd[2] * rB) / L**2 + (dd[1] * txA + dd[3] * txB) / L
    return rx, ry, rz, rxx, (tyB - tyA) / L, (tzB - tzA) / L


def lame(E, nu):
    return E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))


def green_strains(rx, ry, rz):
    """Green-Lagrange E = (J^T J - I)/2 of J = [r_x r_y r_z] as (Exx, Eyy, Ezz, Exy, Exz, Eyz)."""
    return ((ca.dot(rx, rx) - 1) / 2, (ca.dot(ry, ry) - 1) / 2, (ca.dot(rz, rz) - 1) / 2,
            ca.dot(rx, ry) / 2, ca.dot(rx, rz) / 2, ca.dot(ry, rz) / 2)


def torsion_factor(b, h, J):
    """k_t = J / I_p with I_p = b h (b^2 + h^2) / 12 the polar moment of the b x h rectangle.

    The section field is linear in y and z, so a twist rate tau gives the shear strains 2 E_xy = -z tau and
    2 E_xz = y tau and no warping: G int (y^2 + z^2) dA tau^2 / 2 = G I_p tau^2 / 2 instead of St. Venant's
    G J tau^2 / 2 (I_p / J = 1.82 for a 2:1 rectangle, 1.69 for a square). Scaling the section-varying part of
    E_xy, E_xz by k_t gives G J exactly; their section mean (transverse shear) is restored on the axis.
    """
    return 12 * J / (b * h * (b**2 + h**2))


def ecm_section_density(rx, ry, rz, E, nu, kt):
    """Enhanced continuum mechanics, section part (integrated over the b x h section): the strains that vary over
    the section without the Poisson coupling, E/2 E_xx^2 (axial + bending: E I, not the locked
    (lambda + 2 G) I) and 2 k_t G (E_xy^2 + E_xz^2) (torsion G J, see torsion_factor)."""
    exx, _, _, exy, exz, _ = green_strains(rx, ry, rz)
    G = E / (2 * (1 + nu))
    return E / 2 * exx**2 + 2 * kt * G * (exy**2 + exz**2)


def ecm_axis_density(rx, ry, rz, E, nu, kt):
    """Enhanced continuum mechanics, axis part (on the centreline, times the area): the rest of St. Venant-Kirchhoff.

    With D the isotropic normal-strain block and D0 = E I its Poisson-free part already in the section term, this
    adds 1/2 e^T (D - D0) e of the centreline normal strains e = (E_xx, E_yy, E_zz), i.e. lambda/2 (tr e)^2 + G |e|^2
    - E/2 E_xx^2 (the section strains E_yy, E_zz, E_yz are constant over the section, so they live here whole),
    2 G E_yz^2, and the transverse shear's share (1 - k_t) 2 G (E_xy^2 + E_xz^2) that the section term scaled away.
    Uniform stretch thus sees the full 3D law (lateral contraction nu), bending and torsion see E I and G J.
    """
    exx, eyy, ezz, exy, exz, eyz = green_strains(rx, ry, rz)
    lam, G = lame(E, nu)
    return (lam / 2 * (exx + eyy + ezz)**2 + G * (eyy**2 + ezz**2) + (G - E / 2) * exx**2 + 2 * G * eyz**2
            + 2 * (1 - kt) * G * (exy**2 + exz**2))


def svk_density(rx, ry, rz, E, nu):
    """St. Venant-Kirchhoff: lambda/2 (tr E)^2 + G tr(E^2), E = (J^T J - I)/2 with J = [r_x r_y r_z]."""
    exx, eyy, ezz, exy, exz, eyz = green_strains(rx, ry, rz)
    lam, G = lame(E, nu)
    return lam / 2 * (exx + eyy + ezz)**2 + G * (exx**2 + eyy**2 + ezz**2 + 2 * (exy**2 + exz**2 + eyz**2))


def line_bending_density(rx, ry, rz, rxx, EIy, EIz):
    """Section curvatures in an orthonormal frame of the plane normal to r_x, squared so no norm is differentiated.

    e_z = unit(P r_z) with P = I - t t^T the projection normal to the tangent t, e_y = t x e_z; the curvature vector
    components kappa_y = r_xx.e_z/|r_x|^2 and kappa_z = -r_xx.e_y/|r_x|^2 (paper 001's kappa_0y, kappa_0z made
    dimensionally curvatures and smooth when straight). Projecting keeps kappa_y^2 + kappa_z^2 = kappa^2 even where
    the interpolated r_y, r_z are not orthogonal inside the element (error alpha^2 sin^2(2 psi)/12 otherwise).
    """
    gx = ca.dot(rx, rx)
    rz_n = rz - ca.dot(rz, rx) / gx * rx  # P r_z
    nz = ca.dot(rz_n, rz_n)
    ky2 = ca.dot(rxx, rz_n)**2 / (nz * gx**2)
    kz2 = ca.dot(rxx, ca.cross(rx, rz_n))**2 / (nz * gx**3)  # |r_x x P r_z|^2 = gx nz
    return (EIy * ky2 + EIz * kz2) / 2


def torsion_density(ry, rz, ryx, rzx, GIp):
    theta = (ca.dot(ryx, rz) - ca.dot(ry, rzx)) / 2
    return GIp / 2 * theta**2


def gravity_energy(q, p):
    L, rhoA, g = p[0], p[1], p[2:5]
    xs, ws = gauss01(4)
    return -sum(w * L * rhoA * ca.dot(g, centreline(q, L, x)) for x, w in zip(xs, ws))


def moment_z_energy(q, p):
    """Paper 001 Q_Mz: the section vector r_y turns by gamma about Z, r_y = (-sin g, cos g, .): pair (r_y1, r_y2).

    Virtual work M dgamma with dgamma = (r_y1 dr_y2 - r_y2 dr_y1)/f^2 (the paper prints the opposite sign).
    """
    L, xi, M, ref1, ref2 = (p[i] for i in range(5))
    ry = (1 - xi) * q[6:9] + xi * q[18:21]
    # r_y = (-sin g, cos g): rotate the pair (r_y2, -r_y1) which is (cos g, sin g)
    return -M * planar_angle(ref2, -ref1, ry[1], -ry[0])


def moment_y_energy(q, p):
    """Paper 001 Q_My: the section vector r_z turns by beta about Y, r_z = (sin b, ., cos b): pair (r_z3, r_z1)."""
    L, xi, M, ref3, ref1 = (p[i] for i in range(5))
    rz = (1 - xi) * q[9:12] + xi * q[21:24]
    return -M * planar_angle(ref3, ref1, rz[2], rz[0])


def mass_matrix(p):
    """rho int S^T S dV; cubic x cubic in x (4 points), linear x linear in y and z (2 points): exact."""
    L, b, h, rho = (p[i] for i in range(4))
    xs, wx = gauss01(4)
    ys, wy = gauss01(2)
    M = ca.SX.zeros(24, 24)
    eye = ca.SX.eye(3)
    for x, w in zip(xs, wx):
        hx = hermite.h(x)
        for yy, w2 in zip(ys, wy):
            for zz, w3 in zip(ys, wy):
                y, z = (yy - 0.5) * b, (zz - 0.5) * h
                s = [hx[0], L * hx[1], y * (1 - x), z * (1 - x), hx[2], L * hx[3], y * x, z * x]
                S = ca.horzcat(*[sk * eye for sk in s])
                M += w * w2 * w3 * L * b * h * rho * ca.mtimes(S.T, S)
    return M
