"""The exact derivative of the model with respect to a cable member's prestrain, through its elements' reference length.

A prestrain eps draws the member stretched by 1 + eps: each element's reference length is L = l / (1 + eps) (l its
drawn length), so dL/deps = -L / (1 + eps); the nodes' positions and the slopes' directions (all that supports,
joints, bodies and tension loads read of the reference) do not change. The kernels take L as an input but carry no
derivative in it. That derivative follows exactly from the kernels' own outputs by a change of the unit of length:
scaling every length by lambda (positions and L by lambda, slopes unchanged, a coefficient c by lambda^d_c: EA [N]
d = 0, EI [N m^2] d = 2, rho A g [N/m] d = -1, a moment [N m] d = 1) scales an energy [N m] by lambda. Differentiated
at lambda = 1 (Euler's theorem on homogeneous functions):

    L dU/dL = sum_c (1 - d_c) U_c - sum_{i: positions} q_i dU/dq_i

with U_c the energy with coefficient c alone (each kernel is linear in its coefficients). The identity holds for the
discrete element too (Hermite fields r_x = (h1' r0 + h3' r1)/L + h2' t0 + h4' t1, Gauss points in xi, dx = L dxi), so
it is exact, not an approximation; tests/sensitivity/test_sensitivity_prestrain.py checks it against differences in L of every
cable kernel. Its gradient and Hessian in q follow by differentiating it; the Hessian's needs the third derivatives
contracted with the positions, the kernels' compiled Hessian-vector companion d(H v)/dq with v the positions. The mass
matrix: M_ij = rho A int S_i S_j L dxi with S = h for a position, L h for a slope, so L dM_ij/dL = (1 + s_i + s_j)
M_ij (s = 1 for a slope coordinate).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym import kernels, registry

# per effect: (coefficient column, 1 - d_c) pairs, or a number: the whole energy's weight (1 - d of its product of
# coefficients: gravity rho A g -> 2, a moment M -> 0); only cable effects whose other inputs are dimensionless
# (L aside: xi, reference tangents) are listed
WEIGHTS: dict = {"axial_green": (("EA", 1.0),), "axial_biot": (("EA", 1.0),), "axial_decoupled": (("EA", 1.0),),
                 "axial_decoupled_biot": (("EA", 1.0),), "bending": (("EI", -1.0),),
                 "elastic_green": (("EA", 1.0), ("EI", -1.0)), "elastic_biot": (("EA", 1.0), ("EI", -1.0)),
                 "elastic_decoupled": (("EA", 1.0), ("EI", -1.0)),
                 "elastic_decoupled_biot": (("EA", 1.0), ("EI", -1.0)),
                 "gravity": 2.0, "moment": 0.0}

_MAPS: dict = {}


def _mapped(kind: str, element: str, effect: str, gauss: int | None, N: int) -> ca.Function:
    key = (kind, element, effect, gauss, N)
    if key not in _MAPS:
        f = kernels.load(element, effect, gauss) if kind == "full" else kernels.load_hvp(element, effect)
        _MAPS[key] = f.map(N)
    return _MAPS[key]


def position_mask(element: str) -> np.ndarray:
    """1 on an element's position coordinates r(0), r(L), 0 on its slopes."""
    dim = registry.ELEMENTS[element].dim
    return np.r_[np.ones(dim), np.zeros(dim), np.ones(dim), np.zeros(dim)]


