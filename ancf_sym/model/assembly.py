"""Assembled scene: total potential, its exact gradient and sparse Hessian from mapped compiled kernels.

One mapped kernel call per term (never a Python loop over elements); global gradient by bincount, global
Hessian by a precomputed CSC pattern. The same assembly gives CasADi expressions for IPOPT (`casadi_parts`).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym.bodies import planar as bodies, spatial as spatial_bodies
from ancf_sym import kernels
from ancf_sym.util import setup_cache
from ancf_sym.util.casadi_buffers import bind, pooled
from ancf_sym.model.constraints import Constraints, build_constraints
from ancf_sym.model.loads import load_vector, point_mass_triplets
from ancf_sym.model.mesh import Mesh, build_mesh
from ancf_sym import registry
from ancf_sym.scene.builder import Scene, structure_spec_key
from ancf_sym.util.sparsity import casadi_sparsity, csc_pattern, index_dtype
from ancf_sym.model.terms import Term, scene_terms


LOAD_LABELS = ("gravity", "loads")  # energy buckets scaled by a load factor in load stepping
LINEAR_EFFECTS = ("gravity",)  # potential linear in q: zero Hessian, never scattered


_MAPPED: dict = {}  # (element, effect, Gauss order, elements) -> the kernel mapped over them (built once)
MAPPED_CALLS: dict = {}  # (kernel names, elements) -> map_elements' function (cleared with the step graphs)
# _MAPPED's key -> the bound buffers (with their arrays X, E, G, H) of collected MappedKernels, for the next ones
# (binding a new buffer is ~20 us of a run's set-up; cleared with the step graphs)
_BOUND: dict = {}


class MappedKernel:
    """A compiled kernel mapped over a term's elements, called through CasADi's buffer interface."""

    def __init__(self, term: Term):
        self.term = term
        self.kernel = kernels.load(term.element, term.effect, term.gauss)
        self.N, self.nd = term.idx.shape
        self.linear = term.effect in LINEAR_EFFECTS
        self._key = key = (term.element, term.effect, term.gauss, self.N)
        if key not in _MAPPED:
            _MAPPED[key] = self.kernel.map(self.N)
        self.f = _MAPPED[key]
        self.P = np.ascontiguousarray(term.P)

    _BUFFERS = ("X", "E", "G", "H", "buf", "_eval")

    def __getattr__(self, name: str):
        """The call's buffers are bound on first use (a dynamic run calls only the linear terms' kernels here:
        its step graphs call the kernels themselves)."""
        if name not in MappedKernel._BUFFERS or "P" not in self.__dict__:
            raise AttributeError(name)
        # (a buffer and its arrays from a collected kernel of the same map (a second run of a structure), else new)
        be = pooled(_BOUND.setdefault(self._key, []), self.f, self)
        bound = getattr(be[0], "bound_arrays", None)
        if bound is not None:
            (self.X, _), (self.E, self.G, self.H) = bound
        else:
            self.X = np.zeros((self.N, self.nd))
            self.E = np.zeros(self.N)
            self.G = np.zeros((self.N, self.nd))
            self.H = np.zeros((self.N, self.nd, self.nd))
        self.buf, self._eval = bind(self.f, (self.X, self.P), (self.E, self.G, self.H), be)
        return self.__dict__[name]

    def __call__(self, x: np.ndarray) -> None:
        np.take(x, self.term.idx, out=self.X)
        self._eval()


@dataclass
class ForceTerm:
    """One mapped kernel call of a step graph: a scene term, or an axial and a bending term fused on the elements
    they share (internal effect elastic_<strain>, p = (L, EA, EI)). `sources` are (index of the term in the list
    given to force_terms, its rows covered here): the fused rows of both terms, or a single term's rows."""
    element: str
    effect: str
    gauss: int | None
    idx: np.ndarray  # (N, nd) global coordinate indices per element
    P: np.ndarray  # (N, n_p) kernel parameters per element
    labels: tuple  # energy buckets of the public effects it holds
    sources: list

    @property
    def N(self) -> int:
        return self.idx.shape[0]

    @property
    def nd(self) -> int:
        return self.idx.shape[1]

    @property
    def fused(self) -> bool:
        return len(self.sources) > 1

    def mapped(self) -> ca.Function:
        """(q, p) -> (energy, gradient, Hessian), mapped over the elements (q: nd x N, p: n_p x N)."""
        return map_elements(kernels.load(self.element, self.effect, self.gauss),
                            kernels.load_batch(self.element, self.effect, self.gauss), self.N)

    def mapped_grad(self) -> ca.Function:
        """(q, p) -> (energy, gradient) without the Hessian's work, mapped over the elements."""
        return map_elements(kernels.load_grad(self.element, self.effect, self.gauss),
                            kernels.load_batch(self.element, self.effect, self.gauss, "_grad"), self.N)


