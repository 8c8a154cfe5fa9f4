"""Chunks of a contact scene's time loop run on the step graph of the same scene without its contacts, while no
element comes within reach of a contact surface: an untouched contact then costs what the plain scene costs (no
normal-law, damping or friction kernels, no scatter of their blocks, the banded LDL^T of the symmetric tangent
instead of the sparse QR that friction's unsymmetric tangent needs).

Why the values are those of the contact graph: every penalty law here (normal law, damping, friction) is exactly 0
where the gap is positive, so at an iterate whose elements all lie out of reach the contact graph's residual and
tangent are the contact-free ones (plus structural zeros); the two graphs differ only in the linear solver's
round-off. A chunk's step is kept only when the convex hull of every element's Bezier control points
(ancf_sym.contact_gap.gap_lower_bound) clears every surface by more than the allowance below, at the converged
state and for every Newton iterate of the step: the iterates start at the scheme's predictor x0 and converge to the
solution x*, and are taken to stay within SPREAD |x0 - x*| of x* (Newton's contraction: the first correction already
lands far closer than the predictor). The bound is Lipschitz in the control points (1 for a plane, 3 for a drum: the
chord's midpoint and the hull's radius move with them), so an element whose bound at x* exceeds LIPSCHITZ x SPREAD
x its control points' largest displacement between x0 and x* stays out of reach at every iterate.

The first step that is not kept ends the chunk: the steps before it are accepted, and the time loop goes on from
there with the contact graph. A chunk is tried on the free graph only when the start state clears every surface by
the travel the chunk's velocities and accelerations predict; after a chunk that reached a surface the next tries
wait (BACKOFF chunks, doubling), so a member resting on a surface does not pay for free chunks it cannot keep.
Fixed surfaces only (a drum carried by a body moves with the state: its contacts keep their kernels on).
"""
from __future__ import annotations

import copy

import numpy as np

from ancf_sym.contact import gap as contact_gap
from ancf_sym.model.assembly import Assembly

ENABLED = True  # (tests switch it off to compare against the contact graph on every chunk)
SPREAD = 2.0  # Newton's iterates of a step lie within this multiple of |x0 - x*| of x*
BACKOFF = (1, 2, 4, 8)  # chunks to wait before trying the free graph again, after 1, 2, 3, 4+ failed tries


