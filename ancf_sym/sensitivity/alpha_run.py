"""What the forward and adjoint sensitivities of a dynamic run share: the checks (refused features and parameter
paths, before any step), the run itself (the package's compiled alpha steps, every state kept) and the parameter
forcing F_n = dR/dp(q_n) + dM/dp a_n + dC/dp v_n of the differentiated step equations at every step.

Parameters: the model's TOML paths (ancf_sym.sensitivity.model_derivative), the Rayleigh coefficients
dampings[i].alpha | beta (C_n = alpha_R M + beta K_el(q_n): the run takes the elastic tangent at each step's start;
the change of beta K_el(q_n) v_{n+1} with q_n is the kernels' compiled Hessian-vector companions' exact third
derivatives contracted with v) and the strain-rate coefficients dampings[i].axial | bending (the force f_d(q, v) is
linear in them; its tangents df/dq, df/dv are the step system's), and contact damping and friction: their
tangents are in the same graph, their parameters contacts[i].mu | damping (and the friction's share of
contacts[i].stiffness | hertz) in ancf_sym.sensitivity.contact_dissipation. Refused by name: lines in water, a
beta on energies without compiled third derivatives. Applied torques add their skew tangent to the step's matrix.
Constraint rows with multipliers
(rigid joints, bodies' rows) and drives make the step a KKT system: `step_matrix` builds its differentiated matrix,
the run keeps the multipliers and the drives' time inputs.
Time loads (analysis.loads) are applied as the run applies them; they depend on no scene parameter.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym import kernels, registry
from ancf_sym.contact import laws as contact
from ancf_sym.dynamics import DynamicOptions
from ancf_sym.dynamics.initial import released_scene
from ancf_sym.dynamics.newton import Counters
from ancf_sym.dynamics.run import check_drives_at_start, make_integrator
from ancf_sym.dynamics.time_loads import LoadSum
from ancf_sym.dynamics.time_loop import chunk_size
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.model.assembly import Assembly
from ancf_sym.scene.builder import SceneError
from ancf_sym.sensitivity.contact_dissipation import dissipation_forcing, dissipation_index, dissipation_notes
from ancf_sym.sensitivity.kernel_direction import DirectionPiece
from ancf_sym.sensitivity.length_derivative import LengthPiece
from ancf_sym.sensitivity.model_derivative import ParameterError, model_derivative, read_document
from ancf_sym.sensitivity.paths import get_parameter, parse_path
from ancf_sym.sensitivity.run_start import RunStart, run_start
from ancf_sym.sensitivity.step_sequence import adaptive_steps, held_steps
from ancf_sym.sensitivity.rayleigh_beta import beta_pieces
from ancf_sym.sensitivity.water_derivative import water_refusals
from ancf_sym.system import water
from ancf_sym.system.damping import rayleigh_mx, strain_rate_mx
from ancf_sym.system.forces import ELASTIC_LABELS
from ancf_sym.system.step_system import StepSystem
from ancf_sym.util.casadi_buffers import bind
from ancf_sym.util.sparsity import dm

# -- parameters that the dynamics adds to the model's ---------------------------------------------------------------
def damping_index(doc: dict, path: str) -> int | None:
    """i of a path dampings[i].alpha | beta (Rayleigh coefficients) or dampings[i].axial | bending (strain-rate
    coefficients), else None; other damping keys refused by name."""
    p = parse_path(path)
    if p.keys[0] != "dampings":
        return None
    get_parameter(doc, path)
    d = doc["dampings"][p.keys[1]] if len(p.keys) == 3 else None
    ok = d is not None and ((d.get("type") == "rayleigh" and p.keys[2] in ("alpha", "beta")) or
                            (d.get("type") == "strain_rate" and p.keys[2] in ("axial", "bending")))
    if not ok:
        raise SceneError(f"parameter path {path!r}: differentiable damping coefficients: dampings[i].alpha | beta "
                         "of a rayleigh damping, dampings[i].axial | bending of a strain_rate damping")
    if p.keys[2] == "beta" and not d.get("beta"):
        raise SceneError(f"parameter path {path!r}: beta = 0 builds no stiffness damping in the run (its tangent "
                         "K_el is not formed); give beta > 0 to differentiate with respect to it")
    return p.keys[1]


def check_dynamic_paths(scene, doc: dict, paths: list[str], asm=None, options: DynamicOptions | None = None
                        ) -> None:
    """Refuse, before any step, a path that names no differentiable number of a dynamic run (asm: the run's
    assembly; default dynamic_assembly(scene), which also takes scenes with drives that statics refuses; options:
    the run's, for what a prestrain needs of them)."""
    model_paths = [p for p in paths if damping_index(doc, p) is None and dissipation_index(doc, p) is None]
    for p in model_paths:
        get_parameter(doc, p)
    asm = dynamic_assembly(scene) if asm is None else asm
    beta = any(d.get("type") == "rayleigh" and d.get("beta") for d in doc.get("dampings", []))
    for p in model_paths:
        md = model_derivative(asm, doc, p)
        if beta:
            _refuse_direction_with_beta(p, md)
        keys = parse_path(p).keys
        if keys[-1] == "prestrain":
            why = prestrain_run_refusal(asm, doc[keys[0]][keys[1]]["name"], options)
            if why is not None:
                raise SceneError(f"parameter path {p!r}: {why}")


def prestrain_run_refusal(asm, name: str, options: DynamicOptions | None) -> str | None:
    """Why a run's derivative by member `name`'s prestrain is not followed here (None: it is): a start at the
    reference moves with it (its slopes are (1 + eps) t: not followed here); the stiffness and strain-rate damping's
    kernels take the length too; a sensor or time load at a material coordinate moves in its element."""
    if options is not None and options.start != "static":
        return ("a prestrain in a run from the reference (the start's slopes (1 + eps) t move with it; "
                "start = \"static\" is differentiated)")
    if any(d.kind == "strain_rate" or (d.kind == "rayleigh" and d.beta) for d in asm.scene.dampings):
        return "a prestrain with strain-rate or stiffness-proportional damping (their kernels take the length)"
    for what, items in (("sensor", options.sensors if options is not None else []),
                        ("time load", options.loads if options is not None else [])):
        for it in items:
            member, at = (it.get("member"), it.get("at", "end")) if isinstance(it, dict) else (it.member, it.at)
            if member == name and isinstance(at, float):
                return f"a {what} at the material coordinate {at:g} on the member (it moves with the prestrain; " \
                       "put it at a node)"
    return None


def _refuse_direction_with_beta(path: str, md) -> None:
    """Stiffness damping beta K_el v differentiates through the elastic kernels' Hessians at P: a path whose
    kernels change nonlinearly (a DirectionPiece) would need d(K v)/dP, which is not compiled."""
    if any(isinstance(pc, DirectionPiece) and pc.label in ELASTIC_LABELS for pc in md.pieces):
        raise ParameterError(f"parameter path {path!r}: enters the elastic kernels nonlinearly; with stiffness-"
                             "proportional Rayleigh damping (beta) its derivative needs d(K v)/dp of those kernels, "
                             "which is not compiled")


def dynamic_assembly(scene):
    """The assembly a dynamic run of the scene uses: the statics' (shared, cached), or for a scene with drives
    (motion prescribed in time, which statics refuses) its own."""
    from ancf_sym.statics.problem import problem_for

    return Assembly(scene) if scene.drives else problem_for(scene).asm


def refuse_unsupported(S: StepSystem, opts: DynamicOptions, integ) -> None:
    """SceneError naming every feature of the run whose derivative is not propagated."""
    why = []
    if opts.integrator not in ("newmark", "hht", "generalized_alpha", "radau", "gauss"):
        why.append(f"integrator {opts.integrator!r} (alpha schemes and collocation only)")
    elif opts.integrator in ("radau", "gauss") and (S.mc or integ.kdamp.active or water.has_forces(S.asm)):
        why.append(f"integrator {opts.integrator!r} with constraint rows carrying multipliers, stiffness-"
                   "proportional Rayleigh damping or lines in water (collocation: sensitivities without them)")
    if S.mc and opts.start == "static" and (opts.release or opts.initial):
        why.append("a static start with constraint rows carrying multipliers, released or rotating (release, "
                   "initial)")
    if integ.kdamp.active:
        why += stiffness_damping_refusals(S)
    why += water_refusals(S, opts)
    if water.has_forces(S.asm) and (opts.initial or opts.v0 is not None or opts.from_result):
        why.append("lines in water from a moving start (initial, v0, from_result)")
    if why:
        raise SceneError("dynamic sensitivities: not available with " + ", ".join(why))


def elastic_terms(S: StepSystem) -> list:
    """The nonlinear terms in the Rayleigh elastic tangent K_el (elastic labels, a non-zero element weight)."""
    w = S.rayleigh.element_weight if (S.rayleigh is not None and S.rayleigh.beta) else {}
    return [(ti, mk.term) for ti, mk in enumerate(S.nonlinear)
            if mk.term.label in ELASTIC_LABELS and w.get(ti) is not None and np.any(np.asarray(w[ti]))]


def stiffness_damping_refusals(S: StepSystem) -> list[str]:
    """What of a stiffness-proportional Rayleigh damping the derivative does not follow: an elastic energy without
    compiled third derivatives (the kernels' Hessian-vector companions: cables' axial and bending, beam3d's elastic
    energies at their default quadrature). Betas per member (several entries) are followed
    (ancf_sym.sensitivity.rayleigh_beta)."""
    why = []
    for ti, t in elastic_terms(S):
        if not registry.has_third_derivatives(t.element, t.effect, t.gauss):
            why.append(f"stiffness-proportional Rayleigh damping (beta) on {t.element}/{t.effect} energies (gauss "
                       f"{t.gauss}: no compiled third derivatives)")
            break
    return why


def stiffness_damping_jacobian_mx(S: StepSystem, x: ca.MX, v: ca.MX) -> ca.MX:
    """beta d(K_el(q) v)/dq at (x, v) on the reduced coordinates, in a graph: the kernels' compiled Hessian-vector
    companions (q, P, v) -> (H v, d(H v)/dq) mapped over each elastic term's elements (exact third derivatives
    contracted with v), scattered by constant index maps."""
    X, V = S.x_full_mx(x), ca.mtimes(dm(S.E), v)
    n = S.E.shape[0]
    rows, cols, vals = [], [], []
    for ti, t in elastic_terms(S):
        ne, nd = t.idx.shape
        w = np.asarray(S.rayleigh.element_weight[ti], float) * np.ones(ne)
        f = kernels.load_hvp(t.element, t.effect).map(ne)
        Xe = ca.reshape(X[t.idx.ravel().tolist()], nd, ne)
        Ve = ca.reshape(V[t.idx.ravel().tolist()], nd, ne)
        D = f(Xe, ca.DM(np.asarray(t.P, float).T), Ve)[1]  # (nd, ne nd): block e is d(H_e v_e)/dq_e
        # (entry (i, e nd + j) of D: row idx[e, i], column idx[e, j], weight w_e)
        i, e, j = np.meshgrid(np.arange(nd), np.arange(ne), np.arange(nd), indexing="ij")
        rows.append(t.idx[e, i].ravel())
        cols.append(t.idx[e, j].ravel())
        # (ca.vec is column-major: entry (i, e nd + j) of D at (e nd + j) nd + i)
        order = ((e * nd + j) * nd + i).ravel()
        vals.append(ca.vec(D)[order.tolist()] * ca.DM(w[e.ravel()]))
    if not rows:
        return ca.MX(S.nf, S.nf)
    r, c = np.concatenate(rows), np.concatenate(cols)
    A = ca.DM(ca.Sparsity.triplet(n * n, len(r), (c * n + r).tolist(), list(range(len(r)))), 1.0)
    T = ca.reshape(ca.mtimes(A, ca.vertcat(*vals)), n, n)  # (column-major: entry (r, c) at c n + r)
    E = dm(S.E)
    return S.rayleigh.beta * ca.mtimes(E.T, ca.mtimes(T, E))


def _hessian_vectors(element: str, effect: str, gauss, idx: np.ndarray, P: np.ndarray, X: np.ndarray,
                     V: np.ndarray) -> np.ndarray:
    """sum_e H_e(x_k; P_e) v_k[idx_e] scattered on the full coordinates for every row k of X, V, (len(X), n): the
    kernel's Hessian-vector companion where compiled (one mapped call over every row's elements), else its Hessian."""
    ne, nd = idx.shape
    k, n = X.shape
    if registry.has_third_derivatives(element, effect, gauss):
        key = ("hvp", element, effect, k * ne)
        if key not in _MAPPED:
            _MAPPED[key] = kernels.load_hvp(element, effect).map(k * ne)
        hv = np.zeros(k * ne * nd)
        _, evaluate = bind(_MAPPED[key], [np.ascontiguousarray(X[:, idx]).ravel(),
                                          np.ascontiguousarray(np.tile(np.asarray(P, float), (k, 1))).ravel(),
                                          np.ascontiguousarray(V[:, idx]).ravel()], [hv])
        evaluate()
        hv = hv.reshape(k, ne * nd)
    else:
        key = ("full", element, effect, gauss, ne)
        if key not in _MAPPED:
            _MAPPED[key] = kernels.load(element, effect, gauss).map(ne)
        hv = np.zeros((k, ne * nd))
        for r in range(k):
            H = _MAPPED[key](X[r, idx].T, np.asarray(P, float).T)[2].full().reshape(nd, ne, nd).transpose(1, 0, 2)
            hv[r] = np.einsum("eij,ej->ei", H, V[r, idx]).ravel()
    return (_scatter(idx, n).T @ hv.T).T


def stiffness_damping_forcing(run: "AlphaRun", path: str) -> np.ndarray | None:
    """The Rayleigh stiffness damping's part of F_n on the reduced coordinates, (steps + 1, nf): d(beta K_el(q_{n-1})
    v_n)/dp at fixed states, beta dK_el/dp (q_{n-1}) v_n for a model path (the elastic pieces' Hessians) or
    K_el(q_{n-1}) v_n for dampings[i].beta; row 0 at q_0, v_0 (the start's acceleration). None: no beta, or
    the path changes no elastic energy."""
    S = run.S
    if not stiffness_damped(S):
        return None
    X, Vf = run.X, run.V_full
    i = damping_index(run.doc, path)
    if i is not None:
        if run.doc["dampings"][i]["type"] != "rayleigh" or parse_path(path).keys[2] != "beta":
            return None
        # (C's elastic part is sum_e beta_m(e) H_e: the Hessians on the members entry i gives their beta)
        pieces = beta_pieces(S, run.scene, i, None)
    else:
        md = model_derivative(run.asm, run.doc, path)
        _refuse_direction_with_beta(path, md)
        pieces = beta_pieces(S, run.scene, None, md.pieces)
    if not pieces:
        return None
    f = np.zeros(X.shape)
    Xp = np.vstack([X[:1], X[:-1]])  # (row n: K_el(q_{n-1}) v_n; row 0: the start's acceleration, C(q_0) v_0)
    for element, effect, gauss, idx, P, c in pieces:
        f += c * _hessian_vectors(element, effect, gauss, idx, P, Xp, Vf)
    return np.asarray((S.E.T @ f.T).T)


# -- the forward run: the package's compiled steps, every state kept -----------------------------------------------
def forward_states(S: StepSystem, integ, opts: DynamicOptions, loads: LoadSum | None = None
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(Q, V, A, Lam): reduced q, v, a and the true multipliers after each step (row 0: the start), from the
    integrator's compiled chunks (the run's own steps) and its per-step Newton where a chunk stops; loads: the time
    loads (LoadSum) or None."""
    h = opts.dt
    n = opts.n_grid
    nf, mc = S.nf, S.mc
    lam = slice(5 * nf, 5 * nf + mc)  # (the integrator's state: q, v, a, abar, a_prev, lam, controls)
    rows = [np.r_[integ.state[:3 * nf], integ.state[lam]]]
    size = chunk_size(n) if integ.chunkable else 0
    t, k = opts.t_start, 0
    pl = np.repeat(-S.f_lin[:, None], size, axis=1) if size else None
    if pl is not None:
        pl.flags.writeable = False  # (copied into the chunk's buffer once)
    while k < n:
        if size and n - k >= size:
            if loads is not None:  # (the loads at the chunk's step ends, as the time loop gives them)
                pl = -np.column_stack([S.f_lin + loads(opts.t_start + (k + j + 1) * h) for j in range(size)])
            plw = pl if not S.nw else \
                np.vstack([pl, np.column_stack([S.w(opts.t_start + (k + j + 1) * h) for j in range(size)])])
            states, n_ok = integ.run_chunk(h, plw)
            # (copies: the chunk buffer is reused by the next chunk)
            rows.extend(np.hstack([states[:, :3 * nf], states[:, lam]]))
            k += n_ok
            t = opts.t_start + k * h
            if n_ok == size:
                continue
        out = integ.attempt(t, h, loads)
        if not out.converged:
            raise SceneError(f"dynamic sensitivities: the step at t = {t:.6g} s did not converge ({out.reason}); "
                             "a fixed-step derivative cannot take a smaller step there (try a smaller dt)")
        integ.accept()
        rows.append(np.r_[integ.state[:3 * nf], integ.state[lam]])
        k += 1
        t = opts.t_start + k * h
    R = np.array(rows)
    return R[:, :nf], R[:, nf:2 * nf], R[:, 2 * nf:3 * nf], R[:, 3 * nf:]


@dataclass
class AlphaRun:
    """A run of the scene of `doc` kept for differentiation: the model (asm, S), the reduced states Q, V, A after
    each step (row 0: the start), the true multipliers Lam of the constraint rows and drives (steps + 1, mc), the
    full X, V_full, A_full, the step times t, the Rayleigh mass coefficient, the drives' time inputs W (steps + 1,
    nw); the start (RunStart) and, for a run whose steps are not all dt (adaptive, a shorter last step), the
    accepted step sizes H (steps,), else None."""
    doc: dict
    scene: object
    asm: object
    S: StepSystem
    options: DynamicOptions
    Q: np.ndarray
    V: np.ndarray
    A: np.ndarray
    t: np.ndarray
    alpha_r: float
    Lam: np.ndarray
    W: np.ndarray
    start: RunStart | None = None
    H: np.ndarray | None = None

    @property
    def X(self) -> np.ndarray:
        return self.S.full_rows(self.Q)

    @property
    def V_full(self) -> np.ndarray:
        return self.S.full_v_rows(self.V)

    @property
    def A_full(self) -> np.ndarray:
        return self.S.full_v_rows(self.A)


def run_for_sensitivity(doc: dict | str, paths: list[str], options: DynamicOptions,
                        steps: np.ndarray | None = None) -> AlphaRun:
    """Check the run and the paths (refused before any step), then run the scene with the package's own alpha
    steps from the start simulate builds (ancf_sym.sensitivity.run_start): fixed steps of dt (a shorter last one
    taken as the run takes it), the adaptive run's accepted steps, or `steps` (step sizes [s]) held as given."""
    d = read_document(doc)
    given, _ = scene_from_dict(d)
    # release: the run's scene lacks the released supports, its start is the equilibrium of the given scene
    scene = released_scene(given, options.release) if options.release else given
    asm = Assembly(scene) if options.release else dynamic_assembly(scene)
    check_dynamic_paths(scene, d, list(paths), asm, options)
    contact.check_dynamics(asm)  # (exact contact is a statics method: refused as the run refuses it)
    S = StepSystem.for_scene(asm, linsol="auto_lu")  # (the time steps as simulate takes them: sparse LU)
    integ = make_integrator(S, options, Counters(), 0.0, options.newton.xtol * S.length_scale)
    refuse_unsupported(S, options, integ)
    if options.integrator in ("radau", "gauss"):
        raise SceneError(f"dynamic sensitivities: integrator {options.integrator!r}: the alpha schemes' run; "
                         "collocation runs: ancf_sym.sensitivity.collocation_run")
    nf = S.nf
    start = run_start(given, asm, options)
    # (a drive that starts with a velocity jump from this start: refused as the run refuses it)
    check_drives_at_start(S, asm, start.q0, start.v0, options, max(1e-8, 10 * options.newton.xtol) * S.length_scale)
    # time loads (analysis.loads): a forcing that no scene parameter changes, applied as the run applies it
    loads = LoadSum(options.loads, asm, S.E) if options.loads else None
    Q0 = loads(options.t_start) if loads else np.zeros(nf)
    integ.initialize(S.reduce(start.q0), S.reduce(start.v0), Q0, options.t_start)
    integ.tol_q = options.newton.tol * max(float(np.max(np.abs(S.f_lin))), float(np.max(np.abs(S.M @ integ.a))),
                                           float(np.max(np.abs(Q0))), 1e-300)
    lam = slice(5 * nf, 5 * nf + S.mc)  # (the integrator's state: q, v, a, abar, a_prev, lam, controls)

    def row() -> np.ndarray:
        return np.r_[integ.state[:3 * nf], integ.state[lam]]
    H = None if steps is None else np.asarray(steps, float).ravel()
    last = options.t_end - (options.t_start + options.n_grid * options.dt)
    if H is not None:
        R = np.array(held_steps(integ, options.t_start, H, loads, row))
    elif options.adaptive:
        rows, H = adaptive_steps(S, integ, options, loads, row)
        R = np.array(rows)
    else:
        Q, V, A, Lam = forward_states(S, integ, options, loads)
        R = np.hstack([Q, V, A, Lam])
        if last > 1e-9 * options.dt:  # (a shorter last step, as the time loop takes it)
            R = np.vstack([R, held_steps(integ, options.t_start + options.n_grid * options.dt, [last], loads,
                                         row)[1:]])
            H = np.r_[np.full(options.n_grid, options.dt), last]
    Q, V, A, Lam = R[:, :nf], R[:, nf:2 * nf], R[:, 2 * nf:3 * nf], R[:, 3 * nf:]
    t = options.t_start + (options.dt * np.arange(len(Q)) if H is None else np.r_[0.0, np.cumsum(H)])
    W = np.array([S.w(ti) for ti in t]).reshape(len(t), S.nw)
    return AlphaRun(d, scene, asm, S, options, Q, V, A, t, S.rayleigh.alpha if S.rayleigh is not None else 0.0,
                    Lam, W, start, H)


