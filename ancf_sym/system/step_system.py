"""A scene's equations of motion on its reduced coordinates, as compiled CasADi Functions: forces, tangent,
constraints and the sparse factorisation of one Newton iteration of an implicit step.

Equations of motion with exact constraints (index 3):

    M a + C v + grad U(q) + J(q)^T lam = Q(t),    Phi(q) = 0

U is the scene's total potential (strain energies, gravity, dead loads, penalty joints); C is Rayleigh damping
and/or the strain-rate damping force f_d(q, v) (ancf_sym.system.damping). Supports that fix single coordinates
are eliminated and hinges identify coordinates (ancf_sym.model.reduced); the remaining exact rows (rigid joints, skew
clamps) carry Lagrange multipliers.

One full Newton iteration is one call of a CasADi Function: every energy term through its mapped compiled kernel,
residual and KKT matrix assembled by constant index maps (gathers), sparse LDL^T (symmetric positive definite
case) or QR (multipliers, strain-rate damping) factorisation and solve, all inside CasADi: no Python loop over
elements, no numpy scatter. Residuals alone use the kernels' (energy, gradient) companions (no Hessian work).
The graphs are cached by scene structure (ancf_sym.system.graph_cache).
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym.contact import laws as contact
from ancf_sym.bodies import drives
from ancf_sym.util import setup_cache
from ancf_sym.model.assembly import Assembly, force_term_calls, force_terms_of
from ancf_sym.util.casadi_buffers import bind
from ancf_sym.model.reduced import ReducedModel, full_mx, partition, reduce_shared
from ancf_sym.util.sparsity import dm, hessian_entries, kron_factor_dm, kron_product_mx, mx_nonzeros
from ancf_sym.system import band, damping
from ancf_sym.system.band import BandLayout, band_layout_csc
from ancf_sym.system.damping import RayleighData, StrainRateData
from ancf_sym.system.forces import ForceGraphs, band_force_graph, build_force_graphs, gradient_graph
from ancf_sym.system.graph_cache import STEP_TEMPLATES, SYSTEM_GRAPHS, keep_template, pooled_buffer, structure_id
from ancf_sym.system.ldl import LDLFactor, build_ldl
from ancf_sym.util.mx_ops import add, fabs, mul, neg
from ancf_sym.system import water


class StepSystem(ReducedModel):
    """A scene's equations of motion on its free coordinates, as compiled CasADi Functions.

    forces(x) -> (g, K[, kel]): gradient and Hessian of the potential (nonlinear terms and penalty joints; the
    constant forces of linear terms such as gravity are in f_lin), and the elastic tangent values for Rayleigh
    stiffness damping. Every term is one mapped compiled kernel call; assembly by constant index gathers
    (ancf_sym.system.forces).

    For a step with unknown x = q_{n+1} (and scaled multipliers lam, lam_true = kc lam):
        r = [cm M x + cc C x + g(x) + kc J^T lam + p ; kc Phi(x)]
        KKT = [[cm M + cc C + K(x) + H_Phi(kc lam), kc J^T], [kc J, 0]]
    p collects what is constant within a step. C = alpha M + beta K_el(q_n) with K_el(q_n) passed as `kel`.
    `iterate` does a whole full-Newton iteration (residual, KKT, sparse LDL^T factorisation, solve) in one call;
    `residual` (gradient-only kernels) and `jacobian` serve modified Newton with a factorisation kept in Python;
    `ensure_factor` builds the in-graph LDL^T factorisation of the compiled modified step.
    """

    def __init__(self, asm: Assembly, rayleigh: RayleighData | None = None, linsol: str = "auto",
                 strain_rate: StrainRateData | None = None, fuse: bool = True):
        self.asm = asm
        self.fuse = fuse  # axial + bending of a cable in one kernel call (False: one call per term, for tests)
        self.strain_rate = strain_rate
        self.rayleigh = rayleigh if (rayleigh is not None and (rayleigh.alpha or rayleigh.beta)) else None
        # the structure (what reads no element stiffness and no gravity) of an earlier system of a scene that differs
        # only in those (ancf_sym.scene.structure_spec_key) and has the same damping and options; else built here
        key = None if asm.spec_key is None else \
            (asm.spec_key, setup_cache.array_key(self.rayleigh, strain_rate, linsol, fuse))
        template = STEP_TEMPLATES.get(key) if key is not None else None
        if template is not None:
            self.__dict__.update(template)
        else:
            self._structure(asm, linsol)
        self._values(asm)
        if template is None:
            self.graph_key = structure_id(self)
            if key is not None:
                keep_template(key, {k: self.__dict__[k] for k in self._STRUCTURE_ATTRS})
        graphs = SYSTEM_GRAPHS.get(self.graph_key)
        if graphs is None:
            self._graphs = graphs = {}
            # the band path (ancf_sym.system.band) has a force graph of its own: forces_pf only on first use
            layout = self._band_layout()
            fg = build_force_graphs(self, forces=layout is None)
            self._keep_force_graphs(fg)
            self.damp_f, self.damp_force_f = damping.dissipation_functions(self)
            self._build_step(layout=layout, force_exprs=fg.exprs)
            graphs.update({k: getattr(self, k) for k in self._GRAPH_ATTRS})
            SYSTEM_GRAPHS[self.graph_key] = graphs
        else:
            for k in self._GRAPH_ATTRS:
                setattr(self, k, graphs[k])
        self._graphs = graphs
        self.damp_force_maps: dict = {}  # damping_force_rows' mapped calls by the number of states
        self._setup_buffers(self.kel_sparsity is not None)

    # what `_structure` sets (and structure_key from them): shared by the systems of one structure spec
    _STRUCTURE_ATTRS = ("part", "nf", "pos", "gather", "E", "cons", "mc", "drives", "nw", "linsol", "M_full", "M",
                        "length_scale", "span", "is_position", "force_calls", "graph_key")

    def _structure(self, asm: Assembly, linsol: str) -> None:
        """The reduced coordinates, kept constraint rows, drives, linear solver, mass matrix, scales and kernel calls:
        what the scene's element stiffnesses and gravity do not change."""
        self.coordinates(partition(asm), asm)  # (ReducedModel: part, E, nf, pos, the gather, scales)
        self.gather.flags.writeable = False  # (shared with the systems of the same structure)
        part = self.part
        self.cons = asm.exact.subset(part.rows) if len(part.rows) else None
        self.mc = self.cons.m if self.cons is not None else 0
        # drives and torques: rows and forces whose time functions w(t) are per-step inputs, appended to the step's
        # constant vector p (and to the integrators' pload): p = [p (nf); w (nw)]
        self.drives = drives.build(asm)
        self.nw = self.drives.nw if self.drives is not None else 0
        self.nw += 1 if water.timed(asm) else 0  # (lines in water under waves: the time, the last time input)
        if self.drives is not None:
            drives.check_free(self.drives, part.pos)
            self.mc += self.drives.m
        # sparse LDL^T without pivoting for the symmetric positive definite step matrix; sparse QR when multipliers
        # make the KKT matrix indefinite (LDL^T meets zero pivots) or strain-rate damping makes it unsymmetric
        # (d f_d / dq; LDL^T reads one triangle)
        # (contact friction likewise: d f / d q is unsymmetric)
        unsym = self.strain_rate is not None or bool(contact.dissipation_calls(asm.mesh)) or \
            bool(self.drives is not None and self.drives.torques) or \
            water.in_graph(asm)  # (a torque's tangent is skew; drag's d f / d q is unsymmetric)
        # "auto_lu" (the time steps): sparse LU (CSparse, threshold partial pivoting) instead of QR: the step matrix
        # carries cm M on its diagonal, and an inexact solve costs Newton iterations, never a wrong accepted step
        # (acceptance reads the residual); belt drive, 48 elements: one iteration 708 -> 421 us
        if linsol not in ("auto", "auto_lu"):
            self.linsol = linsol
        else:
            self.linsol = ("csparse" if linsol == "auto_lu" else "qr") if (self.mc or unsym) else "ldl"
        M = asm.mass_matrix().tocsc()
        Ma = water.added_mass(asm)  # (lines in water: the added mass, ancf_sym.system.water)
        if Ma is not None:
            M = (M + Ma).tocsc()
        self.M_full = M
        self.M = reduce_shared(part, M)
        # the kernel calls: a cable's axial and bending terms fused into one elastic_<strain> kernel where both
        # are on (same elements, Gauss order and Rayleigh weight): one B^T f_uu B per point instead of two
        weights = self.rayleigh.element_weight if (self.rayleigh is not None and self.rayleigh.beta) else {}
        terms = [mk.term for mk in asm.mapped if not mk.linear]
        self.force_calls = force_term_calls(terms, fuse=self.fuse, row_keys=weights)  # (set-up cache: its key)

    def _values(self, asm: Assembly) -> None:
        """What the element stiffnesses, gravity and loads give: the constant force of the linear terms, their
        energies' coefficients, the kernels' parameters (inputs of the compiled graphs, not baked in)."""
        # linear terms: constant generalized force (gravity, distributed dead loads, point loads)
        self.nonlinear = [mk for mk in asm.mapped if not mk.linear]
        grads: list = []
        f_lin = asm.constant_force(grads)  # (evaluates the linear terms at x0: their G and E below)
        # U_lin(x) = c + G.x (gradient constant), for the energy outputs
        self.lin_energy = [(mk.term.idx.ravel().copy(), mk.G.ravel().copy(),
                             float(mk.E.sum()) - float(mk.G.ravel() @ asm.x0[mk.term.idx.ravel()]), mk.term.label)
                            for mk in asm.mapped if mk.linear]
        self.f_lin_full = f_lin
        self.f_lin = self.part.reduce_vector(f_lin)
        self.force_terms = force_terms_of(self.force_calls, [mk.term for mk in self.nonlinear])
        # values that are inputs of the compiled graphs (not baked in): the kernels' element parameters (material,
        # section, lengths) and the linear potentials' coefficients (gravity, dead loads) of the energy outputs
        self.par = np.concatenate([ft.P.ravel() for ft in self.force_terms] +
                                  [mk.P.ravel() for mk in self.nonlinear] + [np.zeros(0)])
        self.lin = np.concatenate(grads + [np.array([c for _, _, c, _ in self.lin_energy]), asm.Q])

    @classmethod
    def for_scene(cls, asm: Assembly, **kw) -> "StepSystem":
        """The step system with the damping the scene declares (Rayleigh, strain-rate damping of cables)."""
        return cls(asm, damping.rayleigh_data(asm, [mk for mk in asm.mapped if not mk.linear]),
                   strain_rate=damping.strain_rate_data(asm), **kw)

    # compiled functions and what describes them: built once per structure key and shared by later StepSystems
    _GRAPH_ATTRS = ("kel_sparsity", "_energy_kin_labels",
                    "_energy_kin_f", "damp_f", "damp_force_f", "iteration_f")

    @property
    def forces_pf(self) -> ca.Function:
        """forces(x, par) -> (g, K[, kel]) (ancf_sym.system.forces): built with the system, or on first use where
        the band path's iteration has its own force graph; shared by the structure's systems."""
        if "forces_pf" not in self._graphs:
            self._keep_force_graphs(build_force_graphs(self, energies=False))
        return self._graphs["forces_pf"]

    def _keep_force_graphs(self, fg: ForceGraphs) -> None:
        self.kel_sparsity = fg.kel_sparsity
        if fg.forces is not None:
            self._graphs["forces_pf"] = fg.forces
        if fg.energies is not None:
            self._energy_kin_f, self._energy_kin_labels = fg.energies, fg.energy_labels

    @property
    def kkt_sparsity(self) -> ca.Sparsity:
        """The pattern of the step (KKT) matrix; on the band path made on first use from the layout's index arrays
        (the modified step's factorisation, the Newton in Python: a full-Newton run on the band never needs it)."""
        g = self._graphs
        if "kkt_sparsity" not in g:
            g["kkt_sparsity"] = g["band_layout"].pattern
        return g["kkt_sparsity"]

    @property
    def gradient_source(self) -> ca.Function:
        """A compiled function of (x, par) whose first output is the gradient of the nonlinear potential, of those
        the system built: the band path's force graph, or forces_pf (the same kernels and gathers: the same
        numbers)."""
        return self._graphs["forces_band"] if "forces_band" in self._graphs else self.forces_pf

    @property
    def iter_f(self) -> ca.Function:
        """newton_iteration(x, lam, p, cm, cc, kc, vc[, kel], y, par) -> (dz, norms): `iteration_f` with the
        multiplier input also where there are no multipliers (the signature of the Newton in Python)."""
        return self._with_multiplier_input("iter_f", self.iteration_f)

    def _with_multiplier_input(self, name: str, f: ca.Function) -> ca.Function:
        """f (built with the multiplier input only where there are multipliers: CasADi analyses the whole graph of
        a function with an empty input at every symbolic call, and the step graphs call these) with its input
        "lam" also where it is empty, for the Newton in Python: a wrapper inlining f's graph (evaluated as f is),
        built on first use and kept in the structure's graphs under `name`."""
        if name not in self._graphs:
            if not self.mc:
                ins = [ca.MX.sym(f.name_in(k), f.sparsity_in(k)) for k in range(f.n_in())]
                lam = ca.MX.sym("lam", 0)
                f = ca.Function(f.name(), ins[:1] + [lam] + ins[1:], f.call(ins, True, False),
                                f.name_in()[:1] + ["lam"] + f.name_in()[1:], f.name_out())
            self._graphs[name] = f
        return self._graphs[name]

    @property
    def grad_pf(self) -> ca.Function:
        """gradient(x, par) -> g from the gradient-only kernels (ancf_sym.system.forces.gradient_graph): built on
        first use (modified Newton's residual; a full-Newton run never needs it) and shared like res_f."""
        if "grad_pf" not in self._graphs:
            self._graphs["grad_pf"] = gradient_graph(self)
        return self._graphs["grad_pf"]

    @property
    def residual_f(self) -> ca.Function:
        """step_residual(x[, lam], p, cm, cc, kc, vc[, kel], y, par) -> (r, norms) from the gradient-only kernels:
        modified Newton's residual, its multiplier input only where there are multipliers (res_f: always). Built
        on first use (a full-Newton run that converges in its compiled steps never calls it) and shared by the
        structure's systems."""
        if "residual_f" not in self._graphs:
            self._build_step(full_only=False)
        return self._graphs["residual_f"]

    @property
    def jacobian_f(self) -> ca.Function:
        """step_jacobian(x[, lam], ...) -> (r, norms, KKT values): the modified step's refactorisations. Built on
        first use, like residual_f."""
        if "jacobian_f" not in self._graphs:
            self._build_step(full_only=False)
        return self._graphs["jacobian_f"]

    @property
    def res_f(self) -> ca.Function:
        """residual_f with the multiplier input always (the Newton in Python)."""
        return self._with_multiplier_input("res_f", self.residual_f)

    @property
    def jac_f(self) -> ca.Function:
        """jacobian_f with the multiplier input always (the Newton in Python)."""
        return self._with_multiplier_input("jac_f", self.jacobian_f)

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

    # -- symbolic assembly (once per scene) -------------------------------------------------------------------
    def x_full_mx(self, xf: ca.MX) -> ca.MX:
        """E xf + c as a gather (every coordinate is one unknown or fixed): the element gathers that follow merge
        with it into one, where a product with E would cost a sparse product at every evaluation."""
        return full_mx(xf, self.pos, self.part.c)

    def mass_mx(self, u: ca.MX) -> ca.MX:
        """M u in a graph. Where M = kron(Mbar, I_d) (cables: every direction has the same mass; checked exactly when
        the graphs are built), as the product with Mbar of u reshaped to d x nf/d: at 1000 cable2d elements 29 us
        instead of 61 us per product, the same sums."""
        d, Bt, _ = self._mass_factor()
        return kron_product_mx(d, Bt, u) if d else ca.mtimes(Bt, u)

    def _mass_factor(self) -> tuple:
        """(d, Mbar^T, Mbar) as DMs where M = kron(Mbar, I_d), else (0, M, M) (M as a DM)."""
        if "_mass_kron" not in self.__dict__:
            f = kron_factor_dm(self.M)
            if f is not None:
                self._mass_kron = (f[0], f[1].T, f[1])
            else:
                Md = dm(self.M)
                self._mass_kron = (0, Md, Md)
        return self._mass_kron

    def mass_dm(self) -> ca.DM:
        """M as a DM: kron(Mbar, I_d) where M has that form (the same pattern and entries, b * 1.0 = b; ~8x cheaper
        than converting M's arrays), else from M."""
        d, _, B = self._mass_factor()
        return ca.kron(B, ca.DM.eye(d)) if d else B

    def damping_force(self, xf: np.ndarray, vf: np.ndarray, t: float | None = None) -> np.ndarray | None:
        """Damping force on the unknowns at (x, v) and time t (ancf_sym.system.damping.damping_force)."""
        return damping.damping_force(self, xf, vf, t)

    @property
    def inertia_input(self) -> bool:
        """The step graph's inertia is not M (cm x + y) alone (lines in water: the added mass turns with the line):
        the Python step passes y rather than M y in p."""
        return water.nonlinear_inertia(self.asm)

    @property
    def damped(self) -> bool:
        return self.rayleigh is not None or self.damp_f is not None

    def constraint_mx(self, xf: ca.MX, w: ca.MX | None = None) -> ca.MX:
        """The kept exact rows, then the drive rows at the time inputs w."""
        x = self.x_full_mx(xf)
        parts = [Assembly.casadi_constraint(self.cons, x)] if self.cons is not None else []
        if self.drives is not None and self.drives.m:
            parts.append(self.drives.mx(x, w))
        return ca.vertcat(*parts)

    @property
    def bilinear(self) -> bool:
        """Constraint rows with a Hessian (bilinear terms)."""
        return (self.cons is not None and len(self.cons.qrow) > 0) or (self.drives is not None and self.drives.m > 0)

    def torque_mx(self, xf: ca.MX, w: ca.MX) -> ca.MX | None:
        """Generalized force of the applied torques on the unknowns, tau (-s, c) on a body's (c, s) (spatial: per
        pair of axis-vector components, ancf_sym.bodies.drives), or None."""
        if self.drives is None or not self.drives.torques:
            return None
        vals, rows = [], []
        X = self.x_full_mx(xf)  # (a coordinate a joint fixes keeps its value and takes no force)
        for ic, is_, k, scale in self.drives.torques:
            for i, v in ((ic, -scale * w[k] * X[is_]), (is_, scale * w[k] * X[ic])):
                if self.pos[i] >= 0:
                    vals.append(v)
                    rows.append(int(self.pos[i]))
        if not rows:
            return None
        A = ca.DM(ca.Sparsity.triplet(self.nf, len(rows), rows, list(range(len(rows)))), 1.0)
        return ca.mtimes(A, ca.vertcat(*vals))

    def _build_step(self, full_only: bool = True, layout: BandLayout | None = None,
                    force_exprs: tuple | None = None) -> None:
        """iteration_f (and kkt_sparsity); full_only False: residual_f and jacobian_f instead, into the structure's
        graphs (all three with the multiplier input only where there are multipliers).
        iteration_f(x[, lam], p, cm, cc, kc, vc[, kel], y, par) -> (dz, norms): one full Newton iteration, its
        multiplier input only where there are multipliers (iter_f: always).
        force_exprs: (x, par, outputs) of the force graph just built (build_force_graphs), taken as they are (the
        nodes an inlined call of forces_pf would copy), or None."""
        nf, mc = self.nf, self.mc
        if not full_only or layout is not None:
            force_exprs = None
        xf = force_exprs[0] if force_exprs is not None else ca.MX.sym("x", nf)
        lam, p_in = ca.MX.sym("lam", mc), ca.MX.sym("p", nf + self.nw)
        p, w = (p_in[:nf], p_in[nf:]) if self.nw else (p_in, None)  # w: the drives' time inputs (then the time)
        wd = w[:self.drives.nw] if (self.drives is not None and w is not None) else w  # (the drives' own: their
        # rows index the entry past them as a constant 1)
        cm, cc, kc = ca.MX.sym("cm"), ca.MX.sym("cc"), ca.MX.sym("kc")
        kel = ca.MX.sym("kel", self.kel_sparsity.nnz()) if self.kel_sparsity is not None else None
        vc = ca.MX.sym("vc", nf)  # v_n+1 = vc + cc x (used by the strain-rate damping)
        # y: inertia part of the constant residual, M (cm x + y) (the alpha step graph: one product with M per
        # iteration and none in the step's predictor; other callers pass y = 0 and M y in p)
        y = ca.MX.sym("y", nf)
        par = force_exprs[1] if force_exprs is not None else ca.MX.sym("par", self.par.size)
        ins = [xf, lam, p_in, cm, cc, kc, vc] + ([kel] if kel is not None else []) + [y, par]
        names = ["x", "lam", "p", "cm", "cc", "kc", "vc"] + (["kel"] if kel is not None else []) + ["y", "par"]
        ins_it, names_it = (ins, names) if mc else ([xf] + ins[2:], [names[0]] + names[2:])
        if layout is not None and full_only:  # the Hessian gathered straight into the band, banded LDL^T
            fb = self._graphs["forces_band"] = band_force_graph(self, layout)  # (ancf_sym.system.band)
            g, Kb = fb(xf, par)
            r = add(add(self.mass_mx(add(mul(cm, xf), y)), g), p)
            A = add(mul(cm, ca.MX(ca.DM(layout.values(self.M)))), Kb)
            x, kmax, dzx = layout.solve_mx(A, r)
            self._graphs["band_layout"] = layout  # (kkt_sparsity: its pattern, made on first use)
            # (the diagonal's largest entry per kind of unknown: slot 0 of each column of the band)
            k_pos, k_rest = (ca.mmax(fabs(A[list(map(int, (layout.w + 1) * j))])) if len(j) else ca.MX(0)
                             for j in (np.flatnonzero(self.is_position), np.flatnonzero(~self.is_position)))
            norms = ca.vertcat(ca.mmax(fabs(r)), 0, dzx, 0, kmax, k_pos, k_rest)
            self.iteration_f = ca.Function("newton_iteration", ins_it, [neg(x), norms], names_it, ["dz", "norms"])
            return
        # (the force graph's nodes in the iteration's graph, a call node would cost ~0.3 us of an iteration's ~22 us:
        # those just built, or copied by an inlined call)
        out = force_exprs[2] if force_exprs is not None else self.forces_pf.call([xf, par], True, False)
        g, K = out[0], out[1]
        Mdm = self.mass_dm()
        Cx, C = damping.rayleigh_mx(self, xf, kel)
        Mu = self.mass_mx(add(mul(cm, xf), y))
        turning = water.inertia_mx(self, xf, add(mul(cm, xf), y))  # (lines in water: the added mass that turns)
        if turning is not None:
            Mu = Mu + turning
        damped = self.rayleigh is not None  # (else Cx and C are zeros, the terms nothing: not built)
        r_q = add(add(add(Mu, mul(cc, Cx)), g), p) if damped else add(add(Mu, g), p)
        spS = K.sparsity().unite(Mdm.sparsity())
        # (M placed in K's pattern once where it fits: no projection of M at every evaluation)
        cmM = mul(cm, ca.MX(ca.project(Mdm, spS) if spS == K.sparsity() else Mdm))
        S = add(add(cmM, mul(cc, C)), K) if damped else add(cmM, K)
        if turning is not None:
            S = S + ca.jacobian(turning, xf)
        # (lines in water under waves: the water's forces read the time, the last of the time inputs w)
        dargs = [xf, vc + cc * xf] + ([w[-1]] if damping.timed(self) else [])
        if self.damp_f is not None:
            fd, dft = damping.step_tangent_function(self)(*dargs, cc)  # (df/dx + cc df/dv: one sum per block)
            r_q += fd
            S = S + dft
        # the same residual from the gradient-only kernels (modified Newton: no Hessian work)
        r_g = None if full_only else Mu + cc * Cx + self.grad_pf(xf, par) + p
        if self.damp_f is not None and not full_only:
            r_g += self.damp_force_f(*dargs)
        tq = self.torque_mx(xf, wd)
        if tq is not None:  # applied torques: force tau (-s, c), tangent -d/dx of it
            r_q -= tq
            if r_g is not None:
                r_g -= tq
            S = S - ca.jacobian(tq, xf)
        if mc:
            phi = self.constraint_mx(xf, wd)
            Jx = ca.jacobian(phi, xf)
            r_q += kc * ca.mtimes(Jx.T, lam)
            if r_g is not None:
                r_g += kc * ca.mtimes(Jx.T, lam)
            if self.bilinear:
                S = S + ca.hessian(ca.dot(kc * lam, phi), xf)[0]
            r = ca.vertcat(r_q, kc * phi)
            rg = None if r_g is None else ca.vertcat(r_g, kc * phi)
            KKT = ca.blockcat([[S, kc * Jx.T], [kc * Jx, ca.MX(mc, mc)]])
            rc = ca.mmax(ca.fabs(phi))
        else:
            r, rg, KKT, rc = r_q, r_g, S, ca.MX(0)
        rq = ca.mmax(fabs(r_q))
        kkt_nz = mx_nonzeros(KKT)
        # largest entry (round-off floor): on the diagonal when the step matrix is positive definite
        # (the largest of either kind of unknown's rows: kmax itself, no third pass over the entries)
        k_pos, k_rest = self._largest_by_kind(KKT, kkt_nz)
        kmax = ca.fmax(k_pos, k_rest)
        if not full_only:
            self._graphs["residual_f"] = ca.Function("step_residual", ins_it,
                                                     [rg, ca.vertcat(ca.mmax(ca.fabs(r_g)), rc)], names_it,
                                                     ["r", "norms"])
            self._graphs["jacobian_f"] = ca.Function("step_jacobian", ins_it, [r, ca.vertcat(rq, rc, kmax), kkt_nz],
                                                     names_it, ["r", "norms", "kkt"])
            return
        self._graphs["kkt_sparsity"] = KKT.sparsity()
        dz = neg(ca.solve(KKT, r, self.linsol))
        dzx = ca.mmax(fabs(dz[:nf]))
        dzl = ca.mmax(fabs(dz[nf:])) if mc else ca.MX(0)
        # norms: |r_q|inf [N], |Phi|inf [m], |dx|inf, |dlam|inf (scaled: m), max |KKT|, and its largest entry in the
        # rows of positions and of the other unknowns (alpha_step.update_tolerance)
        self.iteration_f = ca.Function("newton_iteration", ins_it,
                                       [dz, ca.vertcat(rq, rc, dzx, dzl, kmax, k_pos, k_rest)], names_it,
                                       ["dz", "norms"])

    def _largest_by_kind(self, KKT: ca.MX, kkt_nz: ca.MX) -> tuple[ca.MX, ca.MX]:
        """The largest |entry| of the step matrix in the rows of position unknowns and in the others (gradients, axis
        vectors), as kmax: its diagonal where LDL^T applies, else every entry; an entry of a multiplier row counts
        with the unknown of its column (its transpose's row)."""
        nf, pos = self.nf, self.is_position
        if not nf:
            return ca.MX(0), ca.MX(0)
        if self.linsol == "ldl" and not self.mc:
            d = ca.diag(KKT)
            sel = [np.flatnonzero(pos), np.flatnonzero(~pos)]
            vals = [d[list(map(int, s))] if len(s) else None for s in sel]
        else:
            sp_ = KKT.sparsity()
            rows, cols = np.array(sp_.row()), np.repeat(np.arange(sp_.size2()), np.diff(sp_.colind()))
            kind = np.where(rows < nf, pos[np.minimum(rows, nf - 1)], pos[np.minimum(cols, nf - 1)])
            vals = [kkt_nz[list(map(int, np.flatnonzero(m)))] if m.any() else None for m in (kind, ~kind)]
        return tuple(ca.mmax(fabs(v)) if v is not None else ca.MX(0) for v in vals)


    def _band_layout(self) -> BandLayout | None:
        """The band path's layout of the step matrix (ancf_sym.system.band) where it applies, else None: positive
        definite step matrices (LDL^T) without multipliers, drives, Rayleigh or strain-rate damping, penalty joints."""
        if self.linsol != "ldl" or self.mc or self.drives is not None or self.rayleigh is not None or \
                self.strain_rate is not None or contact.dissipation_calls(self.asm.mesh) or \
                self.asm.penalty is not None or self.nf < band.MIN_SIZE:  # (damp_f: strain-rate or contact damping)
            return None
        # the pattern of forces_pf's K (the kernels' Hessian entries on the unknowns) and M's, from the index maps
        M = sp.coo_matrix(self.M)
        rows, cols = [M.row], [M.col]
        for ft in self.force_terms:
            ia, ib, keep = hessian_entries(self.pos, ft.idx)
            rows.append(ib[keep])
            cols.append(ia[keep])
        r, c = np.concatenate(rows), np.concatenate(cols)
        A = sp.csc_matrix((np.ones(len(r)), (r, c)), shape=(self.nf, self.nf))  # (canonical: duplicates summed)
        return band_layout_csc(self.nf, self.nf, A.indptr, A.indices)

    def ensure_factor(self) -> LDLFactor | None:
        """The in-graph LDL^T factorisation of the step matrix (ancf_sym.system.ldl), built on first use and shared
        like the graphs; None where it does not apply: multipliers or strain-rate damping (self.linsol is not
        "ldl"), or a factorisation graph too large."""
        if "factor" not in self._graphs:
            ok = self.linsol == "ldl" and not self.mc and self.nf
            self._graphs["factor"] = build_ldl(self.kkt_sparsity) if ok else None
        return self._graphs["factor"]

    def _setup_buffers(self, has_kel: bool) -> None:
        nf, mc = self.nf, self.mc
        self.nz = nf + mc
        self.x, self.lam, self.p, self.vc = np.zeros(nf), np.zeros(mc), np.zeros(nf + self.nw), np.zeros(nf)
        self.y = np.zeros(nf)  # (stays 0 here: p holds the whole constant part)
        self.cm, self.cc, self.kc = np.zeros(1), np.zeros(1), np.ones(1)
        self.kel = np.zeros(self.kel_sparsity.nnz()) if has_kel else None
        self.r, self.dz = np.zeros(self.nz), np.zeros(self.nz)
        self.norms = np.zeros(7)
        self._jac_norms = np.zeros(3)
        self.floor = 0.0
        self._evals = None  # the compiled calls' buffers: bound on first use (`_bind`)

    def _bind(self) -> tuple:
        """Buffers of iter_f, res_f and jac_f bound to this system's arrays, and the KKT matrix jac_f writes into:
        made on the first Newton iteration in Python (a run whose steps all converge in the compiled step graph
        never needs them; at 1000 elements the three buffers take ~2 ms to allocate), from the structure's pool."""
        if self._evals is None:
            if "kkt_pattern" not in self._graphs:  # (converting CasADi's pattern costs ~10 ms at 1000 elements)
                spk = self.kkt_sparsity
                self._graphs["kkt_pattern"] = (spk.nnz(), np.array(spk.row(), dtype=np.int32),
                                               np.array(spk.colind(), dtype=np.int32))
            nnz, rows, colind = self._graphs["kkt_pattern"]
            self._kkt = sp.csc_matrix((np.zeros(nnz), rows, colind), shape=(self.nz, self.nz))
            has_kel = self.kel is not None
            args = [self.x, self.lam, self.p, self.cm, self.cc, self.kc, self.vc] + ([self.kel] if has_kel else []) \
                + [self.y, self.par]
            bufs = []
            for name, f, outs in (("iter", self.iter_f, (self.dz, self.norms)),
                                  ("res", self.res_f, (self.r, self.norms[:2])),
                                  ("jac", self.jac_f, (self.r, self._jac_norms, self._kkt.data))):
                buf, ev = bind(f, args, outs, pooled_buffer(self._graphs, name, f, self))
                bufs.append((buf, ev, args, outs))  # the buffer object must outlive its evaluations
            self._evals = bufs
        return self._evals

    @property
    def kkt(self) -> sp.csc_matrix:
        """The KKT matrix `jacobian` writes into (its pattern: kkt_sparsity)."""
        self._bind()
        return self._kkt

    # -- numeric calls ------------------------------------------------------------------------------------------
    def iterate(self) -> np.ndarray:
        """One full Newton iteration at the current buffers: self.dz (not applied) and self.norms."""
        self._bind()[0][1]()
        self.floor = float(np.finfo(float).eps * self.norms[4] * self.span)
        return self.dz

    def residual(self) -> np.ndarray:
        """r at the current buffers, written into self.r; norms[:2]."""
        self._bind()[1][1]()
        return self.r

    def jacobian(self) -> sp.csc_matrix:
        """r and the KKT values at the current buffers (self.r, self.kkt in place); updates the round-off floor
        of the residual, eps x largest matrix entry x coordinate span (as statics._roundoff_floor)."""
        self._bind()[2][1]()
        self.norms[:2] = self._jac_norms[:2]
        self.norms[4] = self._jac_norms[2]
        self.floor = float(np.finfo(float).eps * self._jac_norms[2] * self.span)
        return self._kkt

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
        T, pots = self.energies_by_label(xf, vf)
        return T, dict(zip(self.potential_labels, pots))

    def _potential_groups(self) -> tuple[list[str], list | None]:
        """(the potentials' labels, first seen first; per label the indices of its terms' energies, or None when
        every term has its own label). Several terms may share a label: members' bending."""
        if not hasattr(self, "_pot_groups"):
            labels = self._energy_kin_labels
            unique = list(dict.fromkeys(labels))
            groups = None if len(unique) == len(labels) else \
                [[i for i, lbl in enumerate(labels) if lbl == u] for u in unique]
            self._pot_groups = (unique, groups)
        return self._pot_groups

    @property
    def potential_labels(self) -> list[str]:
        """The labels of the potentials `energies_by_label` returns, in its order."""
        return self._potential_groups()[0]

    def energies_by_label(self, xf: np.ndarray, vf: np.ndarray | None) -> tuple[float, list[float]]:
        """(kinetic energy, the potentials summed by label in the order of `potential_labels`) [J]: `energies`
        without the dictionary (the recorder's per-record path)."""
        return self.by_label(self.energy_values(xf, vf))

    def by_label(self, vals: list[float]) -> tuple[float, list[float]]:
        """(kinetic energy, potentials by label) from `energy_values`' list."""
        groups = self._potential_groups()[1]
        if groups is None:
            return vals[-1], vals[:-1]
        pots = []
        for idx in groups:  # (summed in the terms' order)
            acc = 0.0
            for i in idx:
                acc += vals[i]
            pots.append(acc)
        return vals[-1], pots

    def energy_values(self, xf: np.ndarray, vf: np.ndarray | None) -> list[float]:
        """The potentials of the terms, then the kinetic energy, from one compiled call [J] (what
        `energies_by_label` sums by label)."""
        if not hasattr(self, "_ebuf"):
            self._e_x, self._e_vel = np.zeros(self.nf), np.zeros(self.nf)
            self._e_v = np.zeros(self._energy_kin_f.nnz_out(0))
            self._ebuf = bind(self._energy_kin_f, (self._e_x, self._e_vel, self.par, self.lin), (self._e_v,))
        self._e_x[:] = xf
        self._e_vel[:] = 0.0 if vf is None else vf
        self._ebuf[1]()
        return self._e_v.tolist()

    def energy_values_rows(self, Q: np.ndarray, V: np.ndarray) -> list[list[float]]:
        """`energy_values` at each row of Q and V (k x nf) in one call of the energy graph mapped over the rows
        (each row evaluated as energy_values evaluates it: the same numbers); the map of k rows is built on first
        use and shared like the graphs."""
        k = len(Q)
        bufs = self.__dict__.setdefault("_ebufs", {})
        if k not in bufs:
            key = ("energies_rows", k)
            if key not in self._graphs:
                self._graphs[key] = self._energy_kin_f.map(f"energies_{k}", "serial", k, [2, 3], [])
            f = self._graphs[key]
            x, v, out = np.zeros((k, self.nf)), np.zeros((k, self.nf)), np.zeros((k, self._energy_kin_f.nnz_out(0)))
            bufs[k] = (bind(f, (x, v, self.par, self.lin), (out,)), x, v, out)
        (buf, ev), x, v, out = bufs[k]
        x[:], v[:] = Q, V
        ev()
        return out.tolist()

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
        """The step graph's time inputs at t: the drives' (empty without drives), then t itself where the water's
        forces read the time (waves)."""
        w = self.drives.w(t) if self.drives is not None else np.zeros(0)
        return np.r_[w, t] if water.timed(self.asm) else w

    def drive_force(self, xf: np.ndarray, lam: np.ndarray, t: float) -> np.ndarray | None:
        """Generalized force of the drives (their rows' reactions -J_D^T lam_D) and the torques on the unknowns at
        time t (true multipliers lam), for the work they do; None without drives."""
        d = self.drives
        if d is None:
            return None
        x, w = self.full(xf), d.w(t)
        f = d.torque_force(x, w)
        if d.m:
            f = f - d.transpose_product(x, w, lam[self.mc - d.m:])
        return self.E.T @ f

    def stiffness_scale(self) -> float:
        """Largest diagonal entry of M (for the multiplier scale kc = cm * this)."""
        return float(self.M.diagonal().max()) if self.nf else 1.0
