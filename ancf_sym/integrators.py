"""Implicit time-step formulas and the Newton solver on the sparse KKT system of a scene.

Equations of motion with exact constraints (index 3):

    M a + C v + grad U(q) + J(q)^T lam = Q(t),    Phi(q) = 0

U is the scene's total potential (strain energies, gravity, dead loads, penalty joints); C is Rayleigh damping
and/or the strain-rate damping force f_d(q, v). Supports that fix single coordinates (pins, clamps of
axis-aligned members) are eliminated; rows x_i - x_j = d (hinges) identify coordinates; the remaining exact rows
(rigid joints, skew clamps) carry Lagrange multipliers.

One full Newton iteration is one call of a CasADi Function: every energy term through its mapped compiled kernel,
residual and KKT matrix assembled by constant index maps (gathers), sparse LDL^T (symmetric positive definite
case) or QR (multipliers, strain-rate damping) factorisation and solve, all inside CasADi: no Python loop over
elements, no numpy scatter. Residuals alone use the kernels' (energy, gradient) companions (no Hessian work). The
alpha schemes put a whole step (predictor, iterations, corrector) into one graph and map it over many steps (see
AlphaIntegrator). Modified Newton is selectable (newton.modified): in the alpha schemes' step graph with the LDL^T
factor carried in the state, else in Python with a SuperLU factorisation. Full Newton is the default: on the
cable scenes measured (bench/DYNAMICS_RESULTS.md) it converges in one iteration on 96-98 % of the steps, while a
modified step needs a second residual to measure its contraction, and a residual costs ~0.4 of a full iteration.

Newmark, HHT-alpha and generalized-alpha are one family here, in the form of Arnold & Bruels (2007) that Exudyn
also uses: the equations hold at t_{n+1} exactly and an algorithmic acceleration abar carries the alpha
weighting,

    (1 - alpha_m) abar_{n+1} + alpha_m abar_n = (1 - alpha_f) a_{n+1} + alpha_f a_n
    q_{n+1} = q_n + h v_n + h^2 (1/2 - beta) abar_n + h^2 beta abar_{n+1}
    v_{n+1} = v_n + h (1 - gamma) abar_n + h gamma abar_{n+1}.

Newmark is alpha_m = alpha_f = 0; HHT(alpha) is alpha_m = 0, alpha_f = -alpha, beta = (1 - alpha)^2 / 4,
gamma = 1/2 - alpha (for linear systems identical to the classical HHT of paper 002; for nonlinear ones the forces
are evaluated at t_{n+1} instead of averaged); generalized-alpha(rho_inf) is alpha_m = (2 rho - 1)/(rho + 1),
alpha_f = rho/(rho + 1), gamma = 1/2 + alpha_f - alpha_m, beta = (gamma + 1/2)^2 / 4.
"""
from __future__ import annotations

import hashlib
import math
import weakref
from dataclasses import dataclass

import casadi as ca
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from . import contact, drives, kernels
from .assembly import Assembly, force_terms, map_elements
from .checks import fail
from .scene import SceneError
from .sparsity import casadi_sparsity, csc_pattern

ELASTIC_LABELS = ("axial", "bending", "torsion", "continuum")
LINEAR_EFFECTS = ("gravity",)  # energy linear in q: constant force, no Hessian


# -- schemes ---------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Scheme:
    """Coefficients of the generalized-alpha family (Arnold-Bruels form)."""
    name: str
    alpha_m: float
    alpha_f: float
    beta: float
    gamma: float

    @classmethod
    def newmark(cls, beta: float = 0.25, gamma: float = 0.5) -> "Scheme":
        if not (0 < beta <= 0.5 and 0 < gamma <= 1):
            raise fail("analysis.beta", "and gamma must lie in (0, 1/2] x (0, 1]", (beta, gamma))
        return cls("newmark", 0.0, 0.0, float(beta), float(gamma))

    @classmethod
    def hht(cls, alpha: float = -0.05) -> "Scheme":
        a = float(alpha)
        if not (math.isfinite(a) and -1.0 / 3.0 - 1e-12 <= a <= 0.0):
            raise fail("analysis.alpha", "must lie in [-1/3, 0] (HHT)", alpha)
        return cls("hht", 0.0, -a, (1 - a) ** 2 / 4, 0.5 - a)

    @classmethod
    def generalized_alpha(cls, rho_inf: float = 0.9) -> "Scheme":
        r = float(rho_inf)
        if not (math.isfinite(r) and 0.0 <= r <= 1.0):
            raise fail("analysis.rho_inf", "must lie in [0, 1]", rho_inf)
        am, af = (2 * r - 1) / (r + 1), r / (r + 1)
        g = 0.5 + af - am
        return cls("generalized_alpha", am, af, 0.25 * (g + 0.5) ** 2, g)

    def cm(self, h: float) -> float:
        """d(M a_{n+1}) / d q_{n+1} = cm M."""
        return (1 - self.alpha_m) / ((1 - self.alpha_f) * self.beta * h * h)

    def cc(self, h: float) -> float:
        """d v_{n+1} / d q_{n+1} = cc I."""
        return self.gamma / (self.beta * h)

    def error_constant(self) -> float:
        """Local displacement error ~ |beta - 1/6| h^2 |a_{n+1} - a_n| (Zienkiewicz & Xie)."""
        return abs(self.beta - 1.0 / 6.0)


# -- the compiled step system ------------------------------------------------------------------------------------

def _dm(A: sp.spmatrix) -> ca.DM:
    A = sp.csc_matrix(A)
    A.sort_indices()
    return ca.DM(ca.Sparsity(A.shape[0], A.shape[1], A.indptr.tolist(), A.indices.tolist()), A.data.tolist())


def _gather_sum(vals: list, target: np.ndarray, n_out: int) -> ca.MX:
    """out[t] = sum of the entries k of vertcat(vals) with target[k] = t (target -1: dropped), as a few gathers
    (one per multiplicity) and additions: cheaper in the MX virtual machine than a product with a 0/1 matrix."""
    src = ca.vertcat(*vals, ca.MX.zeros(1))
    n_src = src.shape[0] - 1
    valid = np.flatnonzero(target >= 0)
    t = target[valid]
    order = valid[np.argsort(t, kind="stable")]
    cnt = np.bincount(t, minlength=n_out)
    if not len(order):
        return ca.MX.zeros(n_out)
    start = np.r_[0, np.cumsum(cnt)[:-1]]
    out = None
    for j in range(int(cnt.max())):
        idx = np.where(cnt > j, order[np.minimum(start + j, len(order) - 1)], n_src)
        term = src[idx.tolist()]
        out = term if out is None else out + term
    return out


def _sx_nz(A: ca.SX) -> ca.SX:
    """Nonzeros of a sparse SX as a column."""
    return ca.vertcat(*A.nonzeros()) if A.nnz() else ca.SX(0, 1)


def _mx_sparse_nz(A: ca.MX) -> ca.MX:
    """Nonzeros of a sparse MX as a column (no copy of the structure)."""
    return ca.sparsity_cast(A, ca.Sparsity.dense(A.nnz(), 1))


@dataclass
class Partition:
    """Unknowns of the dynamics: x_full = E y + c.

    Exact rows 'x_i = d' fix coordinates (eliminated); rows 'x_i - x_j = d' (hinges, coincident joints)
    identify coordinates (one unknown for the group); the remaining exact rows keep Lagrange multipliers."""
    E: sp.csc_matrix  # (n, ny) 0/1 map from unknowns to coordinates
    c: np.ndarray  # (n,) fixed values and identification offsets
    roots: np.ndarray  # (ny,) the coordinate that represents each unknown
    pos: np.ndarray  # (n,) unknown of each coordinate, -1 if fixed
    rows: np.ndarray  # exact rows kept with multipliers (indices into asm.exact)
    fixed: np.ndarray  # fixed coordinates
    n_identified: int  # coordinates merged into another one

    @property
    def ny(self) -> int:
        return len(self.roots)


def partition(asm: Assembly) -> Partition:
    ex = asm.exact
    n = asm.n
    A = ex.A.tocsr()
    nnz_row = np.diff(A.indptr)
    has_quad = np.zeros(ex.m, bool)
    has_quad[ex.qrow] = True
    parent = np.arange(n)
    off = np.zeros(n)  # x_k = x_parent + off_k

    def find(k):
        path = []
        while parent[k] != k:
            path.append(k)
            k = parent[k]
        root, acc = k, 0.0
        for node in reversed(path):  # compress, accumulating offsets from the root down
            acc += off[node]
            off[node] = acc
            parent[node] = root
        return root

    def value(k):
        r = find(k)
        return r, (off[k] if k != r else 0.0)

    keep_rows = []
    tol = lambda v: 1e-12 * (1.0 + abs(v))
    # identifications x_i - x_j = d first, then fixes
    ident = [r for r in range(ex.m) if nnz_row[r] == 2 and not has_quad[r]
             and abs(A.data[A.indptr[r]] + A.data[A.indptr[r] + 1]) <= 1e-14 * abs(A.data[A.indptr[r]])]
    for r in ident:
        (i, j), (ai, _) = A.indices[A.indptr[r]:A.indptr[r + 1]], A.data[A.indptr[r]:A.indptr[r + 1]]
        d = ex.d[r] / ai  # x_i - x_j = d
        ri, oi = value(int(i))
        rj, oj = value(int(j))
        if ri == rj:
            if abs(oi - oj - d) > tol(d):
                keep_rows.append(r)  # inconsistent cycle: leave it to a multiplier (the scene is then infeasible)
            continue
        parent[rj] = ri
        off[rj] = oi - d - oj
    fixed_val: dict[int, float] = {}
    for r in range(ex.m):
        if nnz_row[r] == 1 and not has_quad[r]:
            c = int(A.indices[A.indptr[r]])
            v = float(ex.d[r] / A.data[A.indptr[r]])
            root, o = value(c)
            rv = v - o
            if root in fixed_val and abs(fixed_val[root] - rv) > tol(rv):
                raise SceneError(f"constraint {ex.labels[r]!r} fixes coordinate {c} to {v!r}, which other supports "
                                 f"or joints fix to {fixed_val[root] + o!r}")
            fixed_val[root] = rv
        elif r not in ident:
            keep_rows.append(r)
    roots_all = np.array([find(k) for k in range(n)])
    offs = np.array([off[k] if roots_all[k] != k else 0.0 for k in range(n)])
    is_fixed = np.array([roots_all[k] in fixed_val for k in range(n)])
    c = offs.copy()
    for k in np.flatnonzero(is_fixed):
        c[k] += fixed_val[roots_all[k]]
    free_roots = np.unique(roots_all[~is_fixed])
    ymap = -np.ones(n, dtype=np.int64)
    ymap[free_roots] = np.arange(len(free_roots))
    pos = np.where(is_fixed, -1, ymap[roots_all])
    rows_e = np.flatnonzero(pos >= 0)
    E = sp.csc_matrix((np.ones(len(rows_e)), (rows_e, pos[rows_e])), shape=(n, len(free_roots)))
    keep = np.array(sorted(set(keep_rows)), dtype=np.int64)
    # rows whose coordinates are all fixed are redundant once the coordinates are eliminated
    if len(keep):
        touch = []
        for r in keep:
            cols = A.indices[A.indptr[r]:A.indptr[r + 1]]
            qc = np.r_[ex.qi[ex.qrow == r], ex.qj[ex.qrow == r]]
            touch.append(bool(np.any(pos[np.r_[cols, qc].astype(np.int64)] >= 0)))
        keep = keep[np.array(touch, bool)]
    return Partition(E, c, free_roots, pos, keep, np.flatnonzero(is_fixed), int(np.sum(~is_fixed) - len(free_roots)))


# compiled graphs by structure key (StepSystem._structure_key): a process builds a scene structure's graphs once
_GRAPHS: dict = {}


def clear_graph_cache() -> None:
    """Forget the compiled step graphs of this process (the next run of every structure builds them again)."""
    _GRAPHS.clear()
    AlphaIntegrator._GRAPHS.clear()


@dataclass
class StrainRateData:
    """Kelvin-Voigt damping of cables at Gauss points of the damped members: r_x = Bx x, r_xx = Bxx x (rows
    component-major: d * P + point), weights w L, coefficients, and which points use the Green strain rate."""
    dim: int
    Bx: sp.csr_matrix
    Bxx: sp.csr_matrix
    wL: np.ndarray
    c_axial: np.ndarray
    c_bending: np.ndarray
    green: np.ndarray


@dataclass
class RayleighData:
    alpha: float  # mass-proportional [1/s]
    beta: float  # stiffness-proportional [s], on the current elastic tangent
    element_weight: dict  # term index -> per-element factor (members the damping applies to)