def clear_kernel_buffers() -> None:
    """Forget the pooled buffers of collected MappedKernels (ancf_sym.dynamics.clear_graph_cache)."""
    _BOUND.clear()


def map_elements(one: ca.Function, batch: ca.Function | None, N: int) -> ca.Function:
    """`one` mapped over N elements: its batched version (registry.BATCH_LANES elements per call, SIMD) over the
    whole batches and `one` over the rest; the plain map where no batched version exists. Kept for each (kernel,
    N): the runs of a structure map the same kernels again (ancf_sym.dynamics.clear_graph_cache forgets them)."""
    key = (one.name(), None if batch is None else batch.name(), N)
    f = MAPPED_CALLS.get(key)
    if f is None:
        f = MAPPED_CALLS[key] = _map_elements(one, batch, N)
    return f


def _map_elements(one: ca.Function, batch: ca.Function | None, N: int) -> ca.Function:
    lanes = registry.BATCH_LANES
    nb = N // lanes if batch is not None else 0
    if nb == 0:
        return one.map(N)
    if nb * lanes == N:
        return batch.map(nb)
    X, P = ca.MX.sym("q", one.size1_in(0), N), ca.MX.sym("p", one.size1_in(1), N)
    k = nb * lanes
    a = batch.map(nb).call([X[:, :k], P[:, :k]])
    b = one.map(N - k).call([X[:, k:], P[:, k:]])
    return ca.Function(f"{one.name()}_mapped", [X, P], [ca.horzcat(u, v) for u, v in zip(a, b)],
                       one.name_in(), one.name_out())


def force_terms(terms: list[Term], fuse: bool = True, row_keys: dict | None = None) -> list[ForceTerm]:
    """The terms as mapped kernel calls for gradients and Hessians, a cable's axial (green, biot) and bending
    terms fused into one elastic_<strain> call on every element where both are on at the same Gauss order (same
    coordinates and length): one B^T f_uu B per Gauss point instead of two. Energies per effect are not in
    these calls' first output (the step graphs report them from the separate <effect>_energy functions).

    row_keys: term index -> per-element values that must also agree for two rows to fuse (Rayleigh weights)."""
    return force_terms_of(force_term_calls(terms, fuse, row_keys), terms)


def force_term_calls(terms: list[Term], fuse: bool = True, row_keys: dict | None = None) -> list[tuple]:
    """force_terms' calls without their parameters, (element, effect, gauss, idx, labels, sources), kept by what
    decides them (ancf_sym.util.setup_cache: the terms' elements, coordinates and lengths, fuse, the row keys)."""
    rk = None if row_keys is None else {i: np.asarray(v, dtype=float) for i, v in row_keys.items()}
    key = setup_cache.array_key([(t.label, t.element, t.effect, t.gauss, t.idx, t.P[:, 0]) for t in terms], fuse,
                                None if rk is None else sorted(rk.items(), key=lambda kv: kv[0]))
    return setup_cache.cached("force_terms", key, lambda: _force_term_rows(terms, fuse, rk))


def force_terms_of(calls: list[tuple], terms: list[Term]) -> list[ForceTerm]:
    """The ForceTerms of force_term_calls' calls with the terms' parameters."""
    out = []
    for element, effect, gauss, idx, labels, sources in calls:  # (the calls' arrays are read-only: shared)
        if len(sources) > 1:
            (ia, ra), (ib, rb) = sources
            P = np.column_stack([terms[ia].P[ra, :2], terms[ib].P[rb, 1]])  # (L, EA, EI)
        else:
            (i, rows), = sources
            P = terms[i].P[rows]
        out.append(ForceTerm(element, effect, gauss, idx, P, labels, list(sources)))
    return out


