"""Fields along a member from its nodal coordinates: positions, axial strain and curvature at sample points.

All elements at once (NumPy broadcasting over elements and sample points): a 150 000-element member samples in a
fraction of a second. Two axial strains are given: `strain` = |r_x| - 1 (the centre line's stretch, the same for
every member) and `axial_strain`, the strain measure the member's axial energy uses (`axial_measure` names it):
for the decoupled strain that is the strain of the equivalent rod, which is smooth where |r_x| - 1 of a bent
element oscillates from element to element.
"""
from __future__ import annotations

import numpy as np

from ancf_sym.elements import hermite
from ancf_sym.elements.quadrature import gauss01
from ancf_sym.model.mesh import MemberMesh
from ancf_sym.scene.builder import Member

# what each strain measure is, for axis labels and VTK readers (docs/results.md)
MEASURES = {
    "green": "Green strain (r_x.r_x - 1)/2",
    "biot": "Biot strain |r_x| - 1",
    "decoupled": "decoupled strain ((r_D,x)^2 - 1)/2 of the equivalent rod",
    None: "stretch |r_x| - 1 (no axial stiffness)",
    "beam3d": "centre-line Green strain (r_x.r_x - 1)/2",
}


def axial_measure(member: Member) -> str:
    """The name of the axial strain `axial_strain` gives for this member (what its axial energy uses)."""
    if member.element == "beam3d":
        return MEASURES["beam3d"]
    return MEASURES[member.axial]


def _element_coefficients(mm: MemberMesh, xn: np.ndarray) -> np.ndarray:
    """(n_el, 4, dim): r(0), r_x(0), r(L), r_x(L) of every element."""
    dim = mm.member.points.shape[1]
    a, b = mm.elem_nodes[:, 0], mm.elem_nodes[:, 1]
    return np.stack([xn[a, :dim], xn[a, dim:2 * dim], xn[b, :dim], xn[b, dim:2 * dim]], axis=1)


def element_fields(mm: MemberMesh, xn: np.ndarray, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(r, r_x, r_xx), each (n_el, len(xi), dim), at the element coordinates xi in [0, 1] of every element."""
    c = _element_coefficients(mm, xn)
    xi = np.asarray(xi, float)
    L = mm.elem_length[:, None, None]
    h, dh, ddh = (np.stack(f(xi), axis=1) for f in (hermite.h, hermite.dh, hermite.ddh))  # (k, 4) each
    # interpolation.weights with the element length moved onto the coefficients: one (k, 4) matrix for all elements
    one = np.ones_like(L)

    def apply(m: np.ndarray, f_pos: np.ndarray, f_slope: np.ndarray) -> np.ndarray:
        return m @ (c * np.concatenate([f_pos, f_slope, f_pos, f_slope], axis=1))  # (n_el, k, dim)

    return apply(h, one, L), apply(dh, 1 / L, one), apply(ddh, 1 / L**2, 1 / L)



def _norm(v: np.ndarray) -> np.ndarray:
    return np.sqrt(np.einsum("...d,...d->...", v, v))


def decoupled_strain(mm: MemberMesh, xn: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """(n_el, len(xi)) strain ((r_D,x)^2 - 1)/2 of paper 000's equivalent rod q_D = [0, |r_x(0)|, L_D, |r_x(L)|],
    L_D = int |r_x| dx by the member's Gauss rule: the same numbers as the axial_decoupled kernel (elements.cable)."""
    from ancf_sym.registry import EFFECTS

    m = mm.member
    gauss = m.gauss or EFFECTS[(m.element, "axial_decoupled")].default_gauss
    c = _element_coefficients(mm, xn)
    a, cc = _norm(c[:, 1]), _norm(c[:, 3])
    xg, wg = gauss01(gauss)
    LD = mm.elem_length * (_norm(element_fields(mm, xn, xg)[1]) @ wg)
    d = hermite.dh(np.asarray(xi, float))
    rDx = d[1][None, :] * a[:, None] + d[2][None, :] * (LD / mm.elem_length)[:, None] + d[3][None, :] * cc[:, None]
    return (rDx**2 - 1) / 2


def axial_strain(mm: MemberMesh, xn: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """(n_el, len(xi)) the member's own axial strain measure (axial_measure) at xi of every element."""
    m = mm.member
    if m.element.startswith("cable") and m.axial == "decoupled":
        return decoupled_strain(mm, xn, xi)
    g = np.einsum("ekd,ekd->ek", *[element_fields(mm, xn, xi)[1]] * 2)
    if m.element == "beam3d" or m.axial == "green":
        return (g - 1) / 2
    return np.sqrt(g) - 1


def positions(mm: MemberMesh, xn: np.ndarray, per_element: int = 8) -> np.ndarray:
    """(k, dim) centre-line points along the member at the points of sample() (positions only: the cheap part)."""
    h = np.stack(hermite.h(np.linspace(0.0, 1.0, per_element + 1)), axis=1)  # (k, 4)
    c = _element_coefficients(mm, xn)
    c[:, 1::2] *= mm.elem_length[:, None, None]  # r = h1 r(0) + L h2 r_x(0) + h3 r(L) + L h4 r_x(L)
    r = h @ c  # (n_el, k, dim)
    return np.concatenate([r[0, :1], r[:, 1:].reshape(-1, r.shape[2])])


def sample(mm: MemberMesh, xn: np.ndarray, per_element: int = 8) -> dict:
    """Positions r, slopes r_x and r_xx along the member; xn: (n_nodes, node_size) nodal coordinates.

    Returns s [m] (material coordinate), r (k, dim), strain = |r_x| - 1 [-], axial_strain [-] (the member's own
    measure, axial_measure), curvature |r_x x r_xx|/|r_x|^3 [1/m]. Shared element ends appear once.
    """
    dim = mm.member.points.shape[1]
    xi = np.linspace(0.0, 1.0, per_element + 1)
    r, rx, rxx = element_fields(mm, xn, xi)
    s = mm.s_node[mm.elem_nodes[:, 0]][:, None] + xi[None, :] * mm.elem_length[:, None]
    eps = axial_strain(mm, xn, xi)

    def flat(v: np.ndarray) -> np.ndarray:  # every element's points but its first (the previous one's last)
        return np.concatenate([v[0, :1], v[:, 1:].reshape(-1, *v.shape[2:])])

    r, rx, rxx, s, eps = flat(r), flat(rx), flat(rxx), flat(s), flat(eps)
    norm = _norm(rx)
    if dim == 2:  # np.cross of 2-vectors is deprecated (NumPy 2)
        cr = np.abs(rx[:, 0] * rxx[:, 1] - rx[:, 1] * rxx[:, 0])
    else:
        cr = _norm(np.cross(rx, rxx))
    return {"s": s, "r": r, "strain": norm - 1.0, "axial_strain": eps, "curvature": cr / norm**3}