@dataclass
class LengthPiece:
    """d/deps of one term's energy, gradient and Hessian on some elements, where each element's L has
    dL/deps = factor L (the identity of the module docstring)."""
    element: str
    effect: str
    gauss: int | None
    idx: np.ndarray  # (N, nd)
    P: np.ndarray  # (N, np): the term's parameters
    label: str
    factor: float  # (dL/deps) / L = -1 / (1 + eps)

    def _parts(self) -> list[tuple[float, np.ndarray]]:
        """(weight, parameter rows) whose weighted kernel energies sum to sum_c (1 - d_c) U_c."""
        w = WEIGHTS[self.effect]
        if not isinstance(w, tuple):
            return [(w, self.P)] if w else []
        names = kernels.parameters(self.element, self.effect)
        cols = [names.index(c) for c, _ in w]
        out = []
        for c, a in w:
            P = np.array(self.P, float)
            for j in cols:
                if j != names.index(c):
                    P[:, j] = 0.0
            out.append((a, P))
        return out

    def _eval(self, x: np.ndarray, P: np.ndarray):
        N, nd = self.idx.shape
        e, g, H = _mapped("full", self.element, self.effect, self.gauss, N)(x[self.idx].T, P.T)
        return (e.full().ravel(), g.full().T, H.full().reshape(nd, N, nd).transpose(1, 0, 2))

    def grad(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """(d energy/deps summed over the elements, d gradient/deps per element (N, nd))."""
        m = position_mask(self.element)
        Q = x[self.idx]
        e, g, H = self._eval(x, self.P)
        V = -np.einsum("ei,ei->e", Q * m, g)
        dV = -np.einsum("eij,ej->ei", H, Q * m) - g * m
        for a, P in self._parts():
            ea, ga, _ = self._eval(x, P) if P is not self.P else (e, g, H)
            V, dV = V + a * ea, dV + a * ga
        return self.factor * float(V.sum()), self.factor * dV

    def gradients(self, X: np.ndarray) -> np.ndarray:
        """d gradient/deps assembled on the full coordinates at every state (rows of X), (len(X), n)."""
        out = np.zeros(X.shape)
        for k, x in enumerate(X):
            out[k] = np.bincount(self.idx.ravel(), self.grad(x)[1].ravel(), minlength=X.shape[1])
        return out

    def hessian(self, x: np.ndarray) -> np.ndarray:
        """d Hessian/deps per element (N, nd, nd): the identity differentiated twice; its third-derivative part
        from the compiled Hessian-vector companion (kept for the last x: every mode's derivative reads it)."""
        last = getattr(self, "_last", None)
        if last is not None and np.array_equal(last[0], x):
            return last[1]
        dH = self._hessian(x)
        self._last = (np.array(x, copy=True), dH)
        return dH

    def _hessian(self, x: np.ndarray) -> np.ndarray:
        if self.effect == "gravity":  # linear in q
            return np.zeros((*self.idx.shape, self.idx.shape[1]))
        if not registry.has_third_derivatives(self.element, self.effect, self.gauss):
            raise ValueError(f"the prestrain's second-order derivative needs the third derivatives of "
                             f"{self.element}/{self.effect} (gauss {self.gauss}), which are not compiled")
        m = position_mask(self.element)
        N, nd = self.idx.shape
        Q = x[self.idx]
        _, _, H = self._eval(x, self.P)
        T = _mapped("hvp", self.element, self.effect, None, N)(Q.T, self.P.T, (Q * m).T)[1].full()
        dH = -T.reshape(nd, N, nd).transpose(1, 0, 2) - m[None, :, None] * H - H * m[None, None, :]
        for a, P in self._parts():
            dH = dH + a * (self._eval(x, P)[2] if P is not self.P else H)
        return self.factor * dH


def mass_derivative(asm, members: list[str], factor: float) -> sp.csc_matrix:
    """d M/deps of the members' own mass matrices (dL/deps = factor L): (1 + s_i + s_j) M_ij factor."""
    rows, cols, vals = [], [], []
    for name in members:
        mm = asm.mesh.members[name]
        m = mm.member
        idx = mm.elem_dofs()
        s = 1.0 - position_mask(m.element)
        scale = 1.0 + s[:, None] + s[None, :]
        lengths, which = np.unique(np.asarray(mm.elem_length, float), return_inverse=True)
        blocks = [(factor * scale * kernels.mass_matrix(m.element, [float(L), m.material.density * m.section.area]))
                  .ravel() for L in lengths]  # (one kernel call per distinct length: equal elements share it)
        nd = idx.shape[1]
        rows.append(np.repeat(idx, nd, axis=1).ravel())
        cols.append(np.tile(idx, (1, nd)).ravel())
        vals.append(np.concatenate([blocks[w] for w in which]))
    return sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(asm.n, asm.n))


def prestrain_refusal(asm, name: str) -> str | None:
    """Why the prestrain of member `name` is not differentiable here (None: it is)."""
    scene = asm.scene
    m = scene.members[name]
    if m.element == "beam3d":
        return "a beam3d member's section size enters its kernels with the length (not differentiable here)"
    if m.arc_curvature is not None:
        return "an arc's prestrain follows from its curvature (not a free number)"
    for i, load in enumerate(scene.loads):
        if load.member == name and isinstance(load.at, float):
            return (f"loads[{i}] acts at the material coordinate {load.at:g} m, whose element and place in it move "
                    "with the prestrain (put it at a node)")
    for i, pm in enumerate(getattr(scene, "point_masses", ())):
        if pm.member == name and isinstance(pm.at, float):
            return f"masses[{i}] sits at the material coordinate {pm.at:g} m (put it at a node)"
    for i, c in enumerate(getattr(scene, "contacts", ())):
        if c.member == name:
            return f"contacts[{i}] on the member: the contact kernels' lengths are not differentiated here"
    for j in scene.joints:
        if j.kind == "rigid" and scene.dim == 3 and name in (j.a[0], j.b[0]) and j.a[0] != j.b[0]:
            return "a spatial rigid joint to another member keeps the ratio of the reference slopes' lengths"
    for t in asm.terms:
        if t.effect not in WEIGHTS and _member_rows(asm, t, name).any():
            return f"its {t.effect!r} energy has no length derivative here"
    return None


def _member_rows(asm, term, name: str) -> np.ndarray:
    mm = asm.mesh.members[name]
    first = term.idx[:, 0]
    return (first >= mm.offset) & (first < mm.offset + mm.x0.size)


def prestrain_pieces(asm, name: str, prestrain: float) -> list[LengthPiece]:
    """The length pieces of every term on member `name` (check prestrain_refusal first)."""
    factor = -1.0 / (1.0 + prestrain)
    out = []
    for t in asm.terms:
        rows = _member_rows(asm, t, name)
        # (a moment's potential depends on its reference tangent's direction only, not on its length 1 + eps)
        if rows.any() and t.effect in WEIGHTS:
            out.append(LengthPiece(t.element, t.effect, t.gauss, t.idx[rows], np.asarray(t.P[rows], float),
                                   t.label, factor))
    return out
