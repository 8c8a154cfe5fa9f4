"""Contact of members with the ground and with fixed drums: scene declaration, energy terms, and the dissipation kernels of the step graphs.

The normal law is a potential (kernel <element>_contact_ground): it enters the scene's total potential as a term
like any other, so statics (penalty contact) and every integrator see it with its exact Hessian. Damping and
friction depend on the velocity: their kernel (<element>_contact_ground_friction) is a dissipation function
D([q; v]) whose v-gradient is the force and whose Hessian blocks are its exact tangents d f / d q, d f / d v; the
step graphs add them to the strain-rate damping force (ancf_sym.system.damping, from `dissipation_calls`), so the
damping work they book includes the friction and contact-damping work. Only scenes that declare contact pay.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from ancf_sym.elements.hermite import weights
from ancf_sym.util.checks import SceneError

LABEL = "contact"


@dataclass(frozen=True)
class ContactLaw:
    """What every contact shares: the member, the normal law k/2 delta^2 + 2/5 kh delta^2.5 per unit length (delta:
    penetration of the section's surface, half thickness `thickness`), damping c delta (n.w), regularised Coulomb
    friction mu f_n w_t / sqrt(|w_t|^2 + eps^2), at `gauss` points per element."""
    member: str
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


@dataclass(frozen=True, kw_only=True)
class GroundContact(ContactLaw):
    """Centre line of `member` against the half-space {n.r >= level}, with the ContactLaw."""
    normal: np.ndarray
    level: float


def _nonnegative(name: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SceneError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v < 0:
        raise SceneError(f"{name} must be finite and >= 0, got {value!r}")
    return v


def _law(scene, f: str, member: str, stiffness, hertz, thickness, damping, mu, eps, gauss, method) -> dict:
    """The validated ContactLaw fields (member, normal law, section half thickness, damping, friction)."""
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
    return dict(member=member, stiffness=k, hertz=kh, thickness=t, damping=c, mu=mu_, eps=e if e > 0 else 1e-3,
                gauss=int(gauss), method=method)


def _vector(f: str, name: str, value, dim: int, unit: bool) -> np.ndarray:
    v = np.asarray(value, float).ravel() if value is not None else np.zeros(0)
    if v.shape != (dim,) or not np.all(np.isfinite(v)) or (unit and np.linalg.norm(v) == 0):
        kind = "a non-zero vector" if unit else "a vector"
        raise SceneError(f"{f}: {name} must be {kind} of {dim} numbers, got {value!r}")
    return v / np.linalg.norm(v) if unit else v


def ground(scene, member: str, stiffness: float = 0.0, hertz: float = 0.0, normal: Sequence[float] | None = None,
           level: float = 0.0, thickness: float | None = None, damping: float = 0.0, mu: float = 0.0,
           eps: float = 1e-3, gauss: int = 5, method: str = "penalty") -> GroundContact:
    """Validated GroundContact of a scene member (see Scene.contact_ground)."""
    f = f"contact_ground(member={member!r})"
    law = _law(scene, f, member, stiffness, hertz, thickness, damping, mu, eps, gauss, method)
    n = np.zeros(scene.dim)
    n[1 if scene.dim == 2 else 2] = 1.0
    if normal is not None:
        n = _vector(f, "normal", normal, scene.dim, True)
    lvl = float(level)
    if not math.isfinite(lvl):
        raise SceneError(f"{f}: level must be finite, got {level!r}")
    return GroundContact(normal=n, level=lvl, **law)


@dataclass(frozen=True, kw_only=True)
class DrumContact(ContactLaw):
    """Centre line of `member` outside a fixed drum: circle (2D) or cylinder of unit axis `axis` (3D) of centre
    `centre` and radius `radius`; the ContactLaw with the radial gap |r - c|_perp - radius - thickness. The centre
    is a kernel parameter (kernel <element>_contact_drum); a drum carried by a rigid body uses the kernels with the
    centre and angle as inputs (<element>_contact_circle). A drum carried by a planar rigid body (`body`: centred at
    its centre of mass, turning with it) uses <element>_contact_circle on [q, x, y] and
    <element>_contact_body_friction on [q, x, y, c, s; rates] (the body's spin c s' - s c'): the contact forces act
    on the member and on the body, with exact tangents through the body's coordinates. A drum carried by a spatial
    body (3D): `centre` a point on its axis and `axis`, world, reference state (ancf_sym.contact.body)."""
    centre: np.ndarray
    radius: float
    axis: np.ndarray | None
    body: str | None = None


def drum(scene, member: str, centre: Sequence[float] | None, radius: float, axis: Sequence[float] | None = None,
         stiffness: float = 0.0, hertz: float = 0.0, thickness: float | None = None, damping: float = 0.0,
         mu: float = 0.0, eps: float = 1e-3, gauss: int = 5, method: str = "penalty",
         body: str | None = None) -> DrumContact:
    """Validated DrumContact of a scene member (see Scene.contact_drum)."""
    f = f"contact_drum(member={member!r})"
    law = _law(scene, f, member, stiffness, hertz, thickness, damping, mu, eps, gauss, method)
    if body is not None:
        if body not in scene.bodies:
            raise SceneError(f"{f}: body {body!r} does not exist; bodies: {sorted(scene.bodies)}")
        if scene.dim == 3:  # a spatial body's drum (ancf_sym.contact.body): centre and axis fixed in the body
            from ancf_sym.contact.body import geometry

            centre, axis = geometry(scene, body, centre, axis)
        elif scene.members[member].element != "cable2d":
            raise SceneError(f"{f}: a drum carried by a (planar) body is for cable2d members, got "
                             f"{scene.members[member].element!r}")
        elif centre is not None:
            raise SceneError(f"{f}: a body-carried drum is centred at the body's centre of mass: leave centre out, "
                             f"got {centre!r}")
        else:
            centre = scene.bodies[body].position
    elif centre is None:
        raise SceneError(f"{f}: centre: missing (a fixed drum's centre, or body = the body carrying the drum)")
    c = _vector(f, "centre", centre, scene.dim, False)
    try:
        R = float(radius)
    except (TypeError, ValueError):
        raise SceneError(f"{f}: radius must be a number, got {radius!r}") from None
    if not math.isfinite(R) or R <= 0:
        raise SceneError(f"{f}: radius must be finite and > 0, got {radius!r}")
    if scene.dim == 2:
        if axis is not None:
            raise SceneError(f"{f}: axis is for 3D scenes (a 2D drum turns about z), got {axis!r}")
        a = None
    else:
        a = _vector(f, "axis", (0.0, 0.0, 1.0) if axis is None else axis, 3, True)
    return DrumContact(centre=c, radius=R, axis=a, body=body, **law)


def _effect(c) -> str:
    return "contact_drum" if isinstance(c, DrumContact) else "contact_ground"


def kernel_call(c, mesh, friction: bool) -> tuple[str, np.ndarray, np.ndarray]:
    """(effect, idx (N, kernel input), P (N, parameters)) of a contact's normal-law (or, friction, dissipation)
    kernel: a body-carried drum's kernels take the body's coordinates after the element's."""
    mm = mesh.members[c.member]
    idx, L = mm.elem_dofs(), mm.elem_length
    if isinstance(c, DrumContact) and c.body is not None and mesh.scene.dim == 3:
        from ancf_sym.contact.body import call

        return call(c, mesh, friction)
    if isinstance(c, DrumContact) and c.body is not None:
        o = mesh.bodies[c.body]
        extra = np.arange(o, o + (4 if friction else 2))
        idx = np.hstack([idx, np.tile(extra, (len(idx), 1))])
        P = _params(c, L, friction)[:, :-mesh.scene.dim]  # (no centre parameter: the body's coordinates)
        return ("contact_body_friction" if friction else "contact_circle"), idx, P
    return _effect(c) + ("_friction" if friction else ""), idx, _params(c, L, friction)


def _params(c, L: np.ndarray, friction: bool) -> np.ndarray:
    """Kernel parameters per element (registry: ground (L, k, kh, t, n, d[, c, mu, eps]); fixed drum
    (L, k, kh, t, R[, axis][, c, mu, eps], centre); a body's drum: the same without the centre)."""
    one = np.ones_like(L)
    cols = [L, c.stiffness * one, c.hertz * one, c.thickness * one]
    if isinstance(c, DrumContact):
        cols += [c.radius * one, *(v * one for v in (c.axis if c.axis is not None else ()))]
    else:
        cols += [*(v * one for v in c.normal), c.level * one]
    if friction:
        cols += [c.damping * one, c.mu * one, c.eps * one]
    if isinstance(c, DrumContact):
        cols += [v * one for v in c.centre]
    return np.column_stack(cols)


def energy_terms(terms: dict, mesh, add) -> None:
    """The normal-law terms of the scene's contacts (terms.scene_terms calls this; `add` is terms._add)."""
    for c in getattr(mesh.scene, "contacts", ()):
        if c.method != "penalty":
            continue
        effect, idx, P = kernel_call(c, mesh, False)
        add(terms, LABEL, mesh.members[c.member].member.element, effect, c.gauss, idx, P)


def dissipation_calls(mesh) -> list[tuple[str, int, np.ndarray, np.ndarray]]:
    """(element, effect, gauss, idx (N, nd), P) of the damping/friction kernels the scene needs (empty: none)."""
    out = []
    for c in getattr(mesh.scene, "contacts", ()):
        if c.dissipative:
            effect, idx, P = kernel_call(c, mesh, True)
            out.append((mesh.members[c.member].member.element, effect, c.gauss, idx, P))
    return out


def exact_contacts(asm) -> list:
    """The scene's exact (unilateral-row) contacts, in declaration order; empty: no contact rows."""
    return [c for c in getattr(asm.scene, "contacts", ()) if c.method == "exact"]


def check_dynamics(asm) -> None:
    """Exact contact is a statics method: refuse it in a dynamic run, before any work."""
    exact = exact_contacts(asm)
    if exact:
        raise SceneError(f"{_effect(exact[0])}(member={exact[0].member!r}): method='exact' (unilateral "
                         "constraints) is for statics; dynamics needs method='penalty' (a stiffness or hertz law)")


# -- statics with exact frictionless contact: unilateral constraints g(x) = A x - b >= 0 --------------------------

def position_rows(element: str, L: float, xi: float, dim: int) -> np.ndarray:
    """(dim, nd) matrix S with r(xi) = S q_e (cubic Hermite centre line; beam3d: the r and r_x blocks)."""
    from ancf_sym.registry import ELEMENTS

    w = weights(xi, L)[0]  # r = w0 r(0) + w1 r_x(0) + w2 r(L) + w3 r_x(L)
    nd = ELEMENTS[element].ndof
    S = np.zeros((dim, nd))
    node = nd // 2
    for off, coef in zip((0, dim, node, node + dim), w):
        S[:, off:off + dim] += coef * np.eye(dim)
    return S


def unilateral(asm, only=None) -> tuple | None:
    """(A (m x n sparse), b, labels) of the exact ground contacts' rows n.r(xi_k) - level - t >= 0 at the Gauss
    points of every element (the points where the penalty law is evaluated), or None; `only`: of that contact.
    Linear in x: no Hessian term. (All exact contacts, drums too: ancf_sym.contact.exact.)"""
    from ancf_sym.elements.quadrature import gauss01

    rows, cols, vals, b, labels = [], [], [], [], []
    m = 0
    for c in getattr(asm.scene, "contacts", ()):
        if c.method != "exact" or isinstance(c, DrumContact) or (only is not None and c is not only):
            continue
        mm = asm.mesh.members[c.member]
        d = asm.scene.dim
        for e, (idx, L) in enumerate(zip(mm.elem_dofs(), mm.elem_length)):
            for xi in gauss01(c.gauss)[0]:
                a = c.normal @ position_rows(mm.member.element, L, float(xi), d)
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