class StepSystem:
    """A scene's equations of motion on its free coordinates, as compiled CasADi Functions.

    forces(x) -> (g, K[, kel]): gradient and Hessian of the potential (nonlinear terms and penalty joints; the
    constant forces of linear terms such as gravity are in f_lin), and the elastic tangent values for Rayleigh
    stiffness damping. Every term is one mapped compiled kernel call; assembly by constant sparse matrices.

    For a step with unknown x = q_{n+1} (and scaled multipliers lam, lam_true = kc lam):
        r = [cm M x + cc C x + g(x) + kc J^T lam + p ; kc Phi(x)]
        KKT = [[cm M + cc C + K(x) + H_Phi(kc lam), kc J^T], [kc J, 0]]
    p collects what is constant within a step. C = alpha M + beta K_el(q_n) with K_el(q_n) passed as `kel`.
    `iterate` does a whole full-Newton iteration (residual, KKT, sparse LDL^T factorisation, solve) in one call;
    `residual` (gradient-only kernels) and `jacobian` serve modified Newton with a factorisation kept in Python;
    `ensure_factor` builds the in-graph LDL^T factorisation (fact_f, ldl_solve_mx) of the compiled modified step.
    """

    def __init__(self, asm: Assembly, rayleigh: RayleighData | None = None, linsol: str = "auto",
                 strain_rate: StrainRateData | None = None, fuse: bool = True):
        self.asm = asm
        self.fuse = fuse  # axial + bending of a cable in one kernel call (False: one call per term, for tests)
        self.strain_rate = strain_rate
        self.part = part = partition(asm)
        n = asm.n
        nf = part.ny
        self.nf = nf
        self.pos = part.pos
        self._gather = np.where(part.pos >= 0, part.pos, nf)  # full coordinate k = ext[_gather[k]], ext[nf] = 0
        self.E = part.E
        self.cons = asm.exact.subset(part.rows) if len(part.rows) else None
        self.mc = self.cons.m if self.cons is not None else 0
        # drives and torques: rows and forces whose time functions w(t) are per-step inputs, appended to the step's
        # constant vector p (and to the integrators' pload): p = [p (nf); w (nw)]
        self.drives = drives.build(asm)
        self.nw = self.drives.nw if self.drives is not None else 0
        if self.drives is not None:
            drives.check_free(self.drives, part.pos)
            self.mc += self.drives.m
        self.rayleigh = rayleigh if (rayleigh is not None and (rayleigh.alpha or rayleigh.beta)) else None
        # sparse LDL^T without pivoting for the symmetric positive definite step matrix; sparse QR when multipliers
        # make the KKT matrix indefinite (LDL^T meets zero pivots) or strain-rate damping makes it unsymmetric
        # (d f_d / dq; LDL^T reads one triangle)
        # (contact friction likewise: d f / d q is unsymmetric)
        unsym = strain_rate is not None or bool(contact.dissipation_calls(asm.mesh)) or \
            bool(self.drives is not None and self.drives.torques)  # (a torque's tangent is skew)
        self.linsol = linsol if linsol != "auto" else ("qr" if (self.mc or unsym) else "ldl")

        M = asm.mass_matrix().tocsc()
        self.M_full = M
        self.M = (part.E.T @ M @ part.E).tocsc()
        self.M.sort_indices()

        # linear terms: constant generalized force (gravity, distributed dead loads, point loads)
        lin = [mk for mk in asm.mapped if mk.term.effect in LINEAR_EFFECTS]
        self.nonlinear = [mk for mk in asm.mapped if mk.term.effect not in LINEAR_EFFECTS]
        f_lin = asm.Q.copy()
        self._lin_energy = []
        for mk in lin:
            mk(asm.x0)
            G = mk.G.ravel().copy()
            f_lin -= np.bincount(mk.term.idx.ravel(), G, minlength=n)
            # U_lin(x) = c + G.x (gradient constant)
            self._lin_energy.append((mk.term.idx.ravel().copy(), G, float(mk.E.sum()) - float(G @ asm.x0[mk.term.idx.ravel()]),
                                     mk.term.label))
        self.f_lin_full = f_lin
        self.f_lin = part.E.T @ f_lin
        self.length_scale = asm.mesh.length_scale
        self.span = float(np.max(np.abs(asm.x0))) + 1.0
        # the kernel calls: a cable's axial and bending terms fused into one elastic_<strain> kernel where both
        # are on (same elements, Gauss order and Rayleigh weight): one B^T f_uu B per point instead of two
        weights = self.rayleigh.element_weight if (self.rayleigh is not None and self.rayleigh.beta) else {}
        self.force_terms = force_terms([mk.term for mk in self.nonlinear], fuse=self.fuse, row_keys=weights)
        # values that are inputs of the compiled graphs (not baked in): the kernels' element parameters (material,
        # section, lengths) and the linear potentials' coefficients (gravity, dead loads) of the energy outputs
        self.par = np.concatenate([ft.P.ravel() for ft in self.force_terms] +
                                  [mk.P.ravel() for mk in self.nonlinear] + [np.zeros(0)])
        self.lin = np.concatenate([np.bincount(idx, G, minlength=n) for idx, G, _, _ in self._lin_energy] +
                                  [np.array([c for _, _, c, _ in self._lin_energy]), asm.Q])
        self.graph_key = self._structure_key()
        graphs = _GRAPHS.get(self.graph_key)
        if graphs is None:
            self._build_forces()
            self._build_damping()
            self._build_step()
            graphs = {k: getattr(self, k) for k in self._GRAPH_ATTRS}
            graphs["factor"] = {}
            _GRAPHS[self.graph_key] = graphs
        else:
            for k in self._GRAPH_ATTRS:
                setattr(self, k, graphs[k])
        self._graphs = graphs
        self._setup_buffers(self.kel_sparsity is not None)

    # compiled functions and what describes them: built once per structure key and shared by later StepSystems
    _GRAPH_ATTRS = ("kel_sparsity", "forces_pf", "grad_pf", "energy_labels", "energy_f", "_energy_kin_labels",
                    "_energy_kin_f", "damp_f", "damp_force_f", "kkt_sparsity", "iter_f", "res_f", "jac_f")

    @property
    def forces_f(self) -> ca.Function:
        """forces(x) -> (g, K[, kel]) with this scene's element parameters (forces_pf takes them as an input)."""
        if "forces_f" not in self.__dict__:
            xf = ca.MX.sym("x", self.nf)
            out = self.forces_pf(xf, ca.DM(self.par))
            self.__dict__["forces_f"] = ca.Function("forces", [xf], list(out), ["x"],
                                                    [self.forces_pf.name_out(i) for i in range(len(out))])
        return self.__dict__["forces_f"]

    @property
    def grad_f(self) -> ca.Function:
        """gradient(x) -> g with this scene's element parameters (grad_pf takes them as an input)."""
        if "grad_f" not in self.__dict__:
            xf = ca.MX.sym("x", self.nf)
            self.__dict__["grad_f"] = ca.Function("gradient", [xf], [self.grad_pf(xf, ca.DM(self.par))], ["x"], ["g"])
        return self.__dict__["grad_f"]

    def _structure_key(self) -> str:
        """What the compiled graphs bake in: the pattern of the equations (elements, kernels, gathers, sparsity),
        and the values that are constants of the graphs (mass matrix, fixed coordinates, Rayleigh and strain-rate
        damping, penalties, constraints, scales). Element parameters (E, section, lengths), constant and time
        loads, the step size and the initial state are inputs: runs that differ only in those share the graphs."""
        h = hashlib.sha256()

        def add(*xs):
            for x in xs:
                if isinstance(x, np.ndarray):
                    h.update(repr((x.dtype.str, x.shape)).encode())
                    h.update(np.ascontiguousarray(x).tobytes())
                elif isinstance(x, (list, tuple)):
                    h.update(b"[")
                    add(*x)
                    h.update(b"]")
                elif isinstance(x, dict):
                    add(*sorted(x.items(), key=lambda kv: repr(kv[0])))
                elif hasattr(x, "__dict__") and not isinstance(x, type):
                    add(type(x).__name__, dict(vars(x)))
                elif sp.issparse(x):
                    x = sp.csc_matrix(x)
                    add(x.shape, x.indptr, x.indices, x.data)
                else:
                    h.update(repr(x).encode())
        asm = self.asm
        add(asm.n, self.nf, self.mc, self.linsol, self.fuse, self._gather, self.part.c, self.M, self.span,
            self.length_scale, bool(np.any(asm.Q)), [lbl for *_, lbl in self._lin_energy])
        add([(ft.element, ft.effect, ft.gauss, ft.idx, ft.P.shape, ft.labels, ft.sources) for ft in self.force_terms])
        add([(mk.term.element, mk.term.effect, mk.term.gauss, mk.term.idx, mk.P.shape, mk.term.label)
             for mk in self.nonlinear])
        r = self.rayleigh
        add(None if r is None else (r.alpha, r.beta, {k: np.asarray(v, float) for k, v in r.element_weight.items()}))
        add(self.strain_rate, asm.penalty, self.cons)
        add(contact.dissipation_calls(asm.mesh))  # contact damping/friction: parameters baked into the graph
        d = self.drives  # drive rows' pattern (their time functions are inputs)
        add(None if d is None else (d.nw, d.row, d.wk, d.i, d.j, d.coef, d.torques))
        return h.hexdigest()

    # -- symbolic assembly (once per scene) -------------------------------------------------------------------
    def x_full_mx(self, xf: ca.MX) -> ca.MX:
        """E xf + c as a gather (every coordinate is one unknown or fixed): the element gathers that follow merge
        with it into one, where a product with E would cost a sparse product at every evaluation."""
        x = ca.vertcat(xf, ca.MX.zeros(1))[self._gather.tolist()]
        return x + ca.DM(self.part.c) if np.any(self.part.c) else x

    def _build_forces(self) -> None:
        asm, nf, pos = self.asm, self.nf, self.pos
        xf = ca.MX.sym("x", nf)
        par = ca.MX.sym("par", self.par.size)
        x = self.x_full_mx(xf)
        energies = []
        kel_vals, kel_rows, kel_cols = [], [], []
        weights = self.rayleigh.element_weight if (self.rayleigh is not None and self.rayleigh.beta) else {}
        Ps, o = [], 0  # each kernel call's parameters (n_p x N) from the input vector
        for P in [ft.P for ft in self.force_terms] + [mk.P for mk in self.nonlinear]:
            Ps.append(ca.reshape(par[o:o + P.size], P.shape[1], P.shape[0]))
            o += P.size
        Pft, Pmk = Ps[:len(self.force_terms)], Ps[len(self.force_terms):]
        groups: dict = {}  # calls on the same element coordinates: gradients and Hessians summed before the scatter
        for ft, Pk in zip(self.force_terms, Pft):
            Xe = ca.reshape(x[ft.idx.ravel().tolist()], ft.nd, ft.N)
            _, G, H = ft.mapped()(Xe, Pk)
            key = (ft.idx.shape, ft.idx.tobytes())
            if key in groups:
                grp = groups[key]
                grp[1], grp[2] = grp[1] + G, grp[2] + H
            else:
                groups[key] = [ft.idx, G, H]
            if weights and all(lbl in ELASTIC_LABELS for lbl in ft.labels):
                ti, rows = ft.sources[0]  # fused rows have equal weights (row_keys)
                w = weights.get(ti)
                if w is not None and np.any(np.asarray(w)[rows]):
                    ia, ib, keep = self._hessian_entries(ft.idx)
                    we = np.repeat(np.asarray(w, float)[rows], ft.nd * ft.nd)[keep]
                    hv = ca.vec(H)
                    kel_vals.append((hv[keep.tolist()] if len(keep) < hv.shape[0] else hv) * ca.DM(we))
                    kel_rows.append(ib[keep])
                    kel_cols.append(ia[keep])
        gvals, gtarget, hvals, rows, cols, hpos = [], [], [], [], [], []
        n_h = 0
        for idx, G, H in groups.values():
            gvals.append(ca.vec(G))
            gtarget.append(pos[idx.ravel()])
            ia, ib, keep = self._hessian_entries(idx)
            hvals.append(ca.vec(H))
            rows.append(ib[keep])
            cols.append(ia[keep])
            hpos.append(n_h + keep)
            n_h += ia.size
        g = _gather_sum(gvals, np.concatenate(gtarget), nf) if gvals else ca.MX.zeros(nf)
        K = ca.MX(nf, nf)
        if rows:
            K = self._scatter(hvals, np.concatenate(rows), np.concatenate(cols), np.concatenate(hpos), n_h)
        self.kel_sparsity = None
        outs = [g, K]
        if kel_vals:
            Kel = self._scatter(kel_vals, np.concatenate(kel_rows), np.concatenate(kel_cols))
            self.kel_sparsity = Kel.sparsity()
            outs.append(_mx_sparse_nz(Kel))
        if asm.penalty is not None:
            pc = asm.penalty
            c = asm._casadi_constraint(pc, x)
            pen = 0.5 * ca.sum1(ca.DM(pc.k) * c * c)
            outs[0] = outs[0] + ca.gradient(pen, xf)
            outs[1] = outs[1] + ca.hessian(pen, xf)[0]
            energies.append(("penalty", pen))
        self.forces_pf = ca.Function("forces", [xf, par], outs, ["x", "par"],
                                     ["g", "K"] + (["kel"] if kel_vals else []))
        # the gradient alone from the (energy, gradient) companions: no Hessian work (residuals of modified Newton)
        ggroups: dict = {}
        for ft, Pk in zip(self.force_terms, Pft):
            Xe = ca.reshape(x[ft.idx.ravel().tolist()], ft.nd, ft.N)
            G = ft.mapped_grad()(Xe, Pk)[1]
            key = (ft.idx.shape, ft.idx.tobytes())
            ggroups[key] = (ft.idx, ggroups[key][1] + G) if key in ggroups else (ft.idx, G)
        gg = _gather_sum([ca.vec(G) for _, G in ggroups.values()],
                         np.concatenate([pos[idx.ravel()] for idx, _ in ggroups.values()]), nf) \
            if ggroups else ca.MX.zeros(nf)
        if asm.penalty is not None:
            gg += ca.gradient(pen, xf)
        self.grad_pf = ca.Function("gradient", [xf, par], [gg], ["x", "par"], ["g"])
        # energies for the outputs from the energy-only compiled functions (no gradient, no Hessian)
        elist = []
        for mk, Pk in zip(self.nonlinear, Pmk):
            t = mk.term
            Xe = ca.reshape(x[t.idx.ravel().tolist()], mk.nd, mk.N)
            ef = map_elements(kernels.load_energy(t.element, t.effect, t.gauss),
                              kernels.load_batch(t.element, t.effect, t.gauss, "_energy"), mk.N)
            elist.append((t.label, ca.sum2(ef(Xe, Pk))))
        elist += [(lbl, e) for lbl, e in energies if lbl == "penalty"]
        self.energy_labels = [lbl for lbl, _ in elist]
        self.energy_f = ca.Function("energies", [xf, par], [ca.vertcat(*[e for _, e in elist]) if elist
                                                            else ca.MX(0, 1)])
        # the outputs' energies in one call: the potentials (the linear ones, U = c + G.x, as dot products with the
        # input `lin` = [G_1 .. G_k, c_1 .. c_k, Q]) and the kinetic energy
        lin = ca.MX.sym("lin", self.lin.size)
        n, k = asm.n, len(self._lin_energy)
        for j, (_, _, _, label) in enumerate(self._lin_energy):
            elist.append((label, lin[k * n + j] + ca.dot(lin[j * n:(j + 1) * n], x)))
        if np.any(asm.Q):
            elist.append(("loads", -ca.dot(lin[k * n + k:], x)))
        self._energy_kin_labels = [lbl for lbl, _ in elist]
        vf = ca.MX.sym("v", nf)
        self._energy_kin_f = ca.Function("energies_kinetic", [xf, vf, par, lin], [
            ca.vertcat(*[e for _, e in elist], 0.5 * ca.dot(vf, ca.mtimes(_dm(self.M), vf)))])

    def _build_damping(self) -> None:
        """damp_f(x, v) -> (f_d, df_d/dx, df_d/dv) of the strain-rate dissipation D = 1/2 sum_points w L
        (c_axial eps_dot^2 + c_bending |kappa_dot|^2): exact derivatives by AD of one vectorized graph."""
        self.damp_f = self.damp_force_f = None
        sr = self.strain_rate
        nf = self.nf
        xf, vf = ca.MX.sym("x", nf), ca.MX.sym("v", nf)
        X, V = self.x_full_mx(xf), ca.mtimes(_dm(self.E), vf)
        # contact damping and friction (ancf_sym.contact): force and exact tangents from the compiled kernels
        dc = contact.dissipation_mx(self, X, V)
        if sr is None:
            if dc is not None:
                self.damp_f = ca.Function("contact_dissipation", [xf, vf], list(dc), ["x", "v"],
                                          ["f", "df_dx", "df_dv"])
                self.damp_force_f = ca.Function("contact_force", [xf, vf], [dc[0]], ["x", "v"], ["f"])
            return
        d = sr.dim
        P = len(sr.wL)
        R, Rd, RR = ca.mtimes(_dm(sr.Bx), X), ca.mtimes(_dm(sr.Bx), V), ca.mtimes(_dm(sr.Bxx), X)
        rx = [R[k * P:(k + 1) * P] for k in range(d)]
        rd = [Rd[k * P:(k + 1) * P] for k in range(d)]
        rxx = [RR[k * P:(k + 1) * P] for k in range(d)]
        n2 = sum(c * c for c in rx)
        dot = sum(a * b for a, b in zip(rx, rd))
        g = ca.DM(sr.green.astype(float))
        eps_dot = g * dot + (1 - g) * dot / ca.sqrt(n2)
        if d == 2:
            kap = [(rx[0] * rxx[1] - rx[1] * rxx[0]) / n2 ** 1.5]
        else:
            kap = [(rx[1] * rxx[2] - rx[2] * rxx[1]) / n2 ** 1.5, (rx[2] * rxx[0] - rx[0] * rxx[2]) / n2 ** 1.5,
                   (rx[0] * rxx[1] - rx[1] * rxx[0]) / n2 ** 1.5]
        wl = ca.DM(sr.wL)
        D = 0.5 * ca.dot(ca.DM(sr.c_axial) * wl, eps_dot * eps_dot)
        if np.any(sr.c_bending):
            kdot = ca.jtimes(ca.vertcat(*kap), xf, vf)
            cb = ca.repmat(ca.DM(sr.c_bending) * wl, d if d == 3 else 1, 1)
            D += 0.5 * ca.dot(cb, kdot * kdot)
        fd = ca.gradient(D, vf)
        outs = [fd, ca.jacobian(fd, xf), ca.jacobian(fd, vf)]
        if dc is not None:
            outs = [a + b for a, b in zip(outs, dc)]
            fd = outs[0]
        self.damp_f = ca.Function("strain_rate_damping", [xf, vf], outs, ["x", "v"], ["f", "df_dx", "df_dv"])
        self.damp_force_f = ca.Function("strain_rate_force", [xf, vf], [fd], ["x", "v"], ["f"])

    def damping_force(self, xf: np.ndarray, vf: np.ndarray) -> np.ndarray | None:
        """Damping force on the unknowns at (x, v): Rayleigh C v (with the current K_el values) + strain rate."""
        f = None
        C = self.damping_matrix(self.kel)
        if C is not None:
            f = C @ vf
        if self.damp_f is not None:
            fd = np.asarray(self.damp_f(xf, vf)[0]).ravel()
            f = fd if f is None else f + fd
        return f

    @property
    def damped(self) -> bool:
        return self.rayleigh is not None or self.damp_f is not None

    def _hessian_entries(self, idx: np.ndarray):
        """Unknowns (a, b) of the entries of the column-major vec of a mapped kernel's Hessian output (nd x nd N:
        entry e nd^2 + a nd + b is d2U / dx_idx[e, a] dx_idx[e, b]) and the entries on two unknowns."""
        N, nd = idx.shape
        ia = self.pos[np.broadcast_to(idx[:, :, None], (N, nd, nd)).ravel()]
        ib = self.pos[np.broadcast_to(idx[:, None, :], (N, nd, nd)).ravel()]
        return ia, ib, np.flatnonzero((ia >= 0) & (ib >= 0))

    def _scatter(self, vals: list, r: np.ndarray, c: np.ndarray, src: np.ndarray | None = None,
                 n_src: int | None = None) -> ca.MX:
        """Sparse nf x nf MX summing the values at (r, c): entry k is vertcat(vals)[src[k]] (default: k)."""
        nf = self.nf
        indptr, indices, inv = csc_pattern(r, c, nf, nf)
        spK = casadi_sparsity(nf, nf, indptr, indices)
        if src is None:
            src, n_src = np.arange(len(inv)), len(inv)
        target = -np.ones(n_src, dtype=np.int64)
        target[src] = inv
        return ca.MX(spK, _gather_sum(vals, target, len(indices)))

    def constraint_mx(self, xf: ca.MX, w: ca.MX | None = None) -> ca.MX:
        """The kept exact rows, then the drive rows at the time inputs w."""
        x = self.x_full_mx(xf)
        parts = [Assembly._casadi_constraint(self.cons, x)] if self.cons is not None else []
        if self.drives is not None and self.drives.m:
            parts.append(self.drives.mx(x, w))
        return ca.vertcat(*parts)

    @property
    def bilinear(self) -> bool:
        """Constraint rows with a Hessian (bilinear terms)."""
        return (self.cons is not None and len(self.cons.qrow) > 0) or (self.drives is not None and self.drives.m > 0)

    def torque_mx(self, xf: ca.MX, w: ca.MX) -> ca.MX | None:
        """Generalized force of the applied torques on the unknowns, tau (-s, c) on a body's (c, s), or None."""
        if self.drives is None or not self.drives.torques:
            return None
        vals, rows = [], []
        for ic, is_, k in self.drives.torques:
            uc, us = int(self.pos[ic]), int(self.pos[is_])
            vals += [-w[k] * xf[us], w[k] * xf[uc]]
            rows += [uc, us]
        A = ca.DM(ca.Sparsity.triplet(self.nf, len(rows), rows, list(range(len(rows)))), 1.0)
        return ca.mtimes(A, ca.vertcat(*vals))

    def damping_mx(self, xf_or_v: ca.MX, kel: ca.MX | None) -> tuple[ca.MX, ca.MX]:
        """(C v, C) as MX for C = alpha M + beta K_el (kel: its values, or None)."""
        nf = self.nf
        Cv, C = ca.MX.zeros(nf), ca.MX(nf, nf)
        if self.rayleigh is None:
            return Cv, C
        Mdm = _dm(self.M)
        if self.rayleigh.alpha:
            Cv += self.rayleigh.alpha * ca.mtimes(Mdm, xf_or_v)
            C = C + self.rayleigh.alpha * Mdm
        if kel is not None:
            Kel = ca.MX(self.kel_sparsity, kel)
            Cv += self.rayleigh.beta * ca.mtimes(Kel, xf_or_v)
            C = C + self.rayleigh.beta * Kel
        return Cv, C

    def _build_step(self) -> None:
        nf, mc = self.nf, self.mc
        xf, lam, p_in = ca.MX.sym("x", nf), ca.MX.sym("lam", mc), ca.MX.sym("p", nf + self.nw)
        p, w = (p_in[:nf], p_in[nf:]) if self.nw else (p_in, None)  # w: the drives' time inputs
        cm, cc, kc = ca.MX.sym("cm"), ca.MX.sym("cc"), ca.MX.sym("kc")
        kel = ca.MX.sym("kel", self.kel_sparsity.nnz()) if self.kel_sparsity is not None else None
        vc = ca.MX.sym("vc", nf)  # v_n+1 = vc + cc x (used by the strain-rate damping)
        # y: inertia part of the constant residual, M (cm x + y) (the alpha step graph: one product with M per
        # iteration and none in the step's predictor; other callers pass y = 0 and M y in p)
        y = ca.MX.sym("y", nf)
        par = ca.MX.sym("par", self.par.size)
        out = self.forces_pf(xf, par)
        g, K = out[0], out[1]
        Mdm = _dm(self.M)
        Cx, C = self.damping_mx(xf, kel)
        r_q = ca.mtimes(Mdm, cm * xf + y) + cc * Cx + g + p
        spS = K.sparsity().unite(Mdm.sparsity())
        if spS == K.sparsity():  # M placed in K's pattern once: no projection of M at every evaluation
            S = cm * ca.project(Mdm, spS) + cc * C + K
        else:
            S = cm * Mdm + cc * C + K
        if self.damp_f is not None:
            fd, dfx, dfv = self.damp_f(xf, vc + cc * xf)
            r_q += fd
            S = S + dfx + cc * dfv
        # the same residual from the gradient-only kernels (modified Newton: no Hessian work)
        r_g = ca.mtimes(Mdm, cm * xf + y) + cc * Cx + self.grad_pf(xf, par) + p
        if self.damp_f is not None:
            r_g += self.damp_force_f(xf, vc + cc * xf)
        tq = self.torque_mx(xf, w)
        if tq is not None:  # applied torques: force tau (-s, c), tangent -d/dx of it
            r_q -= tq
            r_g -= tq
            S = S - ca.jacobian(tq, xf)
        if mc:
            phi = self.constraint_mx(xf, w)
            Jx = ca.jacobian(phi, xf)
            r_q += kc * ca.mtimes(Jx.T, lam)
            r_g += kc * ca.mtimes(Jx.T, lam)
            if self.bilinear:
                S = S + ca.hessian(ca.dot(kc * lam, phi), xf)[0]
            r = ca.vertcat(r_q, kc * phi)
            rg = ca.vertcat(r_g, kc * phi)
            KKT = ca.blockcat([[S, kc * Jx.T], [kc * Jx, ca.MX(mc, mc)]])
            rc = ca.mmax(ca.fabs(phi))
        else:
            r, rg, KKT, rc = r_q, r_g, S, ca.MX(0)
        rq = ca.mmax(ca.fabs(r_q))
        ins = [xf, lam, p_in, cm, cc, kc, vc] + ([kel] if kel is not None else []) + [y, par]
        names = ["x", "lam", "p", "cm", "cc", "kc", "vc"] + (["kel"] if kel is not None else []) + ["y", "par"]
        self.kkt_sparsity = KKT.sparsity()
        kkt_nz = _mx_sparse_nz(KKT)
        # largest entry (round-off floor): on the diagonal when the step matrix is positive definite
        kmax = ca.mmax(ca.fabs(ca.diag(KKT))) if self.linsol == "ldl" and not mc else ca.mmax(ca.fabs(kkt_nz))
        dz = -ca.solve(KKT, r, self.linsol)
        dzx = ca.mmax(ca.fabs(dz[:nf]))
        dzl = ca.mmax(ca.fabs(dz[nf:])) if mc else ca.MX(0)
        # norms: |r_q|inf [N], |Phi|inf [m], |dx|inf, |dlam|inf (scaled: m), max |KKT|
        self.iter_f = ca.Function("newton_iteration", ins, [dz, ca.vertcat(rq, rc, dzx, dzl, kmax)], names,
                                  ["dz", "norms"])
        self.res_f = ca.Function("step_residual", ins, [rg, ca.vertcat(ca.mmax(ca.fabs(r_g)), rc)], names,
                                 ["r", "norms"])
        self.jac_f = ca.Function("step_jacobian", ins, [r, ca.vertcat(rq, rc, kmax), kkt_nz], names,
                                 ["r", "norms", "kkt"])


    # largest LDL^T factorisation (operations of its SX graph) built for in-graph modified Newton
    MAX_FACTOR_OPS = 2_000_000

    def ensure_factor(self):
        """fact_f, built on first use (None where the in-graph factor does not apply); shared like the graphs."""
        fac = self._graphs["factor"]
        if not fac:
            self._build_factor()
            fac.update({k: getattr(self, k) for k in ("fact_f", "ldl_perm", "ldl_sparsity", "factor_size")
                        if hasattr(self, k)})
        for k, v in fac.items():
            setattr(self, k, v)
        return fac["fact_f"]

    def _build_factor(self) -> None:
        """In-graph sparse LDL^T of the symmetric positive definite step matrix whose factor is a value (so a
        compiled step can keep it across iterations and steps): fact_f(KKT nonzeros) -> (D, U, U^T nonzeros) with
        P A P^T = U^T diag(D) U, U unit upper triangular (fill-reducing AMD ordering P); `ldl_solve_mx` applies it
        with two sparse triangular solves. Only without multipliers and strain-rate damping (self.linsol "ldl"),
        and when the factorisation graph stays small; else self.fact_f is None."""
        self.fact_f = None
        nf = self.nf
        if self.linsol != "ldl" or self.mc or not nf:
            return
        spK = self.kkt_sparsity
        spLT, perm = spK.ldl(True)
        counts = np.diff(np.array(spLT.colind()))  # entries above the diagonal per column of U
        if float(np.sum((counts + 1.0) ** 2)) > self.MAX_FACTOR_OPS:
            return
        a = ca.SX.sym("a", spK.nnz())
        D, LT, p = ca.ldl(ca.SX(spK, a), True)
        U = LT + ca.SX.eye(nf)
        UT = U.T
        self.ldl_perm = np.array(p, dtype=np.int64)
        self.ldl_sparsity = (U.sparsity(), UT.sparsity())
        self.fact_f = ca.Function("ldl_factor", [a], [D, _sx_nz(U), _sx_nz(UT)], ["kkt"], ["D", "U", "UT"])
        self.factor_size = (nf, U.nnz(), UT.nnz())

    def ldl_solve_mx(self, D: ca.MX, U: ca.MX, UT: ca.MX, b: ca.MX) -> ca.MX:
        """A^-1 b from the values of fact_f (MX: two sparse triangular solves and a scaling)."""
        spU, spUT = self.ldl_sparsity
        p = self.ldl_perm
        y = b[p.tolist()] if np.any(p != np.arange(len(p))) else b
        y = ca.solve(ca.MX(spUT, UT), y) / D
        y = ca.solve(ca.MX(spU, U), y)
        return y[np.argsort(p).tolist()] if np.any(p != np.arange(len(p))) else y

    def _setup_buffers(self, has_kel: bool) -> None:
        nf, mc = self.nf, self.mc
        self.nz = nf + mc
        self.x, self.lam, self.p, self.vc = np.zeros(nf), np.zeros(mc), np.zeros(nf + self.nw), np.zeros(nf)
        self.y = np.zeros(nf)  # (stays 0 here: p holds the whole constant part)
        self.cm, self.cc, self.kc = np.zeros(1), np.zeros(1), np.ones(1)
        self.kel = np.zeros(self.kel_sparsity.nnz()) if has_kel else None
        self.r, self.dz = np.zeros(self.nz), np.zeros(self.nz)
        self.norms = np.zeros(5)
        self._jac_norms = np.zeros(3)
        self.floor = 0.0
        spk = self.kkt_sparsity
        self.kkt = sp.csc_matrix((np.zeros(spk.nnz()), np.array(spk.row(), dtype=np.int32),
                                  np.array(spk.colind(), dtype=np.int32)), shape=(self.nz, self.nz))
        args = [self.x, self.lam, self.p, self.cm, self.cc, self.kc, self.vc] + ([self.kel] if has_kel else []) \
            + [self.y, self.par]
        self._bufs = []
        for f, outs in ((self.iter_f, (self.dz, self.norms)), (self.res_f, (self.r, self.norms[:2])),
                        (self.jac_f, (self.r, self._jac_norms, self.kkt.data))):
            buf, ev = f.buffer()
            for i, a in enumerate(args):
                buf.set_arg(i, memoryview(a))
            for i, a in enumerate(outs):
                buf.set_res(i, memoryview(a))
            self._bufs.append((buf, ev, args, outs))  # the buffer object must outlive its evaluations
        self._iter_eval, self._res_eval, self._jac_eval = (b[1] for b in self._bufs)

    # -- numeric calls ------------------------------------------------------------------------------------------
    def iterate(self) -> np.ndarray:
        """One full Newton iteration at the current buffers: self.dz (not applied) and self.norms."""
        self._iter_eval()
        self.floor = float(np.finfo(float).eps * self.norms[4] * self.span)
        return self.dz

    def residual(self) -> np.ndarray:
        """r at the current buffers, written into self.r; norms[:2]."""
        self._res_eval()
        return self.r

    def jacobian(self) -> sp.csc_matrix:
        """r and the KKT values at the current buffers (self.r, self.kkt in place); updates the round-off floor
        of the residual, eps x largest matrix entry x coordinate span (as statics._roundoff_floor)."""
        self._jac_eval()
        self.norms[:2] = self._jac_norms[:2]
        self.norms[4] = self._jac_norms[2]
        self.floor = float(np.finfo(float).eps * self._jac_norms[2] * self.span)
        return self.kkt

    def full(self, xf: np.ndarray) -> np.ndarray:
        """Coordinates of the scene from the unknowns."""
        return self.full_v(xf) + self.part.c

    def full_v(self, vf: np.ndarray) -> np.ndarray:
        """E vf: every coordinate is one unknown or fixed (a gather, cheaper than the sparse product)."""
        vf = np.asarray(vf, dtype=float)
        if vf.ndim != 1:
            return self.E @ vf
        ext = np.empty(self.nf + 1)
        ext[:-1], ext[-1] = vf, 0.0
        return ext[self._gather]

    def reduce(self, x_full: np.ndarray) -> np.ndarray:
        """Unknowns from scene coordinates (that satisfy the eliminated constraints)."""
        return np.asarray(x_full)[self.part.roots].copy()

    def reduce_force(self, f_full: np.ndarray) -> np.ndarray:
        """Generalized force on the unknowns (E^T f)."""
        return self.E.T @ f_full

    def forces(self, xf: np.ndarray) -> tuple[np.ndarray, sp.csc_matrix, np.ndarray | None]:
        """(gradient of the nonlinear potential, its Hessian, K_el values or None) at free coordinates xf."""
        out = self.forces_pf(xf, self.par)
        g = np.asarray(out[0]).ravel()
        K = out[1].sparse() if hasattr(out[1], "sparse") else sp.csc_matrix(np.asarray(out[1]))
        kel = np.asarray(out[2]).ravel() if len(out) > 2 else None
        return g, sp.csc_matrix(K), kel

    def potential(self, xf: np.ndarray) -> dict:
        """Energies by label at free coordinates xf (nonlinear terms, penalty and linear terms) [J]."""
        return self.energies(xf, None)[1]

    def energies(self, xf: np.ndarray, vf: np.ndarray | None) -> tuple[float, dict]:
        """(kinetic energy 1/2 v.M v (0 without vf), potential energies by label) in one compiled call [J]."""
        out: dict[str, float] = {}
        if not hasattr(self, "_ebuf"):
            self._e_x, self._e_vel = np.zeros(self.nf), np.zeros(self.nf)
            self._e_v = np.zeros(self._energy_kin_f.nnz_out(0))
            buf, ev = self._energy_kin_f.buffer()
            buf.set_arg(0, memoryview(self._e_x))
            buf.set_arg(1, memoryview(self._e_vel))
            buf.set_arg(2, memoryview(self.par))
            buf.set_arg(3, memoryview(self.lin))
            buf.set_res(0, memoryview(self._e_v))
            self._ebuf = (buf, ev)
        self._e_x[:] = xf
        self._e_vel[:] = 0.0 if vf is None else vf
        self._ebuf[1]()
        vals = self._e_v.tolist()
        for label, v in zip(self._energy_kin_labels, vals):
            out[label] = out.get(label, 0.0) + v
        return vals[-1], out

    def phi(self, xf: np.ndarray, t: float = 0.0) -> np.ndarray:
        x = self.full(xf)
        parts = [self.cons.value(x)] if self.cons is not None else []
        if self.drives is not None:
            parts.append(self.drives.value(x, self.drives.w(t)))
        return np.concatenate(parts) if parts else np.zeros(0)

    def jac_phi(self, xf: np.ndarray, t: float = 0.0) -> sp.csr_matrix:
        x = self.full(xf)
        parts = [self.cons.jacobian(x)] if self.cons is not None else []
        if self.drives is not None:
            parts.append(self.drives.jacobian(x, self.drives.w(t)))
        return (sp.vstack(parts) @ self.E).tocsr()

    def phi_vv(self, vf: np.ndarray, xf: np.ndarray | None = None, t: float = 0.0) -> np.ndarray:
        """The acceleration-level constraint is J a + gamma = 0: gamma = v^T Phi_qq v of the bilinear rows, and for
        the drive rows (at xf, time t) also their explicit time derivatives (drives.DriveSystem.time_terms)."""
        v = self.full_v(vf)
        parts = []
        if self.cons is not None:
            c = self.cons
            parts.append(np.bincount(c.qrow, 2 * c.qcoef * v[c.qi] * v[c.qj], minlength=c.m) if len(c.qrow)
                         else np.zeros(c.m))
        if self.drives is not None:
            parts.append(self.drives.time_terms(self.full(xf), v, t)[1])
        return np.concatenate(parts) if parts else np.zeros(0)

    def w(self, t: float) -> np.ndarray:
        """The drives' time inputs at t (empty without drives)."""
        return self.drives.w(t) if self.drives is not None else np.zeros(0)

    def drive_force(self, xf: np.ndarray, lam: np.ndarray, t: float) -> np.ndarray | None:
        """Generalized force of the drives (their rows' reactions -J_D^T lam_D) and the torques on the unknowns at
        time t (true multipliers lam), for the work they do; None without drives."""
        d = self.drives
        if d is None:
            return None
        x, w = self.full(xf), d.w(t)
        f = d.torque_force(x, w)
        if d.m:
            f = f - d.jacobian(x, w).T @ lam[self.mc - d.m:]
        return self.E.T @ f

    def damping_matrix(self, kel: np.ndarray | None) -> sp.csc_matrix | None:
        if self.rayleigh is None:
            return None
        C = self.rayleigh.alpha * self.M
        if kel is not None and self.kel_sparsity is not None:
            spk = self.kel_sparsity
            C = C + self.rayleigh.beta * sp.csc_matrix((kel, np.array(spk.row()), np.array(spk.colind())),
                                                       shape=(self.nf, self.nf))
        return sp.csc_matrix(C)

    def stiffness_scale(self) -> float:
        """Largest diagonal entry of M (for the multiplier scale kc = cm * this)."""
        return float(self.M.diagonal().max()) if self.nf else 1.0