def _scatter(idx: np.ndarray, n: int) -> sp.csr_matrix:
    """(ne nd) -> n: the sum of element vectors into the full coordinates."""
    k = idx.size
    return sp.csr_matrix((np.ones(k), (np.arange(k), idx.ravel())), shape=(k, n))


_MAPPED: dict = {}


def _mapped_grad(pc, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(element energies (k ne), element gradients (k ne nd)) of a piece or term at every state (rows of X): one
    mapped call of its gradient kernel."""
    ne, nd = pc.idx.shape
    k = len(X)
    key = (pc.element, pc.effect, pc.gauss, k * ne)
    if key not in _MAPPED:
        _MAPPED[key] = kernels.load_grad(pc.element, pc.effect, pc.gauss).map(k * ne)
    e, g = np.zeros(k * ne), np.zeros(k * ne * nd)
    _, evaluate = bind(_MAPPED[key], [np.ascontiguousarray(X[:, pc.idx]).ravel(),
                                      np.ascontiguousarray(np.tile(np.asarray(pc.P, float), (k, 1))).ravel()], [e, g])
    evaluate()
    return e, g


def _gradients(pc, X: np.ndarray) -> np.ndarray:
    """The piece's assembled gradient at every state (rows of X), (len(X), n): one mapped kernel call."""
    ne, nd = pc.idx.shape
    _, g = _mapped_grad(pc, X)
    return (_scatter(pc.idx, X.shape[1]).T @ g.reshape(len(X), ne * nd).T).T


def _energies(term, X: np.ndarray) -> np.ndarray:
    """A term's element energies at every state (rows of X), (len(X), elements): one mapped kernel call."""
    return _mapped_grad(term, X)[0].reshape(len(X), term.idx.shape[0])


def contact_notes(run: AlphaRun) -> list[str]:
    """Where the run's penalty contacts open or close: the steps after which the set of elements with contact
    energy differs from the step before. The law's force has a kink at zero gap, so the step map is not
    differentiable where a contact point sits exactly there, and the derivative jumps as a parameter moves a
    contact event across a step: the notes name those steps."""
    X = run.X
    change = np.zeros(len(X) - 1, bool)
    terms = [t for t in run.asm.terms if t.label.startswith("contact")]
    for t in terms:
        on = _energies(t, X) > 0.0
        change |= np.any(on[1:] != on[:-1], axis=1)
    if not terms:
        return []
    times = run.t[1:][change]
    extra = dissipation_notes(run)  # (contact damping and friction: by contact point, and the friction law)
    if not len(times):
        return ["contacts: no contact opens or closes along the run (the derivative is that of the penalty law)"] \
            + extra
    return [f"contacts open or close in {len(times)} step(s) (first at t = {times[0]:.6g} s, last at "
            f"{times[-1]:.6g} s): the penalty force has a kink at zero gap, so the derivative there is one-sided "
            "and jumps where a parameter moves a contact event across a step; differences of runs across those "
            "steps are not smooth"] + extra


def forcing(run: AlphaRun, path: str, statics: bool = False) -> np.ndarray:
    """F_n on the reduced coordinates for every step, (steps + 1, nf): E' (dR/dp(x_n) + dM/dp (a_n + alpha_R v_n))
    and, for dampings[i].alpha, M v_n. statics: E' dR/dp(x_0) alone (the static start's right-hand side)."""
    S = run.S
    if dissipation_index(run.doc, path) is not None:  # (contacts[i].mu | damping: the dissipation force alone)
        return np.zeros((1, S.nf)) if statics else dissipation_forcing(run, path)
    i = damping_index(run.doc, path)
    if i is not None:
        if statics:
            return np.zeros((1, S.nf))
        if run.doc["dampings"][i]["type"] == "rayleigh":
            if parse_path(path).keys[2] == "beta":  # (None: the entry's beta acts on no element, later ones win)
                sd = stiffness_damping_forcing(run, path)
                return np.zeros((len(run.Q), S.nf)) if sd is None else sd
            return run.V @ S.M
        return strain_rate_forcing(run, i, parse_path(path).keys[2])
    md = model_derivative(run.asm, run.doc, path)
    X = run.X[:1] if statics else run.X
    R = np.zeros(X.shape)
    for pc in md.pieces:
        if isinstance(pc, (LengthPiece, DirectionPiece)):  # (a prestrain's length derivative, a kernel's
            # parameter-direction companion: at every state)
            R += pc.gradients(X)
        elif pc.effect == "gravity":  # (linear in q: a constant gradient)
            R += _gradients(pc, X[:1])
        else:
            R += _gradients(pc, X)
    if md.dQ is not None:
        R -= md.dQ
    if md.water is not None:  # (lines in water: the drag, water line and waves' forces; statics: at rest)
        R += md.water.forcing(X, None if statics else run.V_full, None if statics else run.t, run.A_full)
    if not statics and md.dM is not None:
        R += (md.dM @ (run.A_full + run.alpha_r * run.V_full).T).T
    F = np.asarray((S.E.T @ R.T).T)
    if statics:
        return F
    for extra in (stiffness_damping_forcing(run, path), dissipation_forcing(run, path)):  # (beta; friction's k)
        if extra is not None:
            F = F + extra
    return F


_UNIT_F: dict = {}


def strain_rate_forcing(run: AlphaRun, i: int, which: str) -> np.ndarray:
    """d f_d / d c at every state (rows): the strain-rate force with the coefficient `which` (axial | bending) of
    damping i set to 1 on its members' points and every other coefficient 0 (f_d is linear in them)."""
    S, sr = run.S, run.S.strain_rate
    mask = point_mask(run, i)
    unit = replace(sr, c_axial=mask * (which == "axial"), c_bending=mask * (which == "bending"))
    key = (S.graph_key, i, which, len(run.Q), unit.c_axial.tobytes(), unit.c_bending.tobytes())
    if key not in _UNIT_F:
        xf, vf = ca.MX.sym("x", S.nf), ca.MX.sym("v", S.nf)
        X, V = S.x_full_mx(xf), ca.mtimes(dm(S.E), vf)
        f = ca.Function("unit_strain_rate", [xf, vf], [strain_rate_mx(unit, xf, X, V, vf)[0]])
        _UNIT_F[key] = f.map(len(run.Q))
    return np.asarray(_UNIT_F[key](run.Q.T, run.V.T)).T


def point_mask(run: AlphaRun, i: int) -> np.ndarray:
    """1 at the strain-rate damping's Gauss points on the members of dampings[i], else 0, in the point order of
    ancf_sym.system.damping.strain_rate_data (members in order of first mention, elements, 5 points each)."""
    scene = run.scene
    order: list = []
    for d in scene.dampings:
        if d.kind == "strain_rate":
            order += [name for name in (d.members or list(scene.members)) if name not in order]
    d_i = scene.dampings[i]  # (the TOML reader adds one Damping per [[dampings]] entry, in order)
    mine = set(d_i.members or list(scene.members))
    return np.concatenate([np.full(len(run.asm.mesh.members[name].elem_nodes) * 5, float(name in mine))
                           for name in order])


def damping_tangents(S: StepSystem, x: ca.MX, v: ca.MX, t: ca.MX | None = None) -> tuple:
    """(df_d/dx, df_d/dv) of the system's velocity-dependent damping force at (x, v) in a graph, or (None, None);
    t: the time, where the force reads it (lines in water under waves)."""
    if S.damp_f is None:
        return None, None
    _, dfx, dfv = S.damp_f(x, v, t) if water.timed(S.asm) else S.damp_f(x, v)
    return dfx, dfv


def step_inputs(S: StepSystem) -> int:
    """The size of a step's extra input y = [lam; w] of step_matrix (the multipliers, the drives' time inputs), 0:
    none."""
    return S.mc + S.nw if (S.mc or S.nw) else 0


def stiffness_damped(S: StepSystem) -> bool:
    """The run has stiffness-proportional Rayleigh damping (beta K_el(q_n))."""
    return S.rayleigh is not None and bool(S.rayleigh.beta)


def damping_matrices(S: StepSystem, alpha_r: float, xp: ca.MX | None, v: ca.MX) -> tuple[ca.MX, ca.MX | None]:
    """(C_n, T_n) of the Rayleigh damping over the step from q_n = xp to v_{n+1} = v: C_n = alpha M + beta K_el(q_n)
    (the run's: K_el at the step's start) and T_n = beta d(K_el(q) v)/dq at q_n (None without beta)."""
    if xp is None or S.rayleigh is None or not S.rayleigh.beta:
        return alpha_r * dm(S.M), None
    kel = S.forces_pf(xp, ca.DM(S.par))[2]
    return rayleigh_mx(S, v, kel)[1], stiffness_damping_jacobian_mx(S, xp, v)


def step_matrix(S: StepSystem, cm: float, cc: float, C: ca.MX, x: ca.MX, v: ca.MX, y: ca.MX | None
                ) -> tuple[ca.MX, ca.MX | None, str]:
    """(A, df_d/dv, linear solver): the differentiated step's matrix at the step's end in a graph, A = cm M + cc C +
    K(x) (+ df_d/dx + cc df_d/dv) and, with constraint rows or drives, the KKT matrix [[A + H, kc J'], [kc J, 0]]
    with J = dPhi/dx(x, w), H = d2(lam . Phi)/dx2 (y = [lam; w]: the true multipliers and the drives' time inputs,
    None without drives or rows), kc = cm max diag M (the solution's multiplier part: dlam / kc); applied torques
    add minus their force's Jacobian to A."""
    nf, mc = S.nf, S.mc
    A = cm * dm(S.M) + cc * C + S.forces_pf(x, ca.DM(S.par))[1]
    # (strain-rate damping, lines in water: their exact tangents at the step's end; under waves at its time, the
    # last of the time inputs)
    dfx, dfv = damping_tangents(S, x, v, y[-1] if water.timed(S.asm) else None)
    unsym = dfx is not None
    if dfx is not None:
        A = A + dfx + cc * dfv
    lam, w = (y[:mc], y[mc:]) if y is not None else (None, None)
    tq = S.torque_mx(x, w) if w is not None else None
    if tq is not None:  # (applied torques tau(t) (-s, c): their tangent, skew)
        A = A - ca.jacobian(tq, x)
        unsym = True
    if not mc:
        return A, dfv, "qr" if unsym else "ldl"  # (d f_d / dq, a torque's tangent: unsymmetric, QR)
    phi = S.constraint_mx(x, w)
    Jx = ca.jacobian(phi, x)
    if S.bilinear:
        A = A + ca.hessian(ca.dot(lam, phi), x)[0]
    # (rows scaled by kc = cm max diag M as the run's step scales them: the KKT matrix's blocks of one size, its
    # condition that of the run's; the solution's multiplier part is dlam / kc)
    kc = cm * S.stiffness_scale()
    return ca.blockcat([[A, kc * Jx.T], [kc * Jx, ca.MX(mc, mc)]]), dfv, "qr"  # (indefinite: QR)


def start_tangent(run: AlphaRun) -> sp.csc_matrix:
    """K(q_0) on the reduced coordinates: the static start's tangent and the initial acceleration's (with the
    velocity-dependent forces' d f_d/dq at rest: lines in water, whose drag in a current and water line act at
    rest; refused under waves, water_refusals)."""
    S = run.S
    K = sp.csc_matrix(S.forces(run.Q[0])[1])
    if S.damp_f is not None and not water.timed(S.asm):
        K = (K + sp.csc_matrix(S.damp_f(run.Q[0], np.zeros(S.nf))[1].sparse())).tocsc()
    return K