def _force_term_rows(terms: list[Term], fuse: bool, row_keys: dict | None) -> list[tuple]:
    """force_terms' calls without their parameters: (element, effect, gauss, idx, labels, sources), from what
    decides the fusion (the terms' elements, coordinates, lengths and row keys)."""
    out: list[tuple] = []
    used: dict[int, np.ndarray] = {i: np.zeros(len(t.idx), bool) for i, t in enumerate(terms)}
    if fuse:
        for ia, ta in enumerate(terms):
            if not ta.element.startswith("cable") or not ta.effect.startswith("axial_"):
                continue
            for ib, tb in enumerate(terms):
                fe = registry.fused_effect(ta.element, (ta.effect, tb.effect)) if tb.effect == "bending" else None
                if fe is None or tb.element != ta.element or tb.gauss != ta.gauss:
                    continue

                def key(i, t, r):
                    extra = () if row_keys is None or i not in row_keys else (float(np.asarray(row_keys[i])[r]),)
                    return (t.idx[r].tobytes(), float(t.P[r, 0])) + extra

                def rowkeys(i, t, rows):
                    return None if row_keys is None or i not in row_keys else np.asarray(row_keys[i])[rows]
                ua, ub = np.flatnonzero(~used[ia]), np.flatnonzero(~used[ib])
                if len(ua) == len(ub) and np.array_equal(ta.idx[ua], tb.idx[ub]) and \
                        np.array_equal(ta.P[ua, 0], tb.P[ub, 0]) and \
                        np.array_equal(rowkeys(ia, ta, ua), rowkeys(ib, tb, ub)):
                    ra, rb = ua, ub  # the same elements in the same order (one member's terms): no row matching
                else:
                    rows_b: dict = {}
                    for r in ub:
                        rows_b.setdefault(key(ib, tb, r), r)
                    pairs = []
                    for r in ua:
                        rb = rows_b.pop(key(ia, ta, r), None)
                        if rb is not None:
                            pairs.append((r, rb))
                    if not pairs:
                        continue
                    ra, rb = (np.array(v, dtype=np.int64) for v in zip(*pairs))
                used[ia][ra], used[ib][rb] = True, True
                out.append((ta.element, fe, ta.gauss, ta.idx[ra], (ta.label, tb.label), [(ia, ra), (ib, rb)]))
    for i, t in enumerate(terms):
        rest = np.flatnonzero(~used[i])
        if len(rest):
            out.append((t.element, t.effect, t.gauss, t.idx[rest], (t.label,), [(i, rest)]))
    return out


@dataclass
class Evaluation:
    energy: float
    energies: dict  # label -> J
    gradient: np.ndarray
    hessian: sp.csc_matrix | None


