"""A scene's potential, residual and tangent on its free coordinates, from the compiled kernels: nothing to build.

One mapped kernel call per (fused) term, never a Python loop over elements: a cable's axial and bending terms fused
into one elastic kernel where it exists (assembly.force_terms), the linear terms (gravity) left out (their force is
constant: ReducedModel.f_lin). The element gradients and Hessians are scattered straight onto the free coordinates by
precomputed index maps (one bincount each): the residual, and the tangent in LAPACK's banded upper storage (a mesh
numbered node by node is a band of width 2 x node size). Penalty springs are added from the Assembly's constraint
rows. Measured (bench/STATICS_RESULTS.md): ~55 us per evaluation at 60 elements (the Assembly's general evaluation
and sparse reduction ~0.3 ms, the compiled StepSystem graph ~50 us after ~35 ms of building it).

Element-local positions: an elastic energy does not change under a translation, so on fine meshes each element's
positions are handed to its kernel relative to its first node. In absolute coordinates the kernel forms differences
of positions ~span apart from each other to resolve lengths ~l (r_xx ~ (r1 - r0)/l^2): the residual then carries
round-off ~eps span / l larger than needed. Measured on a 3 m cantilever at 100 000 elements (span / l ~ 1e5):
Newton's updates from a converged coarse start sat at round-off 1e-10 - 4e-9 L (Green strain, the tip wandering
1.8e-9 m), with local positions at ~1e-12 L (tip within 3.5e-12 m).
"""
from __future__ import annotations

import copy
import dataclasses

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym import kernels, registry
from ancf_sym.model.assembly import LINEAR_EFFECTS, Assembly, ForceTerm, force_terms, map_elements
from ancf_sym.util.casadi_buffers import bind
from ancf_sym.statics.inertia import BAND_LIMIT
from ancf_sym.scene.member_effects import START_EFFECTS

LOCAL_ABOVE = 100.0  # coordinate span / shortest element above which positions go to the kernels element-local
def _mapped(ft, n: int) -> ca.Function:
    """ft's kernel mapped over n >= ft.N elements (the batched version over whole batches where one exists; kept
    by map_elements)."""
    return map_elements(kernels.load(ft.element, ft.effect, ft.gauss),
                        kernels.load_batch(ft.element, ft.effect, ft.gauss), n)


def _whole_batches(N: int, batched: bool) -> int:
    """Element count a kernel is called on: N rounded up to whole SIMD batches where a batched version exists.
    The padding elements repeat the first one and their outputs are dropped. A batch of registry.BATCH_LANES costs
    about one scalar call, and a remainder needs a CasADi wrapper around two maps (measured on 6 decoupled elements:
    batched 6 = 4 + 2 slower than batched 8)."""
    lanes = registry.BATCH_LANES
    return N if not batched or N % lanes == 0 else N + lanes - N % lanes


def _padded(ft) -> int:
    """_whole_batches of a term's kernel call."""
    return _whole_batches(ft.N, registry.has_batch(ft.element, ft.effect, ft.gauss))


def _padding_rows(N: int, n: int) -> np.ndarray:
    """Rows of N elements padded to n: each element once, then the first one again."""
    return np.r_[np.arange(N), np.zeros(n - N, np.int64)]


# a cable's Green or decoupled axial effect -> the Biot one on the same elements and parameters (L, EA[, EI])
BIOT = START_EFFECTS  # (ancf_sym.scene.member_effects)


def fused_terms(terms: list) -> list[ForceTerm]:
    """assembly.force_terms without its row-by-row matching where a cable's axial and bending terms cover the same
    elements in the same order (as a scene's members build them): fused whole, in one step."""
    out, used = [], set()
    for ia, ta in enumerate(terms):
        if not ta.element.startswith("cable") or not ta.effect.startswith("axial_"):
            continue
        for ib, tb in enumerate(terms):
            fe = registry.fused_effect(ta.element, (ta.effect, tb.effect)) if tb.effect == "bending" else None
            if fe is None or tb.element != ta.element or tb.gauss != ta.gauss or ib in used:
                continue
            if not (np.array_equal(ta.idx, tb.idx) and np.array_equal(ta.P[:, 0], tb.P[:, 0])):
                return force_terms(terms)
            rows = np.arange(len(ta.idx))
            out.append(ForceTerm(ta.element, fe, ta.gauss, ta.idx, np.c_[ta.P[:, :2], tb.P[:, 1]],
                                 (ta.label, tb.label), [(ia, rows), (ib, rows)]))
            used |= {ia, ib}
            break
    out += [ForceTerm(t.element, t.effect, t.gauss, t.idx, t.P, (t.label,), [(i, np.arange(len(t.idx)))])
            for i, t in enumerate(terms) if i not in used and len(t.idx)]
    return out


