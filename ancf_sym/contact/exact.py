"""Exact frictionless contact in statics: the contact points' gaps as unilateral constraints g(x) >= 0 of IPOPT.

Every exact contact gives one row per contact point (the `gauss` Gauss points of every element of its member, where
the penalty law is evaluated), in the order the scene declares the contacts:
- ground: g = n.r(xi) - level - t, linear in x (ancf_sym.contact.unilateral): no Hessian term;
- drum: g = |r(xi) - c|_perp - R - t, the compiled kernel <element>_contact_circle_gap (a fixed drum: its centre a
  constant input; a planar body's drum: the body's x, y) or <element>_contact_body_drum_gap (a spatial body's drum:
  the body's r, e1, e2, e3), one call per point, mapped; its gradient gives the constraint Jacobian and its Hessian,
  weighted by the rows' multipliers, the constraints' part of the Hessian of the Lagrangian (exact, no differences).
The multiplier of a row is the contact force at its point [N] (the gap's gradient in r is the unit normal).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym import kernels
from ancf_sym.contact.laws import DrumContact, exact_contacts, unilateral
from ancf_sym.contact.body import BODY_SIZE
from ancf_sym.elements.quadrature import gauss01
from ancf_sym.util.sparsity import dm, hessian_entries, scatter


@dataclass(frozen=True)
class Rows:
    """The rows of one exact contact: linear (A x - b >= 0: A, b) or a gap kernel (element, effect) on the inputs
    z = [x; constants][idx] (idx >= n: the constant const[idx - n], a fixed drum's centre) with parameters P."""
    contact: object
    labels: list  # (member, element, xi) per row
    A: sp.csr_matrix | None = None
    b: np.ndarray | None = None
    element: str = ""
    effect: str = ""
    idx: np.ndarray | None = None  # (rows, kernel inputs)
    const: np.ndarray | None = None
    P: np.ndarray | None = None

    @property
    def m(self) -> int:
        return len(self.labels)


def rows(asm) -> list[Rows]:
    """Rows of every exact contact, in declaration order."""
    out = []
    for c in exact_contacts(asm):
        if not isinstance(c, DrumContact):
            A, b, labels = unilateral(asm, only=c)
            out.append(Rows(c, labels, A=A, b=b))
        else:
            out.append(_drum_rows(asm, c))
    return out


def _drum_rows(asm, c: DrumContact) -> Rows:
    mesh = asm.mesh
    mm = mesh.members[c.member]
    element = mm.member.element
    xis = gauss01(c.gauss)[0]
    E, X = np.meshgrid(np.arange(len(mm.elem_length)), xis, indexing="ij")
    e, xi = E.ravel(), X.ravel()
    idx = mm.elem_dofs()[e]
    geo = [c.thickness, c.radius, *(c.axis if c.axis is not None else ())]
    const = np.zeros(0)
    if c.body is None:  # a fixed drum: its centre, a constant input
        idx = np.hstack([idx, np.tile(asm.n + np.arange(len(c.centre)), (len(idx), 1))])
        const = np.asarray(c.centre, float)
        effect = "contact_circle_gap"
    elif asm.scene.dim == 2:  # a planar body's drum: centred at its (x, y)
        o = mesh.bodies[c.body]
        idx = np.hstack([idx, np.tile([o, o + 1], (len(idx), 1))])
        effect = "contact_circle_gap"
    else:  # a spatial body's: axis and axis point in body components
        b, o = asm.scene.bodies[c.body], mesh.bodies[c.body]
        idx = np.hstack([idx, np.tile(np.arange(o, o + BODY_SIZE), (len(idx), 1))])
        geo = [c.thickness, c.radius, *b.local_direction(c.axis), *b.local(c.centre)]
        effect = "contact_body_drum_gap"
    P = np.column_stack([mm.elem_length[e], xi, np.tile(geo, (len(e), 1))])
    labels = [(c.member, int(a), float(z)) for a, z in zip(e, xi)]
    return Rows(c, labels, element=element, effect=effect, idx=idx, const=const, P=P)


def _inputs(r: Rows, x: np.ndarray) -> np.ndarray:
    return np.r_[np.asarray(x, float), r.const][r.idx]


def gaps(asm, x: np.ndarray, blocks: list[Rows] | None = None) -> np.ndarray:
    """Gap of every contact point [m] (section surface to obstacle; negative: penetration), in row order."""
    out = []
    for r in rows(asm) if blocks is None else blocks:
        if r.A is not None:
            out.append(r.A @ np.asarray(x, float) - r.b)
        else:
            f = kernels.load(r.element, r.effect).map(r.m)
            out.append(np.asarray(f(_inputs(r, x).T, r.P.T)[0]).ravel())
    return np.concatenate(out) if out else np.zeros(0)


def _kind(r: Rows) -> str:
    return "circle" if isinstance(r.contact, DrumContact) else "ground"


def points(asm, x: np.ndarray, forces) -> list[dict]:
    """Per contact point: type ('ground' or 'circle'), member, element, xi (in the element, 0..1), gap [m] and
    force [N] (the point's multiplier: forces = result.constraint_forces['contact'])."""
    blocks = rows(asm)
    g, f = gaps(asm, x, blocks), np.asarray(forces, float)
    kinds = [_kind(r) for r in blocks for _ in r.labels]
    labels = [lbl for r in blocks for lbl in r.labels]
    return [{"type": k, "member": m, "element": e, "xi": xi, "gap": float(gi), "force": float(fi)}
            for k, (m, e, xi), gi, fi in zip(kinds, labels, g, f)]


def report(asm, x: np.ndarray, forces=None) -> list[dict]:
    """Per exact contact (as ancf_sym.contact.report per penalty contact): type, member, method 'exact', the
    smallest gap of its points min_gap [m], the sum of their forces normal_force [N] and per point gap and force
    (forces: result.constraint_forces['contact']; None, a failed solve's: NaN)."""
    out, i = [], 0
    blocks = rows(asm)
    g = gaps(asm, x, blocks)
    f = np.full(len(g), np.nan) if forces is None else np.asarray(forces, float)
    for r in blocks:
        sl = slice(i, i + r.m)
        i += r.m
        out.append({"type": _kind(r), "member": r.contact.member,
                    "method": "exact", "min_gap": float(g[sl].min()), "normal_force": float(f[sl].sum()),
                    "gaps": g[sl].tolist(), "forces": f[sl].tolist()})
    return out


def node_fields(asm, x: np.ndarray, forces) -> dict[str, dict[str, np.ndarray]]:
    """Per member with exact contact: nodal 'contact_gap' [m] (the smallest gap of the points of the elements at the
    node) and 'contact_force' [N] (each point's force shared by its element's nodes as (1 - xi, xi): the sum kept),
    for VTK point data (ancf_sym.contact.point_data)."""
    out: dict = {}
    for p in points(asm, x, forces):
        mm = asm.mesh.members[p["member"]]
        f = out.setdefault(p["member"], {"contact_gap": np.full(mm.n_nodes, np.inf),
                                         "contact_force": np.zeros(mm.n_nodes)})
        a, b = mm.elem_nodes[p["element"]]
        f["contact_gap"][[a, b]] = np.minimum(f["contact_gap"][[a, b]], p["gap"])
        f["contact_force"][a] += (1 - p["xi"]) * p["force"]
        f["contact_force"][b] += p["xi"] * p["force"]
    return out


def casadi_rows(asm, blocks: list[Rows], x: ca.MX, lam: ca.MX):
    """(g (m), lower bounds (m), Jacobian (m x n), upper triangle of sum_k lam_k Hess g_k (n x n)) of the rows as MX
    of x and the rows' multipliers lam: linear rows as constant matrices, drum rows from the gap kernels."""
    n = asm.n
    g, lb, J, H, i = [], [], [], ca.MX(n, n), 0
    for r in blocks:
        if r.A is not None:
            Ad = dm(r.A)
            g.append(ca.mtimes(Ad, x))
            J.append(ca.MX(Ad))
            lb.append(r.b)
        else:
            N, nin = r.idx.shape
            z = ca.vertcat(x, ca.DM(r.const)) if len(r.const) else x
            Z = ca.reshape(z[r.idx.ravel().tolist()], nin, N)
            Pm = ca.DM(r.P.T)
            _, G, Hk = kernels.load(r.element, r.effect).map(N)(Z, Pm)
            # the values through the energy function: its compiled reverse companion lets IPOPT's interface
            # differentiate g where it wants to (the Jacobian and Hessian it uses are G and Hk)
            g.append(kernels.load_energy(r.element, r.effect).map(N)(Z, Pm).T)
            lb.append(np.zeros(N))
            pos = np.r_[np.arange(n), -np.ones(len(r.const), dtype=np.int64)]
            cols = pos[r.idx.ravel()]  # entry k nin + a of vec(G): row k, unknown idx[k, a]
            keep = np.flatnonzero(cols >= 0)
            J.append(scatter([ca.vec(G)], np.repeat(np.arange(N), nin)[keep], cols[keep], N, keep, N * nin, n))
            ia, ib, both = hessian_entries(pos, r.idx)
            up = both[ib[both] <= ia[both]]  # upper triangle: row ib <= column ia
            w = ca.vec(ca.repmat(lam[i:i + N].T, nin * nin, 1))  # each point's multiplier on its nin^2 entries
            H = H + scatter([ca.vec(Hk) * w], ib[up], ia[up], n, up, N * nin * nin)
        i += r.m
    if not g:
        return ca.MX(0, 1), np.zeros(0), ca.MX(0, n), H
    return ca.vertcat(*g), np.concatenate(lb), ca.vertcat(*J), H
