"""The linearised equations of motion of a scene about a state (an equilibrium, usually), on its reduced coordinates:

    M y'' + D y' + K_L y + G^T mu = B u,    G y = 0

y are the unknowns left once supports and hinges are eliminated (x = E y + c, ancf_sym.model.reduced); G is the Jacobian of
the exact rows that keep multipliers (rigid joints, skew clamps); K_L the exact Hessian of the Lagrangian: the
potential's Hessian from the kernels (geometric stiffness of the prestress and penalty springs and penalty contacts
included) plus sum_i lambda_i Hess(Phi_i) of the multiplier rows (bilinear: a constant curvature). D is the
damping: Rayleigh alpha M + beta K_el (K_el: the elastic terms' Hessian at the state, per member as the scene
declares it) plus d f_d / d v at v = 0 of strain-rate damping and dissipative contact (exact, by the dynamics' AD
graph; friction makes it unsymmetric). In water (ancf_sym.modal.water) M holds the added mass, K the exact
Jacobian of the water statics' residual (unsymmetric where a current drags) and D the drag's damping. B maps
point forces at the members' nodes (world components) to generalized forces.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ancf_sym.contact import laws as contact
from ancf_sym.model.assembly import Assembly
from ancf_sym.system import damping
from ancf_sym.model.reduced import Partition
from ancf_sym.scene.builder import Scene, SceneError
from ancf_sym.statics.problem import StaticProblem, StaticResult, problem_for
from ancf_sym.modal.contact_rows import active_rows, exact_multipliers
from ancf_sym.modal.eigen import symmetric
from ancf_sym.modal.water import water_matrices
from ancf_sym.system import water as system_water


@dataclass
class Linearization:
    """The linear model about a state x (full coordinates). Matrices act on the reduced unknowns y (x = E y + c):
    M (mass), K (Hessian of the Lagrangian K_L), D (damping; None without damping), G (Jacobian of the
    exact rows with multipliers, m x ny), B (generalized forces of the inputs, ny x nu: the point forces at every
    member node, labelled by `inputs`)."""
    M: sp.csc_matrix
    K: sp.csc_matrix
    D: sp.csc_matrix | None
    G: sp.csr_matrix
    B: sp.csc_matrix
    E: sp.csc_matrix  # full coordinates of the unknowns: dx = E dy
    x: np.ndarray  # the state (full coordinates)
    multipliers: np.ndarray  # lambda of the rows of G (the exact rows kept with multipliers)
    inputs: list = field(default_factory=list)  # (member, node, component) of each column of B
    assembly: Assembly | None = field(default=None, repr=False)
    H_full: sp.csc_matrix | None = field(default=None, repr=False)  # K_L on the full coordinates
    G_full: sp.csr_matrix | None = field(default=None, repr=False)  # G on the full coordinates

    @property
    def size(self) -> int:
        return self.M.shape[0]

    def full(self, y: np.ndarray) -> np.ndarray:
        """Full-coordinate perturbations of reduced ones (columns of y too)."""
        return self.E @ y

    def condensed_stiffness(self, points: list[tuple[str, object]]) -> np.ndarray:
        """The static stiffness the structure offers at chosen nodes: [(member, at), ...] with at "start", "end" or
        an index of the member's public nodes; returns the (dim k) x (dim k) matrix of the forces on the nodes'
        positions per unit displacement of them, the rest of the structure in its (linear) equilibrium with its
        supports and constraints. A node held by a support is moved with it (a mooring line's fairlead: the force
        on the pin); its other supported coordinates (a clamp's slopes) stay held. Formula: with x = E_r y_r + S d
        (E_r: the unknowns other than the chosen ones), Lagrangian 1/2 x'Hx + mu'Gx, K_c = S'H S + S'H E_r Y +
        S'G' Mu where [[E_r'H E_r, E_r'G'], [G E_r, 0]] [Y; Mu] = -[E_r'H S; G S]: one KKT factorisation."""
        asm = self.assembly
        cols = []
        for member, at in points:
            mm = asm.mesh.members.get(member)
            if mm is None:
                raise SceneError(f"condensed_stiffness: member {member!r} is not in the scene")
            ends = {"start": mm.public_nodes[0], "end": mm.public_nodes[-1]}
            if isinstance(at, str) and at not in ends or not isinstance(at, (str, int, np.integer)) or \
                    isinstance(at, (int, np.integer)) and not -len(mm.public_nodes) <= at < len(mm.public_nodes):
                raise SceneError(f"condensed_stiffness: at={at!r} for member {member!r} is not 'start', 'end' or a "
                                 f"public node index (0..{len(mm.public_nodes) - 1})")
            node = ends[at] if isinstance(at, str) else mm.public_nodes[int(at)]
            cols.extend(mm.node_dofs(node)[:asm.scene.dim])
        cols = np.asarray(cols)
        if len(np.unique(cols)) < len(cols):
            raise SceneError(f"condensed_stiffness: {points!r} names a node twice")
        E = self.E.tocsr()
        chosen = np.unique(E[cols].indices)  # unknowns that a chosen coordinate is
        shared = np.asarray(abs(E[:, chosen]).sum(axis=0)).ravel() > 1
        if np.any(shared):
            raise SceneError(f"condensed_stiffness: a node of {points!r} shares its coordinates with another member's "
                             "(a hinge or joint): choose one side's node of a joint that is not identified")
        keep = np.setdiff1d(np.arange(self.size), chosen)
        Er = self.E[:, keep].tocsc()
        S = sp.csc_matrix((np.ones(len(cols)), (cols, np.arange(len(cols)))), shape=(self.E.shape[0], len(cols)))
        H, Gf = self.H_full, self.G_full
        A, B = (Er.T @ H @ Er).tocsc(), (Gf @ Er).tocsc()
        kkt = sp.bmat([[A, B.T], [B, None]], format="csc") if B.shape[0] else A
        rhs = -np.vstack([(Er.T @ H @ S).toarray(), (Gf @ S).toarray()])
        sol = sp.linalg.splu(kkt).solve(rhs)
        Y, Mu = sol[:len(keep)], sol[len(keep):]
        Kc = (S.T @ H @ S).toarray() + (S.T @ H @ Er) @ Y + (S.T @ Gf.T) @ Mu
        # (symmetric to round-off for a conservative scene; a current's drag makes it unsymmetric: kept so, it is
        # then the fairlead's stiffness of ancf_sym.water.mooring_stiffness)
        return 0.5 * (Kc + Kc.T) if symmetric(H) else Kc


def _state(prob: StaticProblem, state) -> tuple[np.ndarray, StaticResult | None]:
    """(x, the StaticResult if there is one)."""
    if state is None:
        state = prob.solve()
        if not state.success:
            raise SceneError(f"linearize: the static equilibrium failed ({state.status}); pass a state")
    x = state.x if isinstance(state, StaticResult) else np.asarray(state, float)
    if x.shape != (prob.asm.n,) or not np.all(np.isfinite(x)):
        raise SceneError(f"linearize: state must be a StaticResult or {prob.asm.n} finite coordinates, got shape "
                         f"{np.shape(x)}")
    return x, (state if isinstance(state, StaticResult) else None)


def linearize(scene: Scene, state: StaticResult | np.ndarray | None = None, damping_matrix: bool = True,
              problem: StaticProblem | None = None) -> Linearization:
    """M, K_L, D, G, B about `state` (a StaticResult or full coordinates; None: the static equilibrium, solved
    here; a scene with exact contact needs a StaticResult: its contact forces say which points are held, and those
    points' gap rows join G). At an equilibrium the multipliers are exact; elsewhere they are the least-squares
    ones (K_L then holds the constraint curvature of that estimate). damping_matrix=False skips D (strain-rate
    damping and contact friction build the dynamics' step system for it: about a second on large models)."""
    prob = problem if problem is not None else problem_for(scene)
    asm = prob.asm
    x, result = _state(prob, state)
    part: Partition = prob.S.part  # (the statics' ReducedModel)
    if getattr(asm.scene, "water", None) is not None:  # (added mass, the drag's stiffness and damping)
        M, K, D, G, E, lam, J, Gf, wasm = water_matrices(result, part, _damping, damping_matrix)
        B, inputs = _inputs(wasm, E)
        return Linearization(M, K, D, G, B, E, result.x, lam, inputs, wasm, J, Gf)
    ev = asm.evaluate(x, hessian=True)
    H = ev.hessian
    exact_contact = bool(contact.exact_contacts(asm))
    if exact_contact:  # the points in contact: equality rows (ancf_sym.modal.contact_rows)
        Jc, Hc, fc = active_rows(asm, result)
        H = (H + Hc).tocsc()
        lam_all = exact_multipliers(asm, result) if asm.exact.m else np.zeros(0)
    else:
        Jc, fc = sp.csr_matrix((0, asm.n)), np.zeros(0)
        lam_all = prob.multipliers(x, ev.gradient) if asm.exact.m else np.zeros(0)
    if len(asm.exact.qrow):  # bilinear rows (rigid joints' slopes): their curvature, lambda-weighted
        H = (H + asm.exact.hessian(lam_all)).tocsc()
    K = part.reduce_matrix(H)
    K = (0.5 * (K + K.T)).tocsc()  # (the kernels' Hessians are symmetric to round-off; eigsh reads both triangles)
    M = part.reduce_matrix(asm.mass_matrix())
    rows = part.rows
    if len(rows):
        Gf = asm.exact.subset(rows).jacobian(x).tocsr()
        lam = lam_all[rows]
    else:
        Gf, lam = sp.csr_matrix((0, asm.n)), np.zeros(0)
    if Jc.shape[0]:  # (contact rows after the joints'; their multipliers are minus the contact forces)
        Gf, lam = sp.vstack([Gf, Jc]).tocsr(), np.r_[lam, -fc]
    G = (Gf @ part.E).tocsr()
    D = _damping(asm, x, part, M) if damping_matrix else None
    B, inputs = _inputs(asm, part.E)
    return Linearization(M, K, D, G, B, part.E, x, lam, inputs, asm, H.tocsc(), Gf)


def _inputs(asm: Assembly, E: sp.spmatrix) -> tuple[sp.csc_matrix, list]:
    """(B, labels): the generalized forces on the unknowns (x = E y + c) of point forces at every member node."""
    cols, inputs = [], []
    for name, mm in asm.mesh.members.items():
        for k, node in enumerate(mm.public_nodes):
            for d, dof in enumerate(mm.node_dofs(node)[:asm.scene.dim]):
                cols.append(dof)
                inputs.append((name, k, "xyz"[d]))
    P = sp.csc_matrix((np.ones(len(cols)), (np.asarray(cols), np.arange(len(cols)))), shape=(asm.n, len(cols)))
    return (E.T @ P).tocsc(), inputs


def _damping(asm: Assembly, x: np.ndarray, part: Partition, M: sp.csc_matrix) -> sp.csc_matrix | None:
    """Rayleigh damping plus d f_d / d v at (x, v = 0) of strain-rate damping and dissipative contact (the dynamics'
    own exact dissipation graph, ancf_sym.system.damping, built only where the scene has either)."""
    D = _rayleigh(asm, x, M, part)
    if damping.strain_rate_data(asm) is not None or contact.dissipation_calls(asm.mesh) or \
            system_water.has_forces(asm):  # (lines in water: the drag's d f / d v, in the same graph)
        from ancf_sym.system.step_system import StepSystem
        S = StepSystem.for_scene(asm)
        Dv = S.damp_f(S.reduce(x), np.zeros(S.nf))[2]
        Dv = sp.csc_matrix(Dv.sparse() if hasattr(Dv, "sparse") else np.asarray(Dv))
        D = Dv if D is None else (D + Dv).tocsc()
    return D


def _rayleigh(asm: Assembly, x: np.ndarray, M: sp.csc_matrix, part: Partition) -> sp.csc_matrix | None:
    """alpha M + beta K_el: K_el the elastic terms' Hessian at x weighted per member (dynamics' Rayleigh data)."""
    ray = damping.rayleigh_data(asm, asm.curved)
    if ray is None or not (ray.alpha or ray.beta):
        return None
    D = ray.alpha * M
    if ray.beta:
        vals = []
        for ti, mk in enumerate(asm.curved):
            mk(x)
            w = ray.element_weight.get(ti)
            vals.append((mk.H * (w[:, None, None] if w is not None else 1.0)).ravel())
        Kel = part.reduce_matrix(asm.hessian_of(np.concatenate(vals)))
        D = D + ray.beta * 0.5 * (Kel + Kel.T)
    return sp.csc_matrix(D)