class ReducedEvaluation:
    """Potential, residual and tangent of the nonlinear terms on the free coordinates of a ReducedModel.

    After `evaluate(x_full)`: `energy` (nonlinear terms and penalties [J]), `g` (their gradient on the free
    coordinates), `band()` (upper banded tangent, None if the band is wider than BAND_LIMIT) and `matrix()` (the
    sparse tangent, for what a band cannot do: factorisations in another order, LU, the inertia).

    Its layout, which the C Newton loop (newton_loop) reads as well: `calls` (per fused term: input indices, inputs,
    parameters, ...), `padded` (elements per call, whole SIMD batches), `real` (the outputs' rows that are elements,
    None without padding), `gpos` (gradient entry -> free coordinate, nf: none) and `hband` (Hessian entry -> slot of
    LAPACK's upper band, None for a wide band)."""

    def __init__(self, asm: Assembly, reduction):
        self.asm, self.R = asm, reduction
        nf = self.nf = reduction.nf
        pos = reduction.part.pos
        self.fts = fts = fused_terms([t for t in asm.terms if t.effect not in LINEAR_EFFECTS])
        lengths = [mm.elem_length.min() for mm in asm.mesh.members.values()]
        self.local = bool(lengths) and reduction.span > LOCAL_ABOVE * min(lengths)
        self.padded = [_padded(ft) for ft in fts]  # kept by variants: the index maps below are laid out for it
        self.bind_buffers()
        gp, rows, cols = [], [], []
        for ft, N in zip(fts, self.padded):
            nd = ft.nd
            p = np.r_[pos[ft.idx], np.full((N - ft.N, nd), -1)]  # padding rows: on no free coordinate
            gp.append(p.ravel())
            rows.append(np.broadcast_to(p[:, None, :], (N, nd, nd)).ravel())  # H[e, b, a] = d2U/dx_a dx_b
            cols.append(np.broadcast_to(p[:, :, None], (N, nd, nd)).ravel())
        gp = np.concatenate(gp) if gp else np.zeros(0, np.int64)
        self.gpos = np.where(gp >= 0, gp, nf)
        hr = np.concatenate(rows) if rows else np.zeros(0, np.int64)
        hc = np.concatenate(cols) if cols else np.zeros(0, np.int64)
        self._free = np.flatnonzero((hr >= 0) & (hc >= 0))  # kernel Hessian entries on two free coordinates
        self._hr, self._hc = hr[self._free], hc[self._free]
        up = self._hr <= self._hc
        self.bw = int(np.max(self._hc[up] - self._hr[up], initial=0))
        self.pen = asm.penalty
        if self.pen is not None:  # structural pattern of the penalty Hessian (J^T K J and the bilinear terms)
            J = abs(self.pen.jacobian(asm.x0 + 1.0))
            P = (J.T @ J + abs(self.pen.hessian(np.ones(self.pen.m)))).tocoo()
            pr, pc = pos[P.row], pos[P.col]
            keep = (pr >= 0) & (pc >= 0)
            self.bw = max(self.bw, int(np.max(np.abs(pc - pr)[keep], initial=0)))
        self._dump = (self.bw + 1) * nf  # band slot of the entries left out (fixed coordinates, lower triangle)
        self.hband = None
        if self.bw <= BAND_LIMIT:  # kernel entry -> LAPACK's upper banded storage ab[bw + i - j, j]
            flat = np.full(len(hr), self._dump)
            flat[self._free[up]] = (self.bw + self._hr[up] - self._hc[up]) * nf + self._hc[up]
            self.hband = flat
        self.energy, self.g = 0.0, np.zeros(nf)
        self.pen_hessian = None  # penalty Hessian entries at the last evaluation: (rows, cols, values) on free coordinates
        self.at = None  # the array of the last evaluation (the object, not a copy: identity says none came since)

    def bind_buffers(self) -> None:
        """Output buffers (every call's gradients and Hessians side by side) and the mapped kernel calls."""
        fts = self.fts
        self.E = np.zeros(sum(self.padded))
        self.G = np.zeros(sum(N * ft.nd for ft, N in zip(fts, self.padded)))
        self.H = np.zeros(sum(N * ft.nd * ft.nd for ft, N in zip(fts, self.padded)))
        real = [np.arange(ft.N) + sum(self.padded[:i]) for i, ft in enumerate(fts)]
        self.real = np.concatenate(real) if sum(self.padded) > sum(ft.N for ft in fts) else None  # energies to sum
        self.calls = []
        e0 = g0 = h0 = 0
        for ft, N in zip(fts, self.padded):
            nd, rows = ft.nd, _padding_rows(ft.N, N)  # padding repeats the first element (finite outputs)
            X, P = np.zeros((N, nd)), np.ascontiguousarray(ft.P[rows], dtype=float)
            buf, ev = bind(_mapped(ft, N), (X, P),
                           (self.E[e0:e0 + N], self.G[g0:g0 + N * nd], self.H[h0:h0 + N * nd * nd]))
            e0, g0, h0 = e0 + N, g0 + N * nd, h0 + N * nd * nd
            idx = np.ascontiguousarray(ft.idx[rows])
            self.calls.append((idx, X, P, buf, ev, self._local_columns(ft)))

    def _local_columns(self, ft: ForceTerm) -> tuple[np.ndarray, np.ndarray] | None:
        """(columns of both nodes' positions, the first node's position columns under them) for an elastic
        (translation-invariant) kernel when local positions are on, else None."""
        if not self.local or not registry.EFFECTS[(ft.element, ft.effect)].elastic:
            return None
        dim, half = self.asm.scene.dim, ft.nd // 2  # q = [node 0 | node 1], each node's position first
        first = np.arange(dim)
        return np.r_[half + first, first], np.r_[first, first]

    def variant(self, effects: dict) -> "ReducedEvaluation | None":
        """The same evaluation with cable effects swapped (e.g. BIOT), sharing every index map; None if none of
        this scene's calls has such an effect."""
        fts = [dataclasses.replace(ft, effect=effects[ft.effect])
               if ft.element.startswith("cable") and ft.effect in effects else ft for ft in self.fts]
        if all(a is b for a, b in zip(fts, self.fts)):
            return None
        out = copy.copy(self)
        out.fts = fts
        out.at = None
        out.bind_buffers()
        return out

    def evaluate(self, x_full: np.ndarray) -> None:
        """Kernels (and penalties) at x_full: energy, g; the tangent's values kept for band() / matrix()."""
        self.at = x_full
        for idx, X, _, _, ev, local in self.calls:
            np.take(x_full, idx, out=X)
            if local is not None:  # both copies are taken before the assignment: the first node's column too
                X[:, local[0]] -= X[:, local[1]]
            ev()
        self.energy = float(self.E.sum() if self.real is None else self.E[self.real].sum())
        self.g = np.bincount(self.gpos, self.G, minlength=self.nf + 1)[:self.nf]
        self.pen_hessian = None
        if self.pen is not None:
            pc = self.pen
            c = pc.value(x_full)
            self.energy += float(0.5 * np.sum(pc.k * c * c))
            J = pc.jacobian(x_full)
            self.g += self.R.reduce_force(J.T @ (pc.k * c))
            Hp = (J.T @ sp.diags(pc.k) @ J + pc.hessian(pc.k * c)).tocoo()
            pos = self.R.part.pos
            r, col = pos[Hp.row], pos[Hp.col]
            keep = (r >= 0) & (col >= 0)
            self.pen_hessian = (r[keep], col[keep], Hp.data[keep])

    def band(self) -> np.ndarray | None:
        """The reduced tangent in LAPACK's upper banded storage ((bw + 1) x nf), None for a wide band."""
        if self.hband is None:
            return None
        size = self._dump
        ab = np.bincount(self.hband, self.H, minlength=size + 1)[:size]
        if self.pen_hessian is not None:
            r, c, v = self.pen_hessian
            up = r <= c
            ab += np.bincount((self.bw + r[up] - c[up]) * self.nf + c[up], v[up], minlength=size)
        return ab.reshape(self.bw + 1, self.nf)

    def matrix(self) -> sp.csc_matrix:
        """The reduced tangent as a sparse matrix (duplicates summed)."""
        r, c, v = self._hr, self._hc, self.H[self._free]
        if self.pen_hessian is not None:
            r, c, v = np.r_[r, self.pen_hessian[0]], np.r_[c, self.pen_hessian[1]], np.r_[v, self.pen_hessian[2]]
        K = sp.csc_matrix((v, (r, c)), shape=(self.nf, self.nf))
        K.sum_duplicates()
        return K


