"""Contact of members with the ground: scene declaration, energy terms, and the dissipation forces of the step graphs.

The normal law is a potential (kernel <element>_contact_ground): it enters the scene's total potential as a term
like any other, so statics (penalty contact) and every integrator see it with its exact Hessian. Damping and
friction depend on the velocity: their kernel (<element>_contact_ground_friction) is a dissipation function
D([q; v]) whose v-gradient is the force and whose Hessian blocks are its exact tangents d f / d q, d f / d v; the
step graphs add them where they add the strain-rate damping force (integrators.StepSystem._build_damping), so the
damping work they book includes the friction and contact-damping work. Only scenes that declare contact pay.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import casadi as ca
import numpy as np

from . import kernels
from .scene import SceneError

LABEL = "contact"


@dataclass(frozen=True)
class GroundContact:
    """Centre line of `member` against the half-space {n.r >= level}: normal law k/2 delta^2 + 2/5 kh delta^2.5
    per unit length (delta: penetration of the section's surface, half thickness `thickness`), damping c delta (n.w),
    regularised Coulomb friction mu f_n w_t / sqrt(|w_t|^2 + eps^2), at `gauss` points per element."""
    member: str
    normal: np.ndarray
    level: float
    stiffness: float
    hertz: float
    thickness: float
    damping: float
    mu: float
    eps: float
    gauss: int
    method: str = "penalty"  # "exact": statics with unilateral constraints g >= 0 at the contact points

    @property
    def dissipative(self) -> bool:
        return self.method == "penalty" and (self.damping > 0 or self.mu > 0)


def _nonnegative(name: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SceneError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v < 0:
        raise SceneError(f"{name} must be finite and >= 0, got {value!r}")
    return v


def ground(scene, member: str, stiffness: float = 0.0, hertz: float = 0.0, normal: Sequence[float] | None = None,
           level: float = 0.0, thickness: float | None = None, damping: float = 0.0, mu: float = 0.0,
           eps: float = 1e-3, gauss: int = 5, method: str = "penalty") -> GroundContact:
    """Validated GroundContact of a scene member (see Scene.contact_ground)."""
    f = f"contact_ground(member={member!r})"
    if member not in scene.members:
        raise SceneError(f"{f}: member {member!r} does not exist; members: {sorted(scene.members)}")
    m = scene.members[member]
    if method not in ("penalty", "exact"):
        raise SceneError(f"{f}: method must be 'penalty' or 'exact', got {method!r}")
    k, kh = _nonnegative(f"{f}: stiffness", stiffness), _nonnegative(f"{f}: hertz", hertz)
    if method == "exact":
        if k or kh or float(damping) or float(mu):
            raise SceneError(f"{f}: method='exact' is frictionless unilateral contact without a stiffness: leave "
                             f"stiffness, hertz, damping and mu at 0 (got {stiffness!r}, {hertz!r}, {damping!r}, "
                             f"{mu!r})")
    elif k == 0 and kh == 0:
        raise SceneError(f"{f}: give a positive stiffness (linear penalty, N/m^2) or hertz (N/m^2.5 per m)")
    n = np.zeros(scene.dim)
    n[1 if scene.dim == 2 else 2] = 1.0
    if normal is not None:
        n = np.asarray(normal, float).ravel()
        if n.shape != (scene.dim,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) == 0:
            raise SceneError(f"{f}: normal must be a non-zero vector of {scene.dim} numbers, got {normal!r}")
        n = n / np.linalg.norm(n)
    lvl = float(level)
    if not math.isfinite(lvl):
        raise SceneError(f"{f}: level must be finite, got {level!r}")
    if thickness is None:
        s = m.section
        # cables are round (radius from the area); a beam3d section's half height h/2
        t = s.h / 2 if m.element == "beam3d" else math.sqrt(s.area / math.pi)
    else:
        t = _nonnegative(f"{f}: thickness", thickness)
    c, mu_ = _nonnegative(f"{f}: damping", damping), _nonnegative(f"{f}: mu", mu)
    e = _nonnegative(f"{f}: eps", eps)
    if mu_ > 0 and e == 0:
        raise SceneError(f"{f}: eps (friction regularisation velocity, m/s) must be > 0 with friction, got {eps!r}")
    if gauss not in (3, 5, 7):
        raise SceneError(f"{f}: gauss must be 3, 5 or 7, got {gauss!r}")
    return GroundContact(member, n, lvl, k, kh, t, c, mu_, e if e > 0 else 1e-3, int(gauss), method)


TOML_KEYS = ("type", "member", "stiffness", "hertz", "normal", "level", "thickness", "damping", "mu", "eps", "gauss",
             "method")


def from_toml(scene, d: dict) -> GroundContact:
    """A [[contacts]] table: type = "ground" and the keyword arguments of Scene.contact_ground."""
    unknown = sorted(set(d) - set(TOML_KEYS))
    if unknown:
        raise SceneError(f"unknown key {unknown[0]!r} (allowed: {', '.join(TOML_KEYS)})")
    if d.get("type", "ground") != "ground":
        raise SceneError(f"type must be 'ground', got {d.get('type')!r}")
    if "member" not in d:
        raise SceneError("member: missing (the member whose centre line touches the ground)")
    for k, v in d.items():
        if k not in ("type", "member", "normal", "method") and (isinstance(v, bool) or not isinstance(v, (int, float))):
            raise SceneError(f"{k} must be a number, got {v!r}")
    kw = {k: v for k, v in d.items() if k != "type"}
    if "gauss" in kw and isinstance(kw["gauss"], float) and kw["gauss"].is_integer():
        kw["gauss"] = int(kw["gauss"])
    return scene.contact_ground(**kw)


def _params(c: GroundContact, L: np.ndarray, friction: bool) -> np.ndarray:
    one = np.ones_like(L)
    cols = [L, c.stiffness * one, c.hertz * one, c.thickness * one, *(v * one for v in c.normal), c.level * one]
    if friction:
        cols += [c.damping * one, c.mu * one, c.eps * one]
    return np.column_stack(cols)


def energy_terms(terms: dict, mesh, add) -> None:
    """The normal-law terms of the scene's contacts (terms.scene_terms calls this; `add` is terms._add)."""
    for c in getattr(mesh.scene, "contacts", ()):
        if c.method != "penalty":
            continue
        mm = mesh.members[c.member]
        add(terms, LABEL, mm.member.element, "contact_ground", c.gauss, mm.elem_dofs(),
            _params(c, mm.elem_length, False))


def dissipation_calls(mesh) -> list[tuple[str, int, np.ndarray, np.ndarray]]:
    """(element, gauss, idx (N, nd), P) of the damping/friction kernels the scene needs (empty: none)."""
    out = []
    for c in getattr(mesh.scene, "contacts", ()):
        if c.dissipative:
            mm = mesh.members[c.member]
            out.append((mm.member.element, c.gauss, mm.elem_dofs(), _params(c, mm.elem_length, True)))
    return out


def check_dynamics(asm) -> None:
    """Exact contact is a statics method: refuse it in a dynamic run, before any work."""
    exact = [c.member for c in getattr(asm.scene, "contacts", ()) if c.method == "exact"]
    if exact:
        raise SceneError(f"contact_ground(member={exact[0]!r}): method='exact' (unilateral constraints) is for "
                         "statics; dynamics needs method='penalty' (a stiffness or hertz law)")


def dissipation_mx(S, X: ca.MX, V: ca.MX):
    """(f, df/dx, df/dv) on the unknowns of step system S, for full coordinates X and velocities V (MX in S's
    unknowns x, v), or None without dissipative contact. Assembled from the kernels' gradient (v-part) and Hessian
    blocks: exact tangents, no differentiation through the compiled calls."""
    calls = dissipation_calls(S.asm.mesh)
    if not calls:
        return None
    from .integrators import _gather_sum

    nf, pos = S.nf, S.pos
    fv, ft, hv, rx, cx, sx, rv, cv, sv = [], [], [], [], [], [], [], [], []
    n_h = 0
    for element, gauss, idx, P in calls:
        N, nd = idx.shape
        k = kernels.load(element, "contact_ground_friction", None if gauss == 5 else gauss)
        Z = ca.vertcat(ca.reshape(X[idx.ravel().tolist()], nd, N), ca.reshape(V[idx.ravel().tolist()], nd, N))
        _, G, H = k.map(N)(Z, ca.DM(P.T))
        fv.append(ca.vec(G[nd:, :]))
        ft.append(pos[idx.ravel()])  # vec of G[nd:, :]: element e, row a -> coordinate idx[e, a]
        hv.append(ca.vec(H))
        # vec(H) entry e (2nd)^2 + b 2nd + a is d2D / dz_a dz_b; rows a >= nd (forces), columns b < nd (x), >= nd (v)
        e, b, a = np.meshgrid(np.arange(N), np.arange(2 * nd), np.arange(2 * nd), indexing="ij")
        src = n_h + (e * (2 * nd) ** 2 + b * 2 * nd + a).ravel()
        e, b, a = e.ravel(), b.ravel(), a.ravel()
        row = np.where(a >= nd, pos[idx[e, a % nd]], -1)
        col = pos[idx[e, b % nd]]
        ok = (row >= 0) & (col >= 0)
        for sel, R, C, S_ in ((ok & (b < nd), rx, cx, sx), (ok & (b >= nd), rv, cv, sv)):
            R.append(row[sel])
            C.append(col[sel])
            S_.append(src[sel])
        n_h += N * (2 * nd) ** 2
    f = _gather_sum(fv, np.concatenate(ft), nf)
    dfx = S._scatter(hv, np.concatenate(rx), np.concatenate(cx), np.concatenate(sx), n_h)
    dfv = S._scatter(hv, np.concatenate(rv), np.concatenate(cv), np.concatenate(sv), n_h)
    return f, dfx, dfv


def report(asm, x: np.ndarray) -> list[dict]:
    """Per contact: smallest gap of the section surface at the nodes [m] and the total normal force [N] (from the
    normal law's gradient along the normal)."""
    out = []
    for c in getattr(asm.scene, "contacts", ()):
        if c.method != "penalty":
            continue
        mm = asm.mesh.members[c.member]
        X = asm.member_coordinates(x, c.member)
        gaps = X[:, :asm.scene.dim] @ c.normal - c.level - c.thickness
        idx, d = mm.elem_dofs(), asm.scene.dim
        k = kernels.load(mm.member.element, "contact_ground", None if c.gauss == 5 else c.gauss)
        G = np.asarray(k.map(len(idx))(np.asarray(x)[idx].T, _params(c, mm.elem_length, False).T)[1]).T
        per_node = 2 if mm.member.element.startswith("cable") else 4
        force = float(-(G.reshape(len(idx), -1, d)[:, ::per_node, :] @ c.normal).sum())
        out.append({"member": c.member, "min_gap": float(gaps.min()), "normal_force": force})
    return out


# -- statics with exact frictionless contact: unilateral constraints g(x) = A x - b >= 0 --------------------------

def _position_rows(element: str, L: float, xi: float, dim: int) -> np.ndarray:
    """(dim, nd) matrix S with r(xi) = S q_e (cubic Hermite centre line; beam3d: the r and r_x blocks)."""
    from .elements import hermite  # plain polynomials of xi: numbers in, numbers out
    from .registry import ELEMENTS

    h = hermite.h(xi)
    nd = ELEMENTS[element].ndof
    S = np.zeros((dim, nd))
    node = nd // 2
    eye = np.eye(dim)
    for k, (off, coef) in enumerate(((0, h[0]), (dim, L * h[1]), (node, h[2]), (node + dim, L * h[3]))):
        S[:, off:off + dim] += coef * eye
    return S


def unilateral(asm) -> tuple | None:
    """(A (m x n sparse), b, labels) of the exact contacts' rows n.r(xi_k) - level - t >= 0 at the Gauss points of
    every element (the points where the penalty law is evaluated), or None. Linear in x: no Hessian term."""
    from .elements.quadrature import gauss01

    rows, cols, vals, b, labels = [], [], [], [], []
    m = 0
    for c in getattr(asm.scene, "contacts", ()):
        if c.method != "exact":
            continue
        mm = asm.mesh.members[c.member]
        d = asm.scene.dim
        for e, (idx, L) in enumerate(zip(mm.elem_dofs(), mm.elem_length)):
            for xi in gauss01(c.gauss)[0]:
                a = c.normal @ _position_rows(mm.member.element, L, float(xi), d)
                nz = np.flatnonzero(a)
                rows += [m] * len(nz)
                cols += idx[nz].tolist()
                vals += a[nz].tolist()
                b.append(c.level + c.thickness)
                labels.append((c.member, e, float(xi)))
                m += 1
    if not m:
        return None
    import scipy.sparse as sp

    return sp.csr_matrix((vals, (rows, cols)), shape=(m, asm.n)), np.array(b), labels