class FreeChunks:
    """The contact-free integrator of a contact scene and the test that keeps its steps (see the module
    docstring)."""

    def __init__(self, S, integ, free_S, free_integ):
        self.S, self.integ, self.free_S, self.free = S, integ, free_S, free_integ
        asm = S.asm
        self.contacts = list(asm.scene.contacts)
        self.floor = [contact_gap.FLOOR * float(np.max(asm.mesh.members[c.member].elem_length))
                      for c in self.contacts]
        self.wait, self.fails = 0, 0
        self.free_before = False  # the last chunk was kept whole on the free graph
        self._b0 = None  # per contact a lower bound of the hull bound at the start state (carried from the last chunk)
        self.steps = 0  # steps kept from free chunks (for reports and tests)

    @classmethod
    def build(cls, S, integ, opts) -> "FreeChunks | None":
        """The free chunks of a fixed-step run of an alpha scheme on a scene whose contacts are all penalty laws
        on fixed surfaces; None where they do not apply (no contact, adaptive steps, a drum on a body, a Newton
        whose state differs between the two graphs)."""
        from ancf_sym.dynamics.alpha import AlphaIntegrator
        from ancf_sym.system.step_system import StepSystem

        scene = S.asm.scene
        cs = getattr(scene, "contacts", ())
        if not ENABLED or not cs or opts.adaptive or not isinstance(integ, AlphaIntegrator) or not integ.chunkable:
            return None
        if any(c.method != "penalty" or getattr(c, "body", None) is not None for c in cs):
            return None
        free_scene = copy.copy(scene)
        free_scene.contacts = []
        free_S = StepSystem.for_scene(Assembly(free_scene), linsol="auto_lu")  # (as the run's system)
        if free_S.nf != S.nf or free_S.mc != S.mc or free_S.nw != S.nw or not np.array_equal(free_S.pos, S.pos):
            return None
        free = AlphaIntegrator(free_S, integ.scheme, integ.opts, integ.tol_q, integ.tol_x, integ.counters)
        if free.state_size != integ.state_size or free.fac_sizes or integ.fac_sizes or not free.chunkable:
            return None
        return cls(S, integ, free_S, free)

    def prepare(self, n: int) -> None:
        self.free.prepare_chunks(n)

    # -- the reach test --------------------------------------------------------------------------------------
    def _control_maps(self) -> list:
        """Per contact (W, w0): the Bezier control points b_k (r0, r0 + L r_x0 / 3, r1 - L r_x1 / 3, r1) of every
        element of its member as W q + w0 in the unknowns q (W sparse, rows ordered (k, component, element): the
        products come out as contiguous (N, S) blocks)."""
        import scipy.sparse as sp

        S, asm = self.S, self.S.asm
        d = asm.scene.dim
        maps = []
        for c in self.contacts:
            mm = asm.mesh.members[c.member]
            idx, L = mm.elem_dofs(), mm.elem_length
            node = idx.shape[1] // 2
            N = len(idx)
            e = np.arange(N)
            rows, cols, vals = [], [], []
            for j in range(d):
                parts = [[(idx[:, j], np.ones(N))],
                         [(idx[:, j], np.ones(N)), (idx[:, d + j], L / 3)],
                         [(idx[:, node + j], np.ones(N)), (idx[:, node + d + j], -L / 3)],
                         [(idx[:, node + j], np.ones(N))]]
                for k, part in enumerate(parts):
                    for col, v in part:
                        rows.append((k * d + j) * N + e)
                        cols.append(col)
                        vals.append(v)
            Wf = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                               shape=(4 * d * N, asm.n))
            maps.append(((Wf @ S.E).tocsr(), Wf @ S.part.c, N))
        return maps

    def _clearance(self, Q: np.ndarray, D: np.ndarray, per_contact: bool = False) -> np.ndarray:
        """(S,) per state the smallest over contacts and elements of (hull bound at Q - Lipschitz x SPREAD x the
        largest control-point displacement of D - floor): positive where the state and every point within D of it
        lie out of reach. Q: the unknowns (S, nf); D: displacements of them (S, nf)."""
        if not hasattr(self, "_maps"):
            self._maps = self._control_maps()
        s = len(Q)
        d = self.S.asm.scene.dim
        out, each = np.full(s, np.inf), []
        QD = np.hstack([Q.T, D.T])
        for c, floor, (W, w0, N) in zip(self.contacts, self.floor, self._maps):
            both = W @ QD  # (4 d N, 2 S): control points and their displacements, rows (k, component, element)
            both[:, :s] += w0[:, None]
            B = both.reshape(4, d, N, 2 * s)
            b, db = B[..., :s], B[..., s:]
            sq = db[:, 0] * db[:, 0]
            for j in range(1, d):
                sq += db[:, j] * db[:, j]
            move = np.sqrt(sq.max(axis=0))  # (N, S)
            if contact_gap.is_drum(c):
                rel = b - c.centre[None, :, None, None]
                if c.axis is not None:
                    rel = np.einsum("ij,kjns->kins", np.eye(d) - np.outer(c.axis, c.axis), rel)
                m = 0.5 * (rel[0] + rel[3])  # (d, N, S)
                dev = rel - m
                r2 = dev[:, 0] * dev[:, 0]
                mm = m[0] * m[0]
                for j in range(1, d):
                    r2 += dev[:, j] * dev[:, j]
                    mm += m[j] * m[j]
                bound = np.sqrt(mm) - np.sqrt(r2.max(axis=0)) - (c.radius + c.thickness)
                lip = 3.0  # (|m| moves with the control points, the hull's radius by up to twice)
            else:
                h = c.normal[0] * b[:, 0]
                for j in range(1, d):
                    h += c.normal[j] * b[:, j]
                bound = h.min(axis=0) - (c.level + c.thickness)
                lip = 1.0
            bound -= (lip * SPREAD) * move
            each.append(bound.min(axis=0) - floor)
            out = np.minimum(out, each[-1])
        return np.array(each)[:, 0] if per_contact else out

    def _spans(self) -> list:
        """Per contact (unknowns holding its member's node positions r, those holding the slopes r_x, L/3 of its
        longest element): a displacement dq moves every control point by at most
        sqrt(d) (max |dq_r| + L/3 max |dq_rx|)."""
        S, asm = self.S, self.S.asm
        d = asm.scene.dim
        out = []
        for c in self.contacts:
            mm = asm.mesh.members[c.member]
            idx = mm.elem_dofs()
            node = idx.shape[1] // 2
            r = np.unique(np.r_[idx[:, :d].ravel(), idx[:, node:node + d].ravel()])
            t = np.unique(np.r_[idx[:, d:2 * d].ravel(), idx[:, node + d:node + 2 * d].ravel()])
            r, t = S.pos[r], S.pos[t]
            out.append((r[r >= 0], t[t >= 0], float(np.max(mm.elem_length)) / 3))
        return out

    def _quick_clearance(self, q0: np.ndarray, Q: np.ndarray, D: np.ndarray) -> np.ndarray:
        """(S,) a lower bound of _clearance(Q, D) from the start state q0 alone: its hull bound (or a lower bound of
        it carried over from the chunk before) less the Lipschitz constant times the control points' largest
        displacement from q0 to each state and SPREAD x that of D (a few vector maxima per state, no per-element
        work); where it is positive the states are out of reach. Keeps the lower bound at the last state."""
        if not hasattr(self, "_span"):
            self._span = self._spans()
        d = self.S.asm.scene.dim
        b0 = self._b0 if self._b0 is not None else \
            self._clearance(q0[None], np.zeros((1, len(q0))), per_contact=True)
        A = np.abs(Q - q0)
        B = A + SPREAD * np.abs(D)
        out, last = np.full(len(Q), np.inf), []
        for c, b, (ir, it, l3) in zip(self.contacts, b0, self._span):
            lip = np.sqrt(d) * (3.0 if contact_gap.is_drum(c) else 1.0)
            out = np.minimum(out, b - lip * (B[:, ir].max(axis=1) + l3 * B[:, it].max(axis=1)))
            last.append(b - lip * (A[-1, ir].max() + l3 * A[-1, it].max()))
        self._b_last = np.array(last)
        return out

    def _corrections(self, start: np.ndarray, states: np.ndarray, h: float) -> np.ndarray:
        """(k, nf) x* - x0 of each step of a chunk: the solution less the scheme's predictor
        x0 = qh + b h^2 (a - a_m ab) / (1 - a_m); with x* = qh + b h^2 ab_new (the corrector), the difference is
        b h^2 (ab_new - (a - a_m ab) / (1 - a_m)) from the state before (start for the first step)."""
        nf, sc = self.S.nf, self.integ.scheme
        bh2, am = sc.beta * h * h, sc.alpha_m
        k = len(states)
        D = states[:, 3 * nf:4 * nf] * bh2
        c_a, c_ab = bh2 / (1 - am), bh2 * am / (1 - am)
        D[0] -= c_a * start[2 * nf:3 * nf] - c_ab * start[3 * nf:4 * nf]
        if k > 1:
            D[1:] -= c_a * states[:k - 1, 2 * nf:3 * nf]
            D[1:] += c_ab * states[:k - 1, 3 * nf:4 * nf]
        return D

    def _worth_trying(self, n: int, h: float) -> bool:
        """The start state clears every surface by the travel of a chunk at its velocity and acceleration."""
        if self.wait:
            self.wait -= 1
            return False
        if self.free_before:  # the last chunk ended out of reach with its margin: its start is this one's
            return True
        st, nf = self.integ.state, self.S.nf
        T = n * h
        q = st[:nf]
        travel = T * st[nf:2 * nf] + 0.5 * T * T * st[2 * nf:3 * nf]
        return bool(self._clearance(q[None], travel[None] / SPREAD)[0] > 0)  # (the travel itself, no spread)

    # -- a chunk -----------------------------------------------------------------------------------------------
    def run_chunk(self, h: float, ploads: np.ndarray) -> tuple[np.ndarray, int, bool]:
        """(states, n_ok, free): up to n steps from the contact integrator's state, on the free graph where its
        steps are kept (free True; the contact integrator's state advanced to the last kept one), else on the
        contact graph."""
        integ, F = self.integ, self.free
        n = ploads.shape[1]
        if not self._worth_trying(n, h):
            self.free_before, self._b0 = False, None
            states, n_ok = integ.run_chunk(h, ploads)
            return states, n_ok, False
        start = integ.state.copy()
        F.state[:] = start
        F.h_prev, F.tol_q, F.tol_x, F.guard_on = integ.h_prev, integ.tol_q, integ.tol_x, integ.guard_on
        states, n_ok = F.run_chunk(h, ploads)
        kept, quick = 0, False
        if n_ok:
            nf = self.S.nf
            Q = states[:n_ok, :nf]
            D = self._corrections(start, states[:n_ok], h)
            ok = self._quick_clearance(start[:nf], Q, D) > 0
            quick = bool(ok.all())
            if not quick:  # near a surface: element by element
                ok = self._clearance(Q, D) > 0
            kept = n_ok if ok.all() else int(np.argmin(ok))
        self.free_before = kept == n
        self._b0 = self._b_last if (self.free_before and quick) else None
        if kept == n:
            self.fails = 0
        else:
            self.wait = BACKOFF[min(self.fails, len(BACKOFF) - 1)]
            self.fails += 1
        if not kept:  # the first step reached a surface: the chunk on the contact graph, from the start
            states, n_ok = integ.run_chunk(h, ploads)
            return states, n_ok, False
        integ.state[:] = states[kept - 1]
        integ.h_prev = h
        self.steps += kept
        return states[:kept], kept, True