class ResultEnergies:
    """A static result's energies by label (the Assembly's buckets: axial, bending, gravity, loads, penalty, ...)
    and its full gradient, without the Assembly's general evaluation: each nonlinear term's energy-only kernel
    companion (SIMD-batched where one exists), the linear terms' energies from their constant gradients (a
    linear potential is g . x), and the gradient from a ReducedEvaluation already evaluated at the point (the one
    the stability check factorises). Measured on paper 000's cantilever (6 - 18 elements): ~50 - 60 us of the
    Assembly's evaluation (every term's scalar kernel with its gradient and Hessian) become ~10 us."""

    def __init__(self, asm: Assembly):
        self.asm = asm
        grads: list = []
        asm.constant_force(grads)
        linear = [mk.term.label for mk in asm.mapped if mk.linear]
        self.linear = list(zip(linear, grads))  # (label, constant gradient of its potential)
        self.calls = []
        for t in asm.terms:
            if t.effect in LINEAR_EFFECTS or not len(t.idx):
                continue
            batch = kernels.load_batch(t.element, t.effect, t.gauss, "_energy")
            N = len(t.idx)  # whole batches, as ReducedEvaluation's calls
            n = _whole_batches(N, batch is not None)
            rows = _padding_rows(N, n)
            f = map_elements(kernels.load_energy(t.element, t.effect, t.gauss), batch, n)
            X, E = np.zeros((n, t.idx.shape[1])), np.zeros(n)
            P = np.ascontiguousarray(t.P[rows], dtype=float)
            buf, ev = bind(f, (X, P), (E,))
            self.calls.append((t.label, np.ascontiguousarray(t.idx[rows]), X, E[:N], buf, ev))
        self._loads = bool(np.any(asm.Q))  # dead point loads
        self._gidx = None  # full coordinate of each kernel gradient entry of a ReducedEvaluation (set on first use)

    def energies(self, x: np.ndarray) -> dict:
        """label -> energy [J] at x (the Assembly's evaluate(x).energies, from the same kernels)."""
        out: dict[str, float] = {}
        for label, idx, X, E, _, ev in self.calls:
            np.take(x, idx, out=X)
            ev()
            out[label] = out.get(label, 0.0) + float(E.sum())
        for label, g in self.linear:
            out[label] = out.get(label, 0.0) + float(g @ x)
        a = self.asm
        if self._loads:
            out["loads"] = out.get("loads", 0.0) - float(a.Q @ x)
        if a.penalty is not None:
            c = a.penalty.value(x)
            out["penalty"] = float(0.5 * np.sum(a.penalty.k * c * c))
        return out

    def gradient(self, ev: ReducedEvaluation, x: np.ndarray) -> np.ndarray:
        """Full gradient of the total potential at x from `ev` evaluated there (kernels, penalties) and the constant
        force of the linear terms and dead loads."""
        assert ev.at is x, "evaluate the ReducedEvaluation at x first"
        a = self.asm
        if self._gidx is None:  # padding elements (copies of a batch's first) onto a dump slot past the end
            self._gidx = np.concatenate([np.r_[ft.idx.ravel(), np.full((N - ft.N) * ft.nd, a.n)]
                                         for ft, N in zip(ev.fts, ev.padded)]) if ev.fts else np.zeros(0, np.int64)
        g = np.bincount(self._gidx, ev.G, minlength=a.n + 1)[:a.n] - ev.R.f_lin_full
        if a.penalty is not None:
            pc = a.penalty
            g += pc.jacobian(x).T @ (pc.k * pc.value(x))
        return g