class Assembly:
    def __init__(self, scene: Scene):
        self.scene = scene
        # an exact key of the scene without its element stiffnesses and gravity (None where other parts read them):
        # what the constraints are made of here, and a dynamic run's structure (ancf_sym.system.step_system)
        self.spec_key = structure_spec_key(scene)
        self.mesh: Mesh = build_mesh(scene)
        self.n = self.mesh.n
        self.x0 = self.mesh.x0
        self.terms = scene_terms(self.mesh)
        self.mapped = [MappedKernel(t) for t in self.terms]
        self.curved = [mk for mk in self.mapped if not mk.linear]  # terms whose Hessian is assembled
        self.Q = load_vector(self.mesh)  # dead point loads: potential -Q.x
        # rigid bodies' gravity and forces: linear potentials
        (spatial_bodies if scene.dim == 3 else bodies).add_loads(scene, self.mesh.bodies, self.Q)
        # (the constraint rows read no stiffness and no gravity where spec_key is given: shared, read-only, by the
        # scenes of one structure spec)
        self.constraints: Constraints = build_constraints(self.mesh) if self.spec_key is None else \
            setup_cache.cached("constraints", self.spec_key, lambda: build_constraints(self.mesh))
        pen = np.flatnonzero(self.constraints.k > 0)
        self.penalty = self.constraints.subset(pen) if len(pen) else None
        # (no penalty rows: every row is exact, the same rows as a subset of all of them would copy)
        self.exact = self.constraints.subset(np.flatnonzero(self.constraints.k == 0)) if len(pen) else \
            self.constraints

    # -- sparse pattern ------------------------------------------------------------------------------------
    _PATTERN = ("h_indptr", "h_indices", "_hpos", "_n_kernel_entries", "h_nnz", "h_key")

    def __getattr__(self, name: str):
        """The global Hessian's pattern is built on first use (a Newton solve on the free coordinates, statics.evaluation,
        never needs it)."""
        if name in Assembly._PATTERN and "mapped" in self.__dict__:
            self._pattern()
            return self.__dict__[name]
        raise AttributeError(name)

    def _pattern(self) -> None:
        rows, cols = [], []
        for mk in self.curved:
            idx = mk.term.idx  # H[e, b, a] is d2U/dx_a dx_b
            rows.append(np.broadcast_to(idx[:, None, :], mk.H.shape).ravel())
            cols.append(np.broadcast_to(idx[:, :, None], mk.H.shape).ravel())
        if self.penalty is not None:
            J = self.penalty.jacobian(self.x0 + 1.0).tocoo()  # structural pattern (bilinear terms non-zero)
            # J^T J pattern and the constant quadratic-term Hessian
            JtJ = (abs(J).T @ abs(J)).tocoo()
            Hq = abs(self.penalty.hessian(np.ones(self.penalty.m))).tocoo()
            rows += [JtJ.row, Hq.row]
            cols += [JtJ.col, Hq.col]
        r = np.concatenate(rows) if rows else np.zeros(0, int)
        c = np.concatenate(cols) if cols else np.zeros(0, int)
        self.h_indptr, self.h_indices, self._hpos = csc_pattern(r, c, self.n, self.n)
        self._n_kernel_entries = sum(mk.H.size for mk in self.curved)
        self.h_nnz = len(self.h_indices)
        nz_col = np.repeat(np.arange(self.n, dtype=np.int64), np.diff(self.h_indptr))
        self.h_key = nz_col * self.n + self.h_indices  # column-major key of each non-zero, ascending

    # -- evaluation ------------------------------------------------------------------------------------------
    def evaluate(self, x: np.ndarray, hessian: bool = True, penalty: bool = True) -> Evaluation:
        """Total potential Pi(x) = sum of element terms - Q.x + penalties; gradient; sparse Hessian (CSC).

        penalty=False leaves the penalty terms out (their stiffness is not a physical one)."""
        x = np.asarray(x, dtype=float)
        energies: dict[str, float] = {}
        g = np.zeros(self.n)
        vals = []
        for mk in self.mapped:
            mk(x)
            energies[mk.term.label] = energies.get(mk.term.label, 0.0) + float(mk.E.sum())
            g += np.bincount(mk.term.idx.ravel(), mk.G.ravel(), minlength=self.n)
            if hessian and not mk.linear:
                vals.append(mk.H.ravel())
        if np.any(self.Q):
            energies["loads"] = energies.get("loads", 0.0) - float(self.Q @ x)
            g -= self.Q
        H, pen_vals = None, None
        if self.penalty is not None and penalty:
            pc = self.penalty
            c = pc.value(x)
            energies["penalty"] = float(0.5 * np.sum(pc.k * c * c))
            J = pc.jacobian(x)
            g += J.T @ (pc.k * c)
            if hessian:
                Hp = (J.T @ sp.diags(pc.k) @ J + pc.hessian(pc.k * c)).tocsc()
                Hp.sum_duplicates()
                pen_vals = self._scatter_dense(Hp)
        if hessian:
            H = self.hessian_of(np.concatenate(vals) if vals else np.zeros(0), pen_vals)
        return Evaluation(float(sum(energies.values())), energies, g, H)

    def hessian_of(self, kernel_values: np.ndarray, penalty_values: np.ndarray | None = None) -> sp.csc_matrix:
        """The global sparse matrix of per-element Hessian values laid out as the curved terms' kernels give them
        (each term's H raveled, terms in self.curved's order), plus penalty values on the pattern's tail if given:
        the tangent (evaluate) or a weighted one (Rayleigh's elastic stiffness)."""
        data = np.bincount(self._hpos[:self._n_kernel_entries], kernel_values, minlength=self.h_nnz)
        if penalty_values is not None:
            data += penalty_values
        return sp.csc_matrix((data, self.h_indices, self.h_indptr), shape=(self.n, self.n))

    def _scatter_dense(self, Hp: sp.csc_matrix) -> np.ndarray:
        """Penalty Hessian values laid out on the tail of the pattern (J^T J and quadratic entries)."""
        coo = Hp.tocoo()
        key = coo.col.astype(np.int64) * self.n + coo.row
        pos = np.searchsorted(self.h_key, key)
        out = np.zeros(self.h_nnz)
        np.add.at(out, pos, coo.data)
        return out

    def energy(self, x: np.ndarray) -> float:
        return self.evaluate(x, hessian=False).energy

    # -- element queries ---------------------------------------------------------------------------------------
    def member_coordinates(self, x: np.ndarray, name: str) -> np.ndarray:
        mm = self.mesh.members[name]
        return np.asarray(x[mm.offset:mm.offset + mm.x0.size]).reshape(mm.n_nodes, mm.node_size)

    # -- CasADi form for IPOPT -----------------------------------------------------------------------------
    def casadi_parts(self, x: ca.MX, load_factor: ca.MX | float = 1.0):
        """(f, grad, hess_upper, g_exact) as MX of x, loads (gravity, external) scaled by load_factor: objective from the compiled energy functions (their reverse
        companions give CasADi the gradient), the exact gradient and upper-triangular Hessian assembled from the
        kernels through constant sparse matrices, and the exact constraints."""
        f = 0
        grad = 0
        hvals = []
        for mk in self.mapped:
            t = mk.term
            Xe = ca.reshape(x[t.idx.ravel().tolist()], mk.nd, mk.N)
            Pm = ca.DM(mk.P.T)
            efun = kernels.load_energy(t.element, t.effect, t.gauss).map(mk.N)
            s = load_factor if t.label in LOAD_LABELS else 1.0
            f += s * ca.sum2(efun(Xe, Pm))
            _, G, H = mk.kernel.map(mk.N)(Xe, Pm)
            G, H = s * G, s * H
            Ag = ca.DM(ca.Sparsity.triplet(self.n, mk.N * mk.nd, t.idx.ravel().tolist(), list(range(mk.N * mk.nd))), 1.0)
            grad += ca.mtimes(Ag, ca.vec(G))
            if not mk.linear:
                hvals.append(ca.vec(H))  # column-major H (nd x nd*N) == our (N, b, a) C-order layout
        if np.any(self.Q):
            Qd = ca.DM(self.Q)
            f -= load_factor * ca.dot(Qd, x)
            grad -= load_factor * Qd
        if self.penalty is not None:
            pc = self.penalty
            c = self.casadi_constraint(pc, x)
            f += 0.5 * ca.sum1(ca.DM(pc.k) * c * c)
        # Hessian: kernel entries summed into the upper triangle of the global pattern
        sel = self.h_key // self.n >= self.h_key % self.n  # col >= row
        upper_pos = -np.ones(self.h_nnz, dtype=np.int64)
        upper_pos[sel] = np.arange(sel.sum())
        indptr, indices, _ = csc_pattern(self.h_key[sel] % self.n, self.h_key[sel] // self.n, self.n, self.n)
        sp_up = casadi_sparsity(self.n, self.n, indptr, indices)
        hess = None
        if hvals:
            pos = upper_pos[self._hpos[:self._n_kernel_entries]]
            keep = np.flatnonzero(pos >= 0)
            A = ca.DM(ca.Sparsity.triplet(int(sel.sum()), self._n_kernel_entries, pos[keep].tolist(), keep.tolist()), 1.0)
            hess = ca.MX(sp_up, ca.mtimes(A, ca.vertcat(*hvals)))
        if self.penalty is not None:
            # exact penalty Hessian by CasADi AD of its small (bilinear) MX expression, upper triangle
            pen = 0.5 * ca.sum1(ca.DM(self.penalty.k) * self.casadi_constraint(self.penalty, x) ** 2)
            Hp = ca.triu(ca.hessian(pen, x)[0])
            grad += ca.gradient(pen, x)
            hess = Hp if hess is None else hess + Hp
        if hess is None:
            hess = ca.MX(sp_up, 0)
        g_exact = self.casadi_constraint(self.exact, x) if self.exact.m else ca.MX(0, 1)
        return f, grad, hess, g_exact

    @staticmethod
    def casadi_constraint(c: Constraints, x: ca.MX) -> ca.MX:
        # CasADi fills a sparsity's non-zeros in column-major order: build it from CSC, never from row-major data
        Ac = c.A.tocsc()
        Ac.sum_duplicates()
        Ac.sort_indices()
        A = ca.DM(ca.Sparsity(c.m, c.A.shape[1], Ac.indptr.tolist(), Ac.indices.tolist()), Ac.data)
        out = ca.mtimes(A, x) - ca.DM(c.d)
        if len(c.qrow):
            S = ca.DM(ca.Sparsity.triplet(c.m, len(c.qrow), c.qrow.tolist(), list(range(len(c.qrow)))), c.qcoef)
            out += ca.mtimes(S, x[c.qi.tolist()] * x[c.qj.tolist()])
        return out

    def constant_force(self, gradients: list | None = None) -> np.ndarray:
        """Generalized force that does not depend on q (full coordinates): dead point loads minus the gradients of
        the linear energy terms (gravity, distributed dead loads), evaluated once at the start state. gradients: a
        list that receives each linear term's gradient (full coordinates), in the order of self.mapped."""
        f = self.Q.copy()
        for mk in self.mapped:
            if mk.linear:
                mk(self.x0)
                g = np.bincount(mk.term.idx.ravel(), mk.G.ravel(), minlength=self.n)
                f -= g
                if gradients is not None:
                    gradients.append(g)
        return f

    def mass_matrix(self) -> sp.csc_matrix:
        """Constant global mass matrix (sparse, CSC). Kept by its exact inputs (each member's element coordinates,
        lengths and mass parameters, the bodies' entries; ancf_sym.util.setup_cache): a scene that differs only in
        other values shares it, read-only."""
        members = list(self.mesh.members.values())
        # (the key: what elem_dofs and the mass parameters are made of, without making them)
        mass = [(mm.member.element, mm.offset, mm.node_size, mm.elem_nodes, np.asarray(mm.elem_length, dtype=float),
                 _mass_params(mm.member)) for mm in members]
        if self.scene.dim == 3:  # diag(m, m, m) + C (x) I_3 per spatial body
            bi, bj, bv = spatial_bodies.mass_triplets(self.scene, self.mesh.bodies)
        else:  # diag(m, m, J, J) per planar body
            bi, bv = bodies.mass_entries(self.scene, self.mesh.bodies)
            bj = bi
        pi, pj, pv = point_mass_triplets(self.mesh)  # (empty without point masses)
        body = tuple(np.concatenate([np.asarray(a, dtype=b.dtype), b]) for a, b in zip((bi, bj, bv), (pi, pj, pv)))
        key = setup_cache.array_key(self.n, mass, body)
        return setup_cache.cached("mass_matrix", key, lambda: _mass_matrix(self.n, members, body))


def _mass_params(m) -> tuple:
    """A member's mass kernel parameters after the element length: rho A (cables), b, h, rho (beam3d)."""
    return (m.material.density * m.section.area,) if m.element != "beam3d" else \
        (m.section.b, m.section.h, m.material.density)


def _mass_matrix(n: int, members: list, body: tuple) -> sp.csc_matrix:
    """The global mass matrix of the members' elements and the bodies' triplets."""
    rows, cols, vals = [], [], []
    for mm in members:
        element, idx = mm.member.element, mm.elem_dofs()
        L = np.asarray(mm.elem_length, dtype=float)
        P = np.stack([L] + [np.full_like(L, v) for v in _mass_params(mm.member)], axis=1)
        # equal elements (the same parameters) computed once; entry (i, j) of element e at (idx[e,i], idx[e,j])
        if np.all(P == P[:1]):  # (a uniform mesh: one element mass matrix, without sorting the rows)
            uniq, inv = P[:1], np.zeros(len(P), dtype=np.int64)
        else:
            uniq, inv = np.unique(P, axis=0, return_inverse=True)
        Me = np.stack([kernels.mass_matrix(element, list(map(float, p))) for p in uniq])[np.ravel(inv)]
        nd = idx.shape[1]
        rows.append(np.repeat(idx, nd, axis=1).ravel())
        cols.append(np.tile(idx, (1, nd)).ravel())
        vals.append(Me.reshape(len(idx), -1).ravel())
    bi, bj, bv = body
    rows.append(bi)
    cols.append(bj)
    vals.append(bv)
    it = index_dtype(n)
    return sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows).astype(it), np.concatenate(cols).astype(it))),
                         shape=(n, n)).tocsc()