# -- Newton ------------------------------------------------------------------------------------------------------

class StiffnessDamping:
    """Rayleigh beta K_el: the elastic tangent at the start of each step, kept in system.kel (shared by the alpha and
    collocation integrators)."""

    def __init__(self, system: "StepSystem", counters: "Counters"):
        self.S, self.counters = system, counters
        self.f = None
        if system.kel_sparsity is not None:
            xf = ca.MX.sym("x", system.nf)
            self.f = ca.Function("kel", [xf], [system.forces_pf(xf, ca.DM(system.par))[2]])

    @property
    def active(self) -> bool:
        return self.f is not None

    def update(self, q: np.ndarray) -> None:
        if self.f is not None:
            self.S.kel[:] = np.asarray(self.f(q)).ravel()
            self.counters.residuals += 1

    def matrix(self):
        return self.S.damping_matrix(self.S.kel)


@dataclass
class NewtonOptions:
    """Newton on the exact tangent. A step converges when the residual is below tol x force scale (never below
    twice the round-off floor) and the constraints below xtol x length scale, or when the estimated error of the
    last update, theta/(1 - theta) |dz| with theta the contraction of successive updates, is below the update
    tolerance (saves the residual evaluation that would only confirm convergence). Alpha schemes: the update
    tolerance is max(xtol x length scale, lte_fraction x the step's local truncation error), and with `single`
    a step is accepted after one full Newton iteration when Newton's own estimate 2 omega |dz0|^2 is below it
    (an iteration on a kept factor is never accepted before the next one measured the contraction)."""
    tol: float = 1e-8  # residual, relative to the scene's force scale
    xtol: float = 1e-10  # updates and constraints, relative to the scene's length scale
    max_iter: int = 12
    # keep the factorisation across iterations and steps while the iteration contracts: alpha schemes in their
    # compiled step where the step matrix is symmetric positive definite (LDL^T factor in the state), else in
    # Python (SuperLU); residuals from the gradient-only kernels
    modified: bool = False
    single: bool = True  # accept a step after one iteration when Newton's error estimate allows
    lte_fraction: float = 0.01  # alpha schemes: update tolerance also this fraction of the local truncation error
    contraction: float = 0.5  # modified Newton: refactorise when the contraction |dz_k+1| / |dz_k| exceeds this
    max_modified: int = 8  # modified Newton: at most this many iterations on one factorisation within a step

    def __post_init__(self):
        if isinstance(self.lte_fraction, bool) or not isinstance(self.lte_fraction, (int, float)) or \
                not math.isfinite(self.lte_fraction) or self.lte_fraction < 0:
            raise fail("newton.lte_fraction", "must be a non-negative finite number", self.lte_fraction)
        for name in ("tol", "xtol", "contraction"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise fail(f"newton.{name}", "must be a positive finite number", v)
        for name in ("max_iter", "max_modified"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise fail(f"newton.{name}", "must be a positive integer", v)
        if self.contraction >= 1:
            raise SceneError(f"newton.contraction must be below 1, got {self.contraction!r}")
        for name in ("modified", "single"):
            if not isinstance(getattr(self, name), bool):
                raise SceneError(f"newton.{name} must be true or false, got {getattr(self, name)!r}")


@dataclass
class Counters:
    newton_iterations: int = 0  # updates applied (linear solves)
    residuals: int = 0  # residual evaluations (each one mapped kernel call per energy term)
    jacobians: int = 0  # KKT matrix assemblies
    factorizations: int = 0

    def as_dict(self) -> dict:
        return dict(self.__dict__)


class Factor:
    """Modified Newton: a SuperLU factorisation of the KKT matrix, remembered with the step coefficients."""

    def __init__(self):
        self.lu = None
        self.key = None

    def factorize(self, A: sp.csc_matrix, key, counters: Counters) -> bool:
        try:
            self.lu = spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1,
                                options={"SymmetricMode": True})
        except RuntimeError:  # exactly singular
            self.lu, self.key = None, None
            return False
        self.key = key
        counters.factorizations += 1
        return True


@dataclass
class NewtonOutcome:
    converged: bool
    iterations: int
    reason: str = ""
    residual: float = float("nan")


def newton(system: StepSystem, factor: Factor, key, opts: NewtonOptions, counters: Counters,
           tol_q: float, tol_x: float, it0: int = 0) -> NewtonOutcome:
    """Solve r(x, lam) = 0 from the buffers' current x, lam (updated in place).

    tol_q: force tolerance on the free rows [N]; tol_x: tolerance on updates and constraint rows [m].
    `key` identifies the step coefficients of a modified-Newton factorisation (refreshed when it differs).
    it0: iterations already spent on this step (count towards opts.max_iter).
    """
    if opts.modified:
        return _newton_modified(system, factor, key, opts, counters, tol_q, tol_x)
    nf = system.nf
    norms = system.norms
    it = it0
    d_prev = None
    while True:
        system.iterate()
        counters.residuals += 1
        counters.jacobians += 1
        counters.factorizations += 1
        rq, rc, dzx, dzl = norms[0], norms[1], norms[2], norms[3]
        if not (math.isfinite(rq) and math.isfinite(rc)):
            return NewtonOutcome(False, it, "residual not finite")
        tq = max(tol_q, 2.0 * system.floor)
        if rq <= tq and rc <= tol_x:
            return NewtonOutcome(True, it, "", rq)
        d = max(dzx, dzl)
        if not math.isfinite(d):
            return NewtonOutcome(False, it, "singular iteration matrix (update not finite)", rq)
        if it >= opts.max_iter:
            return NewtonOutcome(False, it, f"no convergence in {opts.max_iter} iterations (residual {rq:.3g} N, "
                                            f"constraint {rc:.3g} m; tolerances {tq:.3g} N, {tol_x:.3g} m)", rq)
        system.x += system.dz[:nf]
        if system.mc:
            system.lam += system.dz[nf:]
        it += 1
        counters.newton_iterations += 1
        if d <= 0.1 * tol_x and rc <= tol_x:
            return NewtonOutcome(True, it, "", rq)
        if d_prev is not None:
            theta = d / d_prev
            if theta < 0.5 and theta / (1 - theta) * d <= tol_x:
                return NewtonOutcome(True, it, "", rq)
            if d > 1e6 * d_prev:
                return NewtonOutcome(False, it, f"diverging (update {d:.3g}, residual {rq:.3g} N)", rq)
        d_prev = d


def _newton_modified(system, factor, key, opts, counters, tol_q, tol_x) -> NewtonOutcome:
    nf, mc = system.nf, system.mc
    norms = system.norms
    stale = factor.lu is None or factor.key != key
    A_cur = None
    if stale:
        A_cur = system.jacobian()
        counters.jacobians += 1
    else:
        system.residual()
    counters.residuals += 1
    fresh = stale  # system.kkt holds the Jacobian at the current iterate
    it, on_factor = 0, 0
    s_prev, d_prev = None, None
    r = system.r
    while True:
        rq, rc = norms[0], norms[1]
        if not (math.isfinite(rq) and math.isfinite(rc)):
            return NewtonOutcome(False, it, "residual not finite")
        tq = max(tol_q, 2.0 * system.floor)
        s = max(rq / tq, rc / tol_x)
        if s <= 1.0:
            return NewtonOutcome(True, it, "", rq)
        if it >= opts.max_iter:
            return NewtonOutcome(False, it, f"no convergence in {opts.max_iter} iterations (residual {rq:.3g} N, "
                                            f"constraint {rc:.3g} m; tolerances {tq:.3g} N, {tol_x:.3g} m)", rq)
        refresh = factor.lu is None or factor.key != key
        if s_prev is not None and (s > opts.contraction * s_prev or on_factor >= opts.max_modified):
            refresh = True
        if refresh:
            if not fresh:
                A_cur = system.jacobian()
                counters.jacobians += 1
                counters.residuals += 1
                fresh = True
            if not factor.factorize(A_cur, key, counters):
                return NewtonOutcome(False, it, "singular iteration matrix", rq)
            on_factor = 0
            d_prev = None
        dz = factor.lu.solve(-r)
        d = float(np.max(np.abs(dz))) if len(dz) else 0.0
        if not math.isfinite(d):
            return NewtonOutcome(False, it, "update not finite", rq)
        it += 1
        on_factor += 1
        counters.newton_iterations += 1
        system.x += dz[:nf]
        if mc:
            system.lam += dz[nf:]
        if d_prev is not None:
            theta = d / d_prev
            if theta < 0.5 and theta / (1 - theta) * d <= tol_x and rc <= tol_x:
                return NewtonOutcome(True, it, "", rq)
        d_prev = d
        s_prev = s
        system.residual()
        counters.residuals += 1
        fresh = False
        r = system.r


# -- integrators -------------------------------------------------------------------------------------------------

def initial_acceleration(S: StepSystem, q0: np.ndarray, v0: np.ndarray, Q0: np.ndarray, C=None, t0: float = 0.0):
    """Consistent initial acceleration and multipliers: [M J^T; J 0][a; lam] = [f - C v - g; -gamma] (gamma:
    StepSystem.phi_vv; drives and torques at time t0)."""
    g = np.asarray(S.grad_pf(q0, S.par)).ravel()  # (the gradient-only graph: no Hessian to compute and convert)
    f = S.f_lin + Q0 - g
    if S.drives is not None:
        f = f + S.reduce_force(S.drives.torque_force(S.full(q0), S.w(t0)))
    if C is not None:
        f = f - C @ v0
    if S.damp_f is not None:
        f = f - np.asarray(S.damp_f(q0, v0)[0]).ravel()
    if not S.nf:
        return np.zeros(0), np.zeros(S.mc)
    if S.mc:
        J = S.jac_phi(q0, t0)
        A = sp.bmat([[S.M, J.T], [J, None]], format="csc")
        z = spla.spsolve(A, np.r_[f, -S.phi_vv(v0, q0, t0)])
        return z[:S.nf], z[S.nf:]
    return spla.spsolve(S.M.tocsc(), f), np.zeros(0)


@dataclass
class StepOutcome:
    converged: bool
    iterations: int
    reason: str = ""
    fast: bool = False  # converged within the fused two-iteration call


def _pooled_buffer(graphs: dict, key, f: ca.Function, owner) -> tuple:
    """f.buffer() from the structure's pool (a buffer of a large graph takes ~10 ms to allocate at 1000 elements:
    a second run of the structure reuses the buffer of a finished run); it returns to the pool when `owner` is
    collected. The caller binds every argument and result anew."""
    pool = graphs.setdefault("buffers", {}).setdefault(key, [])
    be = pool.pop() if pool else f.buffer()
    weakref.finalize(owner, pool.append, be)
    return be


UNROLL_STATE = 2000  # step states of this size or more: chunks unrolled, guarded from the start


def _map_steps(step: ca.Function, n: int, n_accum: int) -> ca.Function:
    """n steps in one function, like step.mapaccum(n, n_accum): the first n_accum inputs carried from step to
    step, the others given per step as columns; the outputs of every step as columns. Large states: the n calls
    unrolled in one MX graph (mapaccum's nested construction took 3-5x longer to build at 1000 elements, with
    the same evaluation time)."""
    if step.nnz_in(0) < UNROLL_STATE:
        return step.mapaccum(f"alpha_steps_{n}", n, n_accum)
    ins = [ca.MX.sym(step.name_in(i), step.size1_in(i), 1 if i < n_accum else n) for i in range(step.n_in())]
    acc, outs = ins[:n_accum], [[] for _ in range(step.n_out())]
    for j in range(n):
        r = step(*acc, *[a[:, j] for a in ins[n_accum:]])
        acc = r[:n_accum]
        for k in range(step.n_out()):
            outs[k].append(r[k])
    return ca.Function(f"alpha_steps_{n}", ins, [ca.horzcat(*o) for o in outs])


class AlphaIntegrator:
    """Newmark / HHT / generalized-alpha on a StepSystem (Arnold-Bruels form, index-3 constraints).

    A step is one compiled graph (predictor with the acceleration extrapolated linearly from the last two steps,
    Newton iterations chosen in-graph by CasADi switches that evaluate only the branch taken, corrector), and
    `run_chunk` maps it over many steps (mapaccum) so that a whole stretch of the time loop is one call. Steps
    the graph flags as unconverged are redone by the Python full-Newton loop (`newton`, absolute tolerances,
    max_iter) from the graph's last iterate. Two step graphs:

    - full Newton (default): every iteration is a full Newton iteration with CasADi's sparse LDL^T (or QR:
      multipliers, strain-rate damping); one or two iterations in the graph, accepted after one when Newton's own
      estimate 2 omega |dz0|^2 (omega = |dz1| / |dz0|^2 measured on two-iteration steps) is below the update
      tolerance. omega is re-measured at least every `refresh_every` steps, up to 8x less often when the
      estimate is below a tenth of the tolerance.
    - modified Newton (newton.modified true, symmetric step matrix: no multipliers, no strain-rate damping). The
      LDL^T factor of the step matrix (values D, U, U^T) is carried from step to step as accumulated inputs of
      the step function and kept across iterations and steps while the iteration contracts. An iteration on the
      kept factor costs the gradient-only kernels and two triangular solves; a refactorisation is a full Newton
      iteration (energy, gradient, Hessian kernels, assembly, LDL^T) that stores its factor. An iteration on the
      kept factor is accepted only after the next one measured its contraction theta = |dz_k+1| / |dz_k| (error
      theta / (1 - theta) |dz_k+1|); predicting theta from earlier steps to accept after one iteration was tried
      and let errors far above the tolerance through (a chaotic double pendulum ended 9 mm off). After a
      refactorisation the step may end after one iteration on omega as above. The contraction per step of factor
      age (rate = theta / age, rising at once, decaying slowly) predicts how many iterations the kept factor
      will need; a step starts with a refactorisation when the step size changed, when rate x age reaches
      newton.contraction, or when those iterations cost more than a refactorisation's cycle costs per step so
      far (renewal rule, a refactorisation counted as `refactor_cost` iterations); within a step it
      refactorises when a measured theta exceeds newton.contraction. The step's scalar logic is a few SX
      functions between the iterations (hundreds of scalar MX nodes cost more than the logic itself).

    The update tolerance is max(xtol L, lte_fraction x the step's local truncation error |beta - 1/6| h^2
    |a_n+1 - a_n|): Newton's error stays a small fraction of the time-discretization error, so the accuracy is
    the scheme's. newton.modified true without the in-graph factor (multipliers, strain-rate damping) runs
    modified Newton in Python with a SuperLU factorisation reused across iterations and steps.
    State: q, v (true velocity), a (true acceleration), ab (algorithmic acceleration), a_prev (acceleration of the
    previous step), lam (true multipliers) and the controls (omega, steps since a measurement; modified:
    contraction rate, factor age, step size of the factor, largest step-matrix entry, the last |dz0|, update
    tolerance and truncation error, the cost of the factor's cycle); modified: the factor.
    """
    order = 2  # of the local error estimate (step-size control exponent 1/(order + 1))
    refresh_every = 8  # one-iteration steps between two-iteration steps that re-measure omega / the contraction
    max_slots = 5  # modified Newton: iterations (refactorisations included) the step graph tries per step
    refactor_cost = 3.5  # modified Newton: a refactorisation's cost in iterations on a kept factor
    info_size = 7  # ok, iterations, factorisations, |dz0|, |dz1|, truncation error, max |KKT|
    extra_iterations = 4  # full Newton: iterations the step graph tries after the second one

    def __init__(self, system: StepSystem, scheme: Scheme, newton_opts: NewtonOptions, tol_q: float,
                 tol_x: float, counters: Counters):
        self.S, self.scheme, self.opts = system, scheme, newton_opts
        self.tol_q, self.tol_x = tol_q, tol_x
        self.counters = counters
        self.factor = Factor()
        nf, mc = system.nf, system.mc
        # in-graph modified Newton where the step graph can hold the factor; full Newton on request
        self.modified_graph = newton_opts.modified and system.ensure_factor() is not None
        self.nctl = 10 if self.modified_graph else 2
        self.fac_sizes = system.factor_size if self.modified_graph else ()
        self.q, self.v, self.a, self.ab, self.a_prev = (np.zeros(nf) for _ in range(5))
        self.lam = np.zeros(mc)
        self.ctl = np.zeros(self.nctl)
        self.fac = [np.zeros(k) for k in self.fac_sizes]  # D, U, U^T of the kept factor (modified)
        self._reset_controls()
        self.h_prev = None
        self.new = dict(q=np.zeros(nf), v=np.zeros(nf), a=np.zeros(nf), ab=np.zeros(nf), lam=np.zeros(mc))
        self._new_ctl = self.ctl.copy()
        self._new_fac = [f.copy() for f in self.fac]
        self.kdamp = StiffnessDamping(system, counters)
        # the compiled step and chunk functions, shared by the integrators of one structure and settings
        key = (system.graph_key, scheme, tuple(sorted(vars(newton_opts).items())), self.modified_graph,
               self.extra_iterations)
        self._graphs = self._GRAPHS.setdefault(key, {"chunks": {}})
        if "step" not in self._graphs:
            # full Newton: the further iterations (3-6) in the step graph on large states; small states build them
            # only for guarded chunks (after a hard transient showed up): ~2.5 ms of set-up for a rare need
            self._graphs["step"] = self._build_modified() if self.modified_graph else \
                self._build_full(self.extra_iterations if self.state_size >= UNROLL_STATE else 0)
        self.step_f = self._graphs["step"]
        self._setup_step_buffers()
        self._chunks: dict = {}  # this integrator's buffers of the chunk functions
        self._guard_on = False

    _GRAPHS: dict = {}  # (structure key, scheme, Newton options, in-graph factor) -> step and chunk functions

    # -- the compiled step ------------------------------------------------------------------------------------
    @property
    def state_size(self) -> int:
        return 5 * self.S.nf + self.S.mc + self.nctl

    @property
    def n_accum(self) -> int:
        """Accumulated inputs of the step function: the state, and the factor's D, U, U^T (modified)."""
        return 1 + len(self.fac_sizes)

    def _reset_controls(self) -> None:
        self.ctl[:] = 0.0
        if self.modified_graph:
            self.ctl[2] = -1.0  # contraction rate unknown; ctl[4] = 0: no factor

    def pack(self) -> np.ndarray:
        return np.concatenate([self.q, self.v, self.a, self.ab, self.a_prev, self.lam, self.ctl])

    def unpack(self, s: np.ndarray) -> dict:
        nf, mc = self.S.nf, self.S.mc
        out = {k: s[i * nf:(i + 1) * nf] for i, k in enumerate(("q", "v", "a", "ab", "a_prev"))}
        out["lam"] = s[5 * nf:5 * nf + mc]
        out["ctl"] = s[5 * nf + mc:]
        return out

    def _step_inputs(self):
        S, nf, mc = self.S, self.S.nf, self.S.mc
        st = ca.MX.sym("state", self.state_size)
        q, v, a, ab, ap = (st[i * nf:(i + 1) * nf] for i in range(5))
        lam = st[5 * nf:5 * nf + mc]
        ctl = st[5 * nf + mc:]
        h, hp = ca.MX.sym("h"), ca.MX.sym("h_prev")  # h_prev <= 0: no previous step (constant predictor)
        tols = ca.MX.sym("tols", 2)  # force tolerance [N], update tolerance [m]
        pload = ca.MX.sym("pload", nf + S.nw)  # -(f_lin + Q(t_n+1)), then the drives' inputs w(t_n+1)
        kel = ca.MX.sym("kel", S.kel.size) if S.kel is not None else None
        par = ca.MX.sym("par", S.par.size)  # element parameters (StepSystem.par)
        return st, (q, v, a, ab, ap, lam, ctl), h, hp, tols, pload, kel, par

    def _step_common(self, q, v, a, ab, ap, h, hp, pload, kel):
        """Predictor, constant part of the residual and the corrector of a step (MX)."""
        S, sc = self.S, self.scheme
        nf = S.nf
        b, g, am, af = sc.beta, sc.gamma, sc.alpha_m, sc.alpha_f
        # (each MX node costs a virtual-machine instruction: shared subexpressions are built once, constant
        # factors folded in Python)
        hh = h * h
        bhh = b * hh
        qh = q + h * v + ((0.5 - b) * hh) * ab
        vh = v + (h * (1 - g)) * ab
        cm = ((1 - am) / (1 - af)) / bhh
        cc = g / (b * h)
        kc = cm * S.stiffness_scale()
        vc = vh - cc * qh
        Cvh, _ = S.damping_mx(vc, kel)
        # a_n+1 = ((1 - am) ab_n+1 + am ab - af a) / (1 - af) = cm (x - qh) + k0, with x = qh + (b h^2) ab_n+1
        k0 = (am / (1 - af)) * ab - (af / (1 - af)) * a
        y = k0 - cm * qh  # the residual's inertia is M (cm x + y): no product with M here
        p = Cvh + pload if not S.nw else ca.vertcat(Cvh + pload[:nf], pload[nf:])
        apred = a + ca.if_else(hp > 0, (a - ap) * (h / ca.fmax(hp, 1e-300)), ca.MX.zeros(nf))
        x0 = qh + (bhh / (1 - am)) * ((1 - af) * apred + af * a - am * ab)
        err_c = sc.error_constant()

        def lte(x):
            return (err_c * hh) * ca.mmax(ca.fabs(cm * (x - qh) + k0 - a))

        def block(x):  # q, v, a, ab of the new state and a_prev
            d = x - qh
            ab1 = d / bhh
            return ca.vertcat(x, vh + (h * g) * ab1, cm * d + k0, ab1, a)

        return dict(x0=x0, p=p, y=y, cm=cm, cc=cc, kc=kc, vc=vc, lte=lte, block=block)

    def _full_control_functions(self) -> tuple[ca.Function, ca.Function]:
        """The full-Newton step's scalar logic as two SX functions (before and after the second iteration)."""
        o, tiny = self.opts, 1e-300
        sx = ca.SX.sym
        C, N0, L, T = sx("ctl", 2), sx("n0", 5), sx("lte"), sx("tols", 2)
        om, since = C[0], C[1]
        d0 = ca.fmax(N0[2], N0[3])
        tolx = ca.fmax(T[1], o.lte_fraction * L)
        tq = ca.fmax(T[0], 2 * np.finfo(float).eps * N0[4] * self.S.span)
        conv0 = ca.logic_and(N0[0] <= tq, N0[1] <= T[1])
        est1 = 2 * om * d0 * d0
        # omega is re-measured (second iteration) at least every refresh_every steps, up to 8x less often when the
        # estimate has a wide margin
        fresh = since < self.refresh_every * ca.fmin(8, ca.fmax(1, 0.1 * tolx / ca.fmax(est1, tiny)))
        conv1 = ca.logic_and(ca.logic_and(om > 0, fresh), est1 <= tolx)
        accept1 = ca.logic_or(conv0, conv1) if o.single else ca.SX(0)
        first = ca.Function("after_first", [C, N0, L, T], [ca.vertcat(ca.if_else(accept1, 0, 1), tq, tolx, d0)])
        A, N1 = sx("a", 4), sx("n1", 5)
        second, tq, tolx, d0 = A[0], A[1], A[2], A[3]
        accept1 = second == 0
        d1 = ca.fmax(N1[2], N1[3])
        th = d1 / ca.fmax(d0, tiny)
        conv2 = ca.logic_or(ca.logic_and(N1[0] <= tq, N1[1] <= T[1]), d1 <= 0.1 * tolx)
        conv2 = ca.logic_or(conv2, ca.logic_and(th < 0.5, th / (1 - th) * d1 <= tolx))
        ok = ca.if_else(accept1, 1, conv2)
        om_new = ca.if_else(accept1, om, ca.if_else(d0 > 0, ca.fmax(d1 / ca.fmax(d0 * d0, tiny), 0.5 * om), om))
        since_new = ca.if_else(accept1, since + 1, 0)
        iters = ca.if_else(accept1, 1, 2)
        final = ca.Function("controls", [C, N0, A, N1, L, T],
                            [ca.vertcat(om_new, since_new), ca.vertcat(ok, iters, iters, d0, d1, L, N0[4])])
        return first, final

    def _later_control_function(self) -> ca.Function:
        """Convergence after a third or later full Newton iteration (the criteria and tolerances of `newton`, which
        took these steps before): (ok, iterations, last |dz|) updated by the norms of the iteration (zeros if
        skipped)."""
        sx, tiny = ca.SX.sym, 1e-300
        V, N, A, T = sx("lv", 3), sx("n", 5), sx("a", 4), sx("tols", 2)
        ok, iters, d_prev = V[0], V[1], V[2]
        tq, tolx = A[1], T[1]  # (the absolute update tolerance, as `newton`: a hard step converges fully)
        ran = ok == 0
        d = ca.fmax(N[2], N[3])
        th = d / ca.fmax(d_prev, tiny)
        conv = ca.logic_or(ca.logic_or(ca.logic_and(N[0] <= tq, N[1] <= T[1]), d <= 0.1 * tolx),
                           ca.logic_and(th < 0.5, th / (1 - th) * d <= tolx))
        return ca.Function("after_later", [V, N, A, T], [ca.vertcat(ca.logic_or(ok, ca.logic_and(ran, conv)),
                                                                    iters + ran, ca.if_else(ran, d, d_prev))])

    def _build_full(self, extra_iterations: int) -> ca.Function:
        """Full Newton: one iteration, then (in-graph switch) either acceptance or a second iteration, and up to
        extra_iterations more while not converged."""
        S = self.S
        nf, mc = S.nf, S.mc
        st, (q, v, a, ab, ap, lam, ctl), h, hp, tols, pload, kel, par = self._step_inputs()
        c = self._step_common(q, v, a, ab, ap, h, hp, pload, kel)
        x0, p, cm, cc, kc, vc, y = c["x0"], c["p"], c["cm"], c["cc"], c["kc"], c["vc"], c["y"]
        l0 = lam / kc
        extra = [kel] if kel is not None else []
        dz, n0 = S.iter_f(x0, l0, p, cm, cc, kc, vc, *extra, y, par)
        x1 = x0 + dz[:nf]
        l1 = l0 + dz[nf:] if mc else l0
        lte = c["lte"](x1)
        first, final = self._full_control_functions()
        a1 = first(ctl, n0, lte, tols)
        # second iteration, evaluated only when needed
        xb, lb, pb = ca.MX.sym("xb", nf), ca.MX.sym("lb", mc), ca.MX.sym("pb", nf + S.nw)
        cb, ccb, kb, vb = ca.MX.sym("cmb"), ca.MX.sym("ccb"), ca.MX.sym("kcb"), ca.MX.sym("vcb", nf)
        eb = [ca.MX.sym("kelb", S.kel.size)] if kel is not None else []
        yb, parb = ca.MX.sym("yb", nf), ca.MX.sym("parb", S.par.size)
        dzb, nb = S.iter_f(xb, lb, pb, cb, ccb, kb, vb, *eb, yb, parb)
        f_keep = ca.Function("keep", [xb, lb, pb, cb, ccb, kb, vb] + eb + [yb, parb], [xb, lb, ca.DM.zeros(5)])
        f_iter = ca.Function("second", [xb, lb, pb, cb, ccb, kb, vb] + eb + [yb, parb],
                             [xb + dzb[:nf], (lb + dzb[nf:]) if mc else lb, nb])
        switch = ca.Function.conditional("second_iteration", [f_keep], f_iter)
        # further iterations while not converged after the second (hard transients: the step stays in the graph,
        # and a chunk goes on): a switch inside the second iteration's branch, so that the steps accepted after one
        # iteration (most of them) pay nothing for it; m = (ran, ok, iterations) of the further iterations
        n_more = max(0, min(extra_iterations, self.opts.max_iter - 2))
        if n_more:
            later = self._later_control_function()
            cb_, n0b, a1b, lteb, tb = ca.MX.sym("ctl", 2), ca.MX.sym("n0", 5), ca.MX.sym("a1", 4), ca.MX.sym("lte"), \
                ca.MX.sym("tols", 2)
            lvb = ca.MX.sym("lv", 3)
            iter_ins = [xb, lb, pb, cb, ccb, kb, vb] + eb + [yb, parb]
            # one further iteration on z = (x, lam, (ok, iterations, last |dz|)), folded n_more times (one graph
            # to build, not n_more)
            xk, lk, nk = switch(lvb[0] == 0, xb, lb, pb, cb, ccb, kb, vb, *eb, yb, parb)
            zb = ca.vertcat(xb, lb, lvb)
            others = [a1b, tb, pb, cb, ccb, kb, vb] + eb + [yb, parb]
            one = ca.Function("further_iteration", [zb] + others, [ca.vertcat(xk, lk, later(lvb, nk, a1b, tb))])
            zin = ca.MX.sym("z", zb.numel())
            folded = one.fold(n_more)(zin, *[ca.repmat(o, 1, n_more) for o in others])
            more = ca.Function.conditional("further_iterations", [ca.Function("done", [zin] + others, [zin])],
                                           ca.Function("more", [zin] + others, [folded]))
            x2b, l2b, n1b = f_iter(*iter_ins)
            info2 = final(cb_, n0b, a1b, n1b, lteb, tb)[1]
            lv2 = ca.vertcat(info2[0], info2[1], ca.fmax(n1b[2], n1b[3]))
            z3 = more(lv2[0] == 0, ca.vertcat(x2b, l2b, lv2), *others)
            x3, l3, lv3 = z3[:nf], z3[nf:nf + mc], z3[nf + mc:]
            br_ins = iter_ins + [cb_, n0b, a1b, lteb, tb]
            f_keep = ca.Function("keep", br_ins, [xb, lb, ca.DM.zeros(5), ca.DM.zeros(3)])
            f_iter = ca.Function("second", br_ins, [x3, l3, n1b, ca.vertcat(lv2[0] == 0, lv3[0], lv3[1])])
            x2, l2, n1, m = ca.Function.conditional("second_iteration_on", [f_keep], f_iter)(
                a1[0], x1, l1, p, cm, cc, kc, vc, *extra, y, par, ctl, n0, a1, lte, tols)
        else:
            x2, l2, n1 = switch(a1[0], x1, l1, p, cm, cc, kc, vc, *extra, y, par)
            m = ca.DM.zeros(3)
        ctl_new, info = final(ctl, n0, a1, n1, lte, tols)
        ok, iters = ca.if_else(m[0], m[1], info[0]), ca.if_else(m[0], m[2], info[1])
        info = ca.vertcat(ok, iters, iters, info[3:])
        new_state = ca.vertcat(c["block"](x2), l2 * kc, ctl_new)
        return self._make_step_f([st], [h, hp, pload, tols] + extra + [par], [new_state], info)

    # carried control vector of the modified step (SX functions between the iterations)
    _CV = ("conv", "tolx", "tq", "kmax", "iters", "nfull", "since_full", "d_prev", "last_full", "th", "mode",
           "d1", "th1", "conv0", "refac0", "d0", "th0", "lte1")

    def _control_functions(self) -> dict:
        """The modified step's scalar logic as SX functions (a few calls instead of hundreds of MX nodes)."""
        o = self.opts
        KEEP, MOD, FULL = 0, 1, 2
        cmax, R, tiny = o.contraction, self.refactor_cost, 1e-300
        sx = ca.SX.sym
        C, hs, T = sx("ctl", self.nctl), sx("h"), sx("tols", 2)
        om, since, rate, age, fh, kmax, d0p, tolxp, ltep, cyc = (C[k] for k in range(self.nctl))
        fresh = since < self.refresh_every
        known = rate >= 0
        idx = {k: i for i, k in enumerate(self._CV)}
        # before the first iteration: on the kept factor, or refactorise (no factor for this step size, contraction
        # too slow, or the iterations predicted on the kept factor cost more than a refactorisation's cycle does
        # per step: renewal rule, m0 > cyc / age)
        th0 = ca.fmax(rate, 0) * age
        # (an iteration on the kept factor is accepted only after the next one measured its contraction)
        m0 = 1 + ca.fmax(1, ca.ceil(ca.log(ca.fmax(tolxp * (1 - th0), tiny) / ca.fmax(d0p, tiny)) /
                                    ca.log(ca.fmin(ca.fmax(th0, tiny), 0.999))))
        costly = ca.logic_and(ca.logic_and(known, d0p > 0), m0 * age > cyc)
        refac0 = ca.logic_or(ca.logic_not(ca.logic_and(fh > 0, ca.fabs(fh - hs) <= 1e-9 * hs)),
                             ca.logic_and(known, ca.logic_or(th0 >= cmax, costly)))
        decide = ca.Function("decide", [C, hs], [ca.vertcat(ca.if_else(refac0, FULL, MOD), th0)])
        # after the first iteration
        N, L1, M0, TH0 = sx("n", 3), sx("lte1"), sx("mode0"), sx("th0")
        rq0, d0 = N[0], N[1]
        ref0 = M0 == FULL
        kmax1 = ca.if_else(ref0, N[2], kmax)
        lte_use = ca.if_else(ltep > 0, ca.fmin(L1, 2 * ltep), L1)  # x1 may be off by the tolerance
        tolx = ca.fmax(T[1], o.lte_fraction * lte_use)
        tq = ca.fmax(T[0], 2 * np.finfo(float).eps * kmax1 * self.S.span)
        ok_full = ca.logic_and(ref0, ca.logic_or(d0 <= 0.1 * tolx, ca.logic_and(ca.logic_and(om > 0, fresh),
                                                                                2 * om * d0 * d0 <= tolx)))
        conv = ca.logic_or(rq0 <= tq, ok_full) if o.single else ca.SX(0)
        vals = dict(conv=conv, tolx=tolx, tq=tq, kmax=kmax1, iters=1, nfull=ref0, since_full=0, d_prev=d0,
                    last_full=ref0, th=0, mode=ca.if_else(conv, KEEP, MOD), d1=0, th1=0, conv0=conv, refac0=ref0,
                    d0=d0, th0=TH0, lte1=L1)
        first = ca.Function("after_first", [C, N, L1, T, M0, TH0], [ca.vertcat(*[vals[k] for k in self._CV])])
        # after a further iteration: keep when converged; after a refactorisation the new factor; else refactorise
        # when the kept factor contracted too slowly (theta measured in this step)
        CV, Nk = sx("cv", len(self._CV)), sx("n", 3)
        cv = {k: CV[i] for k, i in idx.items()}
        ran, is_full = cv["mode"] != KEEP, cv["mode"] == FULL
        rq, d = Nk[0], Nk[1]
        th = ca.if_else(ran, d / ca.fmax(cv["d_prev"], tiny), 0)
        conv_k = ca.logic_or(ca.logic_or(rq <= cv["tq"], d <= 0.1 * cv["tolx"]),
                             ca.logic_and(th < 0.5, th / (1 - th) * d <= cv["tolx"]))
        new = dict(cv)
        new["conv"] = ca.logic_or(cv["conv"], ca.logic_and(ran, conv_k))
        new["iters"] = cv["iters"] + ran
        new["nfull"] = cv["nfull"] + is_full
        new["since_full"] = ca.if_else(is_full, 0, cv["since_full"] + ran)
        new["kmax"] = ca.if_else(is_full, Nk[2], cv["kmax"])
        new["d_prev"] = ca.if_else(ran, d, cv["d_prev"])
        new["last_full"] = ca.if_else(ran, is_full, cv["last_full"])
        new["th"] = th
        bad = ca.logic_and(ca.logic_not(new["last_full"]), th > cmax)
        new["mode"] = ca.if_else(new["conv"], KEEP, ca.if_else(bad, FULL, MOD))
        later = ca.Function("after_later", [CV, Nk], [ca.vertcat(*[new[k] for k in self._CV])])
        new1 = dict(new, d1=d, th1=th)
        second = ca.Function("after_second", [CV, Nk], [ca.vertcat(*[new1[k] for k in self._CV])])
        # controls for the next step
        L2 = sx("lte")
        two = ca.logic_not(cv["conv0"])  # a second iteration ran: the estimates were measured
        # contraction per step of factor age, measured when the step started on the kept factor (age >= 1);
        # it rises at once and decays slowly (one lucky measurement must not make the next steps optimistic)
        meas = cv["th1"] / ca.fmax(age, 1)
        rate_new = ca.if_else(ca.logic_and(two, ca.logic_not(cv["refac0"])),
                              ca.if_else(known, ca.fmax(meas, 0.7 * rate), meas), rate)
        om_new = ca.if_else(ca.logic_and(two, cv["refac0"]),
                            ca.if_else(cv["d0"] > 0, ca.fmax(cv["d1"] / ca.fmax(cv["d0"] ** 2, tiny), 0.5 * om), om),
                            om)
        any_full = cv["nfull"] > 0
        ctl_new = ca.vertcat(om_new, ca.if_else(two, 0, since + 1), rate_new, ca.if_else(any_full, 1, age + 1),
                             ca.if_else(any_full, hs, fh), cv["kmax"], cv["d0"], cv["tolx"], L2,
                             ca.if_else(any_full, R + cv["since_full"], cyc + cv["iters"]))
        info = ca.vertcat(cv["conv"], cv["iters"], cv["nfull"], cv["d0"], cv["d1"], cv["lte1"], cv["kmax"])
        final = ca.Function("controls", [C, CV, L2, hs], [ctl_new, info])
        return dict(decide=decide, first=first, second=second, later=later, final=final, mode=idx["mode"])

    def _build_modified(self) -> ca.Function:
        """Modified Newton with the LDL^T factor as accumulated inputs (see the class docstring)."""
        S = self.S
        nf = S.nf
        nD, nU, nUT = S.factor_size
        st, (q, v, a, ab, ap, lam, ctl), h, hp, tols, pload, kel, par = self._step_inputs()
        D0, U0, UT0 = ca.MX.sym("D", nD), ca.MX.sym("U", nU), ca.MX.sym("UT", nUT)
        c = self._step_common(q, v, a, ab, ap, h, hp, pload, kel)
        x0, p, cm, cc, vc, y = c["x0"], c["p"], c["cm"], c["cc"], c["vc"], c["y"]
        extra = [kel] if kel is not None else []
        # one Newton iteration of each kind, with the same signature: keep (converged), kept factor, refactorise
        xs, Ds, Us, UTs = ca.MX.sym("x", nf), ca.MX.sym("D", nD), ca.MX.sym("U", nU), ca.MX.sym("UT", nUT)
        ps, cms, ccs, vcs = ca.MX.sym("p", nf + S.nw), ca.MX.sym("cm"), ca.MX.sym("cc"), ca.MX.sym("vc", nf)
        ks = [ca.MX.sym("kel", S.kel.size)] if kel is not None else []
        ys, pars = ca.MX.sym("y", nf), ca.MX.sym("par", S.par.size)
        args = [xs, Ds, Us, UTs, ps, cms, ccs, vcs] + ks + [ys, pars]
        none = ca.MX(0, 1)
        r, nr = S.res_f(xs, none, ps, cms, ccs, 1.0, vcs, *ks, ys, pars)
        dz = -S.ldl_solve_mx(Ds, Us, UTs, r)
        f_mod = ca.Function("kept_factor", args, [xs + dz, Ds, Us, UTs, ca.vertcat(nr[0], ca.mmax(ca.fabs(dz)), 0)])
        r, nj, knz = S.jac_f(xs, none, ps, cms, ccs, 1.0, vcs, *ks, ys, pars)
        D2, U2, UT2 = S.fact_f(knz)
        dz = -S.ldl_solve_mx(D2, U2, UT2, r)
        f_full = ca.Function("refactorise", args,
                             [xs + dz, D2, U2, UT2, ca.vertcat(nj[0], ca.mmax(ca.fabs(dz)), nj[2])])
        f_keep = ca.Function("keep", args, [xs, Ds, Us, UTs, ca.DM.zeros(3)])
        slot = ca.Function.conditional("newton_iteration", [f_keep, f_mod], f_full)  # 0 keep, 1 kept, 2 refactorise
        cf = self._control_functions()
        dm = cf["decide"](ctl, h)
        mode0, th0 = dm[0], dm[1]
        x, Dk, Uk, UTk, n = slot(mode0, x0, D0, U0, UT0, p, cm, cc, vc, *extra, y, par)
        cv = cf["first"](ctl, n, c["lte"](x), tols, mode0, th0)
        for k in range(1, self.max_slots):
            x, Dk, Uk, UTk, n = slot(cv[cf["mode"]], x, Dk, Uk, UTk, p, cm, cc, vc, *extra, y, par)
            cv = (cf["second"] if k == 1 else cf["later"])(cv, n)
        ctl_new, info = cf["final"](ctl, cv, c["lte"](x), h)
        new_state = ca.vertcat(c["block"](x), lam, ctl_new)
        return self._make_step_f([st, D0, U0, UT0], [h, hp, pload, tols] + extra + [par], [new_state, Dk, Uk, UTk],
                                 info)

    def _make_step_f(self, accum_in, other_in, accum_out, info) -> ca.Function:
        names = ["state", "D", "U", "UT"][:len(accum_in)] + ["h", "h_prev", "pload", "tols"] + \
            (["kel"] if len(other_in) == 6 else []) + ["par"]
        return ca.Function("alpha_step", accum_in + other_in, accum_out + [info], names,
                           ["next_" + nm for nm in names[:len(accum_out)]] + ["info"])

    def _setup_step_buffers(self) -> None:
        S, nf = self.S, self.S.nf
        self._s_in, self._s_out, self._info = np.zeros(self.state_size), np.zeros(self.state_size), \
            np.zeros(self.info_size)
        self._f_out = [np.zeros(k) for k in self.fac_sizes]
        self._h, self._hp, self._pload, self._tols = np.zeros(1), np.zeros(1), np.zeros(nf + S.nw), np.zeros(2)
        args = [self._s_in] + self.fac + [self._h, self._hp, self._pload, self._tols] + \
            ([S.kel] if S.kel is not None else []) + [S.par]
        outs = [self._s_out] + self._f_out + [self._info]
        buf, ev = _pooled_buffer(self._graphs, "step", self.step_f, self)
        for i, arr in enumerate(args):
            buf.set_arg(i, memoryview(arr))
        for i, arr in enumerate(outs):
            buf.set_res(i, memoryview(arr))
        self._step = (buf, ev, args, outs)

    # -- state ------------------------------------------------------------------------------------------------
    def initialize(self, q0: np.ndarray, v0: np.ndarray, Q0: np.ndarray, t0: float = 0.0) -> None:
        self.q[:] = q0
        self.v[:] = v0
        self.kdamp.update(self.q)
        a, lam = initial_acceleration(self.S, q0, v0, Q0, self.kdamp.matrix(), t0)
        self.a[:], self.lam[:] = a, lam
        self.ab[:] = self.a
        self.a_prev[:] = self.a
        self.h_prev = None
        self._reset_controls()

    @property
    def chunkable(self) -> bool:
        """The whole step is in the graph (no Python per step): no stiffness damping update, and not the Python
        modified-Newton loop."""
        return (self.modified_graph or not self.opts.modified) and not self.kdamp.active

    # -- one step ---------------------------------------------------------------------------------------------
    def attempt(self, t: float, h: float, loads=None) -> StepOutcome:
        """Try the step t -> t + h (loads(t): time-dependent generalized force on the unknowns, or None).
        The candidate is in self.new; accept() commits it."""
        S = self.S
        pload = -S.f_lin if loads is None else -(S.f_lin + loads(t + h))
        if S.nw:
            pload = np.r_[pload, S.w(t + h)]
        self._h_try = h
        python_newton = self.opts
        if self.modified_graph or not self.opts.modified:
            self._s_in[:] = self.pack()
            self._h[0] = h
            self._hp[0] = self.h_prev if self.h_prev else 0.0
            self._pload[:] = pload
            self._tols[:] = self.tol_q, self.tol_x
            self._step[1]()
            info = self._info
            k = self._count(info)
            finite = np.all(np.isfinite(self._s_out))
            if info[0] == 1 and finite and all(np.all(np.isfinite(f)) for f in self._f_out):
                u = self.unpack(self._s_out)
                for key in ("q", "v", "a", "ab", "lam"):
                    self.new[key][:] = u[key]
                self._new_ctl[:] = u["ctl"]
                for dst, src in zip(self._new_fac, self._f_out):
                    dst[:] = src
                return StepOutcome(True, k, "", True)
            # the graph did not converge: full Newton in Python, from the graph's last iterate if finite
            python_newton = NewtonOptions(**{**self.opts.__dict__, "modified": False})
            kc = self.scheme.cm(h) * S.stiffness_scale()
            if finite:
                u = self.unpack(self._s_out)
                S.x[:], S.lam[:] = u["q"], u["lam"] / kc
                S.p[:] = self._predict(h, pload, kc)[2]
                it0 = k
            else:
                S.x[:], S.lam[:], S.p[:] = self._predict(h, pload, kc)
                it0 = 0
        else:
            S.x[:], S.lam[:], S.p[:] = self._predict(h, pload, self.scheme.cm(h) * S.stiffness_scale())
            it0 = 0
        sc = self.scheme
        kc = sc.cm(h) * S.stiffness_scale()
        S.cm[0], S.cc[0], S.kc[0] = sc.cm(h), sc.cc(h), kc
        out = newton(S, self.factor, (h, kc), python_newton, self.counters, self.tol_q, self.tol_x, it0)
        if not out.converged:
            return StepOutcome(False, out.iterations, out.reason)
        self._correct(h, S.x, S.lam * kc)
        # controls after a Python step: estimates to be re-measured; the kept factor (modified) one step older
        self._new_ctl[:] = self.ctl
        self._new_ctl[1] = 0.0
        if self.modified_graph:
            self._new_ctl[3] += 1  # factor age
            self._new_ctl[6] = 0.0  # |dz0| of this step unknown: no one-iteration acceptance next
        for dst, src in zip(self._new_fac, self.fac):
            dst[:] = src
        return StepOutcome(True, out.iterations)

    def _count(self, info: np.ndarray) -> int:
        c = self.counters
        k, f = int(info[1]), int(info[2])
        c.residuals += k
        c.jacobians += f
        c.factorizations += f
        c.newton_iterations += k
        return k

    def _predict(self, h, pload, kc):
        sc, S = self.scheme, self.S
        b, g, am, af = sc.beta, sc.gamma, sc.alpha_m, sc.alpha_f
        qh = self.q + h * self.v + h * h * (0.5 - b) * self.ab
        vh = self.v + h * (1 - g) * self.ab
        cm, cc = sc.cm(h), sc.cc(h)
        p = pload.copy()
        p[:S.nf] += S.M @ ((am * self.ab - af * self.a) / (1 - af) - cm * qh)
        C = self.kdamp.matrix()
        if C is not None:
            p[:S.nf] += C @ (vh - cc * qh)
        ap = self.a + ((self.a - self.a_prev) * h / self.h_prev if self.h_prev else 0.0)
        x = qh + b * h * h * ((1 - af) * ap + af * self.a - am * self.ab) / (1 - am)
        S.vc[:] = vh - cc * qh
        return x, self.lam / kc, p

    def _correct(self, h, x, lam_true):
        sc = self.scheme
        b, g, am, af = sc.beta, sc.gamma, sc.alpha_m, sc.alpha_f
        qh = self.q + h * self.v + h * h * (0.5 - b) * self.ab
        vh = self.v + h * (1 - g) * self.ab
        ab1 = (x - qh) / (b * h * h)
        self.new["q"][:] = x
        self.new["lam"][:] = lam_true
        self.new["ab"][:] = ab1
        self.new["a"][:] = ((1 - am) * ab1 + am * self.ab - af * self.a) / (1 - af)
        self.new["v"][:] = vh + h * g * ab1

    def error_estimate(self, h: float) -> np.ndarray:
        """Local displacement error of the candidate, |beta - 1/6| h^2 (a_{n+1} - a_n) (Zienkiewicz-Xie)."""
        return self.scheme.error_constant() * h * h * (self.new["a"] - self.a)

    def accept(self) -> None:
        self.a_prev[:] = self.a
        for k in ("q", "v", "a", "ab", "lam"):
            getattr(self, k)[:] = self.new[k]
        self.ctl[:] = self._new_ctl
        for dst, src in zip(self.fac, self._new_fac):
            dst[:] = src
        self.h_prev = self._h_try
        self.kdamp.update(self.q)

    # -- many steps in one call -------------------------------------------------------------------------------
    def guarded_step(self) -> ca.Function:
        """The step with a 'failed' flag appended to its state: a step the graph cannot accept (not converged, or a
        non-finite state) sets the flag, and every later step of the chunk is a no-op that passes the state on
        (a switch that evaluates only the branch taken), so a chunk costs the steps it accepts plus one."""
        f = self.step_f
        if not self.modified_graph and self.state_size < UNROLL_STATE:  # (the step with iterations 3-6)
            f = self._graphs.setdefault("step_more", None) or self._build_full(self.extra_iterations)
            self._graphs["step_more"] = f
        ins = [ca.MX.sym(f.name_in(i), f.sparsity_in(i)) for i in range(f.n_in())]
        st = ca.MX.sym("state", self.state_size + 1)
        outs = f(st[:self.state_size], *ins[1:])
        new, info = outs[0], outs[-1]
        finite = ca.fabs(ca.sum1(ca.vertcat(new, *outs[1:-1]))) < np.inf  # (false for NaN and inf)
        failed = ca.logic_not(ca.logic_and(info[0] == 1, finite))
        info = ca.vertcat(ca.logic_not(failed), info[1:])  # ok = converged and finite
        names = (["state"] + [f.name_in(i) for i in range(1, f.n_in())],
                 ["next_state"] + [f.name_out(i) for i in range(1, f.n_out())])
        run = ca.Function("step", [st] + ins[1:], [ca.vertcat(new, failed)] + list(outs[1:-1]) + [info])
        keep = ca.Function("skip", [st] + ins[1:], [st] + ins[1:self.n_accum] + [ca.DM.zeros(self.info_size)])
        g = ca.Function.conditional("guarded_step", [run], keep)  # flag 0: the step; 1: no-op
        return ca.Function("alpha_step_guarded", [st] + ins[1:], g(st[-1], st, *ins[1:]), *names)

    @property
    def guard(self) -> bool:
        """Chunks with the no-op guard after a failed step: on large states (the guard's switch costs nothing
        against a step there), and on any state after a chunk has failed early (a hard transient: the steps after
        a failure would be thrown away). Small states start without: the switch costs ~5 % of a 130-unknown step."""
        return self._guard_on or self.state_size >= UNROLL_STATE

    def chunk_function(self, n: int, guard: bool | None = None):
        guard = self.guard if guard is None else guard
        if (n, guard) not in self._chunks:
            g = self._graphs
            if guard and "guarded" not in g:
                g["guarded"] = self.guarded_step()
            if (n, guard) not in g["chunks"]:  # (without the guard: the step itself over the steps)
                g["chunks"][n, guard] = _map_steps(g["guarded"] if guard else self.step_f, n, self.n_accum)
            f = g["chunks"][n, guard]
            buf, ev = _pooled_buffer(g, (n, guard), f, self)
            nf = self.S.nf
            ns = self.state_size + guard
            bufs = dict(s=np.zeros(ns), h=np.zeros(n), hp=np.zeros(n), pload=np.zeros((nf + self.S.nw) * n),
                        tols=np.zeros(2 * n), out=np.zeros(ns * n), info=np.zeros(self.info_size * n),
                        fac_out=[np.zeros(k * n) for k in self.fac_sizes], guard=guard)
            S = self.S
            args = [bufs["s"]] + self.fac + [bufs["h"], bufs["hp"], bufs["pload"], bufs["tols"]] + \
                ([np.tile(S.kel, n)] if S.kel is not None else []) + [np.tile(S.par, n)]
            bufs["fixed"] = args[-1 - (S.kel is not None):]  # (kept alive: the buffer holds their memory)
            outs = [bufs["out"]] + bufs["fac_out"] + [bufs["info"]]
            for i, arr in enumerate(args):
                buf.set_arg(i, memoryview(arr))
            for i, arr in enumerate(outs):
                buf.set_res(i, memoryview(arr))
            self._chunks[n, guard] = (buf, ev, bufs)
        return self._chunks[n, guard]

    def run_chunk(self, h: float, ploads: np.ndarray) -> tuple[np.ndarray, int]:
        """Up to n = ploads.shape[1] steps of size h in one call (no time-dependent C). Returns the states after
        each accepted step (n_ok x state_size) and n_ok: the steps before the first one the graph could not
        converge (that step is then left to `attempt`). The integrator's state is advanced to the last of them."""
        n = ploads.shape[1]
        buf, ev, b = self.chunk_function(n)
        ns = self.state_size
        if b["guard"]:
            b["s"][:-1] = self.pack()
            b["s"][-1] = 0.0  # not failed
        else:
            b["s"][:] = self.pack()
        b["h"][:] = h  # (mapaccum maps every input but the state over the steps)
        b["hp"][:] = h
        b["hp"][0] = self.h_prev if self.h_prev else 0.0
        if ploads is not b.get("pload_from"):  # (a constant load array is copied in once)
            b["pload"][:] = ploads.ravel(order="F")
            b["pload_from"] = ploads if not ploads.flags.writeable else None
        b["tols"][0::2], b["tols"][1::2] = self.tol_q, self.tol_x
        ev()
        info = b["info"].reshape(n, self.info_size)
        states = b["out"].reshape(n, ns + b["guard"])[:, :ns]
        good = info[:, 0] == 1  # (guarded: the failed flag, set at the first unconverged or non-finite step)
        if not b["guard"]:
            good &= np.isfinite(states).all(axis=1)
        n_ok = n if good.all() else int(np.argmin(good))
        # the failing step's work was spent too (and without the guard, the later steps' work)
        self._count(np.nan_to_num(info[:min(n_ok + 1, n) if b["guard"] else n], posinf=0, neginf=0).sum(axis=0))
        if n_ok < n - 1:
            self._guard_on = True  # a hard transient: the next chunks stop at their failing step
        if n_ok:
            self.a_prev[:] = states[n_ok - 2, 2 * self.S.nf:3 * self.S.nf] if n_ok > 1 else self.a
            u = self.unpack(states[n_ok - 1])
            for k in ("q", "v", "a", "ab", "lam"):
                getattr(self, k)[:] = u[k]
            self.ctl[:] = u["ctl"]
            for dst, src, k in zip(self.fac, b["fac_out"], self.fac_sizes):
                dst[:] = src[(n_ok - 1) * k:n_ok * k]
            self.h_prev = h
        return states[:n_ok], n_ok
