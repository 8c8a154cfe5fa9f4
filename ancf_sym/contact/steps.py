"""The statics step limit that keeps penalty contact points from tunnelling through drums.

A Newton step from a state far from equilibrium can be long (a slender cable's first, linear step deflects it by
many lengths): with a penalty law it may carry a contact point into a drum, past its axis and out on the far side,
where the law then pushes it further away. The iteration converges there, on a branch that never touched the drum
(measured on Exudyn's ANCFcontactCircleTest: tip 1.4 m below the contact branch, zero contact force).

The limit: along a step x + t dz (t in [0, 1]) every contact point of a penalty drum moves on a straight line
relative to the drum's axis (r(xi) = S q is linear in the coordinates; a fixed drum's centre is constant, a planar
body's moves linearly with its coordinates; a spatial body's axis turns with the body, so there the relative
position is interpolated between the step's ends). The step is cut back to the first t at which a point comes
closer to the axis than half the contact radius rho = R + thickness (half of it from a point already deeper), so
a point can enter a drum but never reach its axis, the law's normal never flips, and the next Newton step pushes
the point back out on the side it came from. The points are the law's Gauss points and the element ends. Ground
contacts need no limit: a half-space has no far side.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym.contact import body as contact_body
from ancf_sym.contact.laws import DrumContact, position_rows
from ancf_sym.elements.quadrature import gauss01

DEPTH = 0.5  # a step may take a point at most this fraction of the contact radius into a drum


class StepLimit:
    """The penalty drums of a scene and their points as linear maps of the full coordinates."""

    def __init__(self, asm, drums: list):
        self.asm = asm
        self.dim = d = asm.scene.dim
        self.blocks = []  # (contact, P (points*dim x n) sparse, rho)
        for c in drums:
            mm = asm.mesh.members[c.member]
            xis = np.r_[0.0, gauss01(c.gauss)[0], 1.0]
            rows, cols, vals, m = [], [], [], 0
            for idx, L in zip(mm.elem_dofs(), mm.elem_length):
                for xi in xis:
                    S = position_rows(mm.member.element, float(L), float(xi), d)
                    i, j = np.nonzero(S)
                    rows += (m + i).tolist()
                    cols += idx[j].tolist()
                    vals += S[i, j].tolist()
                    m += d
            P = sp.csr_matrix((vals, (rows, cols)), shape=(m, asm.n))
            self.blocks.append((c, P, c.radius + c.thickness))

    def relative(self, c, P, x: np.ndarray) -> np.ndarray:
        """(points, dim) positions relative to the drum's axis, the axial part removed."""
        r = (P @ x).reshape(-1, self.dim)
        centre, axis = (c.centre, c.axis) if c.body is None else contact_body.pose(c, self.asm, x)
        rel = r - centre
        if axis is not None:
            rel = rel - np.outer(rel @ axis, axis)
        return rel

    def __call__(self, x: np.ndarray, dz: np.ndarray) -> float:
        """The largest t in (0, 1] such that no point along x + s dz, s in [0, t], comes closer to a drum's axis
        than DEPTH x rho (or DEPTH x its distance at x where it is deeper already)."""
        t = 1.0
        for c, P, rho in self.blocks:
            p0 = self.relative(c, P, x)
            d = self.relative(c, P, x + dz) - p0
            a = np.einsum("ij,ij->i", d, d)
            b = np.einsum("ij,ij->i", p0, d)
            c0 = np.einsum("ij,ij->i", p0, p0)
            dmin2 = (DEPTH * np.minimum(rho, np.sqrt(c0))) ** 2
            disc = b * b - a * (c0 - dmin2)
            hit = (b < 0) & (disc > 0) & (a > 0)
            if not np.any(hit):
                continue
            t1 = (-b[hit] - np.sqrt(disc[hit])) / a[hit]  # first time |p0 + s d| = dmin (c0 > dmin2: t1 > 0)
            t = min(t, float(np.min(t1, initial=1.0)))
        return t


def deep_starts(limit: StepLimit, x: np.ndarray) -> list[str]:
    """Per drum whose points at x lie within DEPTH x rho of its axis (a start cutting through a drum, where the
    law's normal is arbitrary): 'member (k points) in the drum at centre c, radius R'."""
    out = []
    for c, P, rho in limit.blocks:
        d = np.linalg.norm(limit.relative(c, P, x), axis=1)
        k = int(np.sum(d < DEPTH * rho))
        if k:
            out.append(f"member {c.member!r} ({k} points) in the drum at centre {np.round(c.centre, 6).tolist()}, "
                       f"radius {c.radius:g}")
    return out


def limiter(asm) -> StepLimit | None:
    """The scene's step limit, None without penalty drum contacts."""
    drums = [c for c in getattr(asm.scene, "contacts", ()) if isinstance(c, DrumContact) and c.method == "penalty"]
    return StepLimit(asm, drums) if drums else None


class IterateWatch(ca.Callback):
    """IPOPT's iteration callback for a scene with a StepLimit: IPOPT's steps cannot be cut back, so each one (from
    iterate to iterate) is checked and `crossed` records one that carried a contact point to a drum's axis; the
    statics then rejects that run's answer (it may lie on a branch past the drum)."""

    def __init__(self, limit: StepLimit, nx: int, ng: int, n_p: int):
        ca.Callback.__init__(self)
        self.limit, self.sizes = limit, {"x": nx, "lam_x": nx, "g": ng, "lam_g": ng, "f": 1, "lam_p": n_p}
        self.prev: np.ndarray | None = None
        self.crossed = False
        self.construct("contact_step_watch", {})

    def reset(self, x0: np.ndarray) -> None:
        self.prev, self.crossed = np.asarray(x0, float).copy(), False

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "ret"

    def get_sparsity_in(self, i):
        return ca.Sparsity.dense(self.sizes[ca.nlpsol_out(i)], 1)

    def eval(self, arg):
        x = np.asarray(arg[0], float).ravel()
        if self.prev is not None and not self.crossed and self.limit(self.prev, x - self.prev) < 1.0:
            self.crossed = True
        self.prev = x
        return [0]
