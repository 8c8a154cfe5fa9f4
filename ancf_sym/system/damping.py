"""Damping of the equations of motion, in one place: what the scene asks for (Rayleigh, strain-rate damping of
cables, dissipative contact) and the forces and exact tangents the step graphs and the time loop use.

- Rayleigh C = alpha M + beta K_el(q_n): mass-proportional, and stiffness-proportional on the elastic tangent at
  the start of each step (ancf_sym.dynamics.stiffness_damping keeps it), with per-member weights (`rayleigh_data`);
- Kelvin-Voigt strain-rate damping of cables, the dissipation D = 1/2 sum_points w L (c_axial eps_dot^2 +
  c_bending |kappa_dot|^2) at 5 Gauss points per element (`strain_rate_data`), force and tangents by AD of one
  vectorized graph;
- contact damping and friction: the compiled dissipation kernels the scene's contacts declare
  (`contact.dissipation_calls`), force and tangents from their gradient and Hessian blocks.

`dissipation_functions(S)` gives the step system's velocity-dependent force f_d(x, v) with df_d/dx, df_d/dv (the
last two terms); `rayleigh_mx` the Rayleigh part inside a graph; `damping_force` the whole damping force at a state.
S in the signatures: the step system the graphs are built for (ancf_sym.system.interface.StepSystemView).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym.contact import laws as contact
from ancf_sym import kernels
from ancf_sym.model.assembly import Assembly
from ancf_sym.elements.quadrature import gauss01
from ancf_sym.elements.hermite import weights
from ancf_sym.scene.member_effects import AXIAL_STRAINS
from ancf_sym.scene.builder import SceneError
from ancf_sym.util.casadi_buffers import bind
from ancf_sym.util.sparsity import casadi_sparsity, csc_pattern, dm, gather_sum, scatter
from ancf_sym.system import contact_reach
from ancf_sym.system.interface import StepSystemView


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


def rayleigh_data(asm: Assembly, terms: list) -> RayleighData | None:
    """Rayleigh damping requested by the scene (scene.dampings) with per-element weights of each term."""
    scene = asm.scene
    ds = [d for d in getattr(scene, "dampings", []) if d.kind == "rayleigh"]
    if not ds:
        return None
    alphas = {d.alpha for d in ds if d.alpha}
    if len(alphas) > 1 or any(d.members is not None for d in ds if d.alpha):
        raise SceneError("mass-proportional Rayleigh damping (alpha) must be one value for the whole scene, got "
                         f"{sorted(alphas)}")
    alpha = alphas.pop() if alphas else 0.0
    betas = {}
    for d in ds:
        if d.beta:
            for name in (d.members or list(scene.members)):
                betas[name] = d.beta
    beta_ref = max(betas.values()) if betas else 0.0
    weights = {}
    if beta_ref:
        starts = np.array([mm.offset for mm in asm.mesh.members.values()])
        factor = np.array([betas.get(name, 0.0) / beta_ref for name in asm.mesh.members])
        for ti, mk in enumerate(terms):
            member = np.searchsorted(starts, mk.term.idx[:, 0], side="right") - 1
            weights[ti] = factor[member]
    return RayleighData(float(alpha), float(beta_ref), weights)


def strain_rate_data(asm: Assembly) -> StrainRateData | None:
    """Gauss points (5 per element) of the members with strain-rate damping: r_x and r_xx as sparse maps."""
    ds = [d for d in getattr(asm.scene, "dampings", []) if d.kind == "strain_rate"]
    if not ds:
        return None
    coef: dict[str, list] = {}
    for d in ds:
        for name in (d.members or list(asm.scene.members)):
            c = coef.setdefault(name, [0.0, 0.0])
            c[0], c[1] = c[0] + d.axial, c[1] + d.bending
    dim = asm.scene.dim
    xi, wq = gauss01(5)
    rows_x, rows_xx, wl, ca_, cb_, green = [], [], [], [], [], []
    for name, (c_ax, c_be) in coef.items():
        mm = asm.mesh.members[name]
        if mm.member.element == "beam3d":
            raise SceneError(f"strain_rate_damping: member {name!r} is a beam3d (cables only)")
        for e, (na, nb) in enumerate(mm.elem_nodes):
            L = mm.elem_length[e]
            da, db = mm.node_dofs(na), mm.node_dofs(nb)
            _, wx, wxx = weights(xi, L)  # (4, 5)
            for k in range(5):
                rows_x.append((da, db, list(wx[:, k])))
                rows_xx.append((da, db, list(wxx[:, k])))
                wl.append(wq[k] * L)
                ca_.append(c_ax)
                cb_.append(c_be)
                green.append(mm.member.axial is not None and AXIAL_STRAINS[mm.member.axial].rate == "green")
    P = len(wl)

    def matrix(rows):
        r, c, v = [], [], []
        for p, (da, db, w) in enumerate(rows):
            for comp in range(dim):
                for dofs, w_r, w_t in ((da, w[0], w[1]), (db, w[2], w[3])):
                    r += [comp * P + p, comp * P + p]
                    c += [dofs[comp], dofs[dim + comp]]
                    v += [w_r, w_t]
        return sp.csr_matrix((v, (r, c)), shape=(dim * P, asm.n))

    return StrainRateData(dim, matrix(rows_x), matrix(rows_xx), np.array(wl), np.array(ca_), np.array(cb_),
                          np.array(green))


def rayleigh_mx(S: StepSystemView, v: ca.MX, kel: ca.MX | None) -> tuple[ca.MX, ca.MX]:
    """(C v, C) as MX for C = alpha M + beta K_el (kel: its values, or None) on the unknowns of S."""
    nf = S.nf
    Cv, C = ca.MX.zeros(nf), ca.MX(nf, nf)
    if S.rayleigh is None:
        return Cv, C
    Mdm = S.mass_dm()
    if S.rayleigh.alpha:
        Cv += S.rayleigh.alpha * S.mass_mx(v)
        C = C + S.rayleigh.alpha * Mdm
    if kel is not None:
        Kel = ca.MX(S.kel_sparsity, kel)
        Cv += S.rayleigh.beta * ca.mtimes(Kel, v)
        C = C + S.rayleigh.beta * Kel
    return Cv, C


def rayleigh_matrix(S: StepSystemView, kel: np.ndarray | None) -> sp.csc_matrix | None:
    """C = alpha M + beta K_el on the unknowns of S (kel: the values of K_el, or None), None without Rayleigh."""
    if S.rayleigh is None:
        return None
    C = S.rayleigh.alpha * S.M
    if kel is not None and S.kel_sparsity is not None:
        spk = S.kel_sparsity
        C = C + S.rayleigh.beta * sp.csc_matrix((kel, np.array(spk.row()), np.array(spk.colind())),
                                                shape=(S.nf, S.nf))
    return sp.csc_matrix(C)


def strain_rate_mx(sr: StrainRateData, xf: ca.MX, X: ca.MX, V: ca.MX, vf: ca.MX,
                   E: sp.spmatrix | None = None, cc: ca.MX | None = None) -> list[ca.MX]:
    """(f_d, df_d/dx, df_d/dv) of the strain-rate dissipation for full coordinates X and velocities V (MX in the
    unknowns xf, vf): exact derivatives by AD of one vectorized graph, or (axial damping only, E = dX/dxf given)
    in closed form (_axial_rate_mx). With cc (the step's velocity coefficient): (f_d, df_d/dx + cc df_d/dv)."""
    if E is not None and not np.any(sr.c_bending):
        return _axial_rate_mx(sr, X, V, E, cc)
    if cc is not None:
        f, dfx, dfv = strain_rate_mx(sr, xf, X, V, vf, E)
        return [f, dfx + cc * dfv]
    d = sr.dim
    P = len(sr.wL)
    R, Rd, RR = ca.mtimes(dm(sr.Bx), X), ca.mtimes(dm(sr.Bx), V), ca.mtimes(dm(sr.Bxx), X)
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
    return [fd, ca.jacobian(fd, xf), ca.jacobian(fd, vf)]


def _axial_rate_mx(sr: StrainRateData, X: ca.MX, V: ca.MX, E: sp.spmatrix, cc: ca.MX | None = None) -> list[ca.MX]:
    """Axial strain-rate damping D = 1/2 sum_p c_p w_p edot_p^2 in closed form: edot = m (r_x . r_x'), m = 1
    (Green) or 1/|r_x| (Biot), so f = B^T [c w edot m r_x] and both tangents are B^T A_p B with 2 x 2 (3 x 3) point
    blocks A_p (B = Bx E: r_x of the unknowns), assembled by one constant sparse map from the blocks to the
    nonzeros. The same derivatives as AD of the graph (to round-off), at half its cost on a 48-element belt (221 ->
    111 us): AD's Jacobian runs one directional pass per colour of the closed loop's pattern."""
    d, P = sr.dim, len(sr.wL)
    Bu = sp.csr_matrix(sr.Bx @ E)
    Bu.sort_indices()
    R, Rd = ca.mtimes(dm(sr.Bx), X), ca.mtimes(dm(sr.Bx), V)
    rx = [R[k * P:(k + 1) * P] for k in range(d)]
    rd = [Rd[k * P:(k + 1) * P] for k in range(d)]
    n2 = sum(c * c for c in rx)
    dot = sum(a * b for a, b in zip(rx, rd))
    g = ca.DM(sr.green.astype(float))
    s = ca.sqrt(n2)
    m = g + (1 - g) / s  # d edot / d r_x' = m r_x
    ed = m * dot
    cw = ca.DM(sr.c_axial * sr.wL)
    f = ca.densify(ca.mtimes(dm(sp.csr_matrix(Bu.T)), ca.vertcat(*[cw * ed * m * rx[a] for a in range(d)])))
    s3 = n2 * s
    de = [g * rd[b] + (1 - g) * (rd[b] / s - dot * rx[b] / s3) for b in range(d)]  # d edot / d r_x
    dm_ = [-(1 - g) * rx[b] / s3 for b in range(d)]  # d m / d r_x
    Av, Ax = [], []
    for a in range(d):
        for b in range(d):
            Av.append(cw * m * m * rx[a] * rx[b])
            Ax.append(cw * ((de[b] * m + ed * dm_[b]) * rx[a] + (ed * m if a == b else 0)))
    pattern, M = _block_map(Bu, d, P)
    if cc is not None:  # (the step's df/dx + cc df/dv: the point blocks summed, one map to the nonzeros)
        return [f, ca.MX(pattern, ca.mtimes(M, ca.vertcat(*Ax) + cc * ca.vertcat(*Av)))]
    return [f, ca.MX(pattern, ca.mtimes(M, ca.vertcat(*Ax))), ca.MX(pattern, ca.mtimes(M, ca.vertcat(*Av)))]


def _block_map(Bu: sp.csr_matrix, d: int, P: int) -> tuple[ca.Sparsity, ca.DM]:
    """Pattern of sum_p B_p^T A_p B_p (B_p: rows p, P + p, ... of Bu) and the constant sparse map from the point
    blocks, stacked (a, b, p) -> (a d + b) P + p, to its nonzeros."""
    nf = Bu.shape[1]
    coo = Bu.tocoo()
    rows, cols, vals = coo.row, coo.col, coo.data
    r, c, w, src = [], [], [], []
    for a in range(d):
        for b in range(d):
            ka = np.flatnonzero((rows >= a * P) & (rows < (a + 1) * P))
            pa = rows[ka] - a * P
            lo, hi = Bu.indptr[b * P + pa], Bu.indptr[b * P + pa + 1]
            rep = hi - lo
            left = np.repeat(ka, rep)
            right = np.repeat(lo, rep) + np.arange(rep.sum()) - np.repeat(np.cumsum(rep) - rep, rep)
            r.append(cols[left])
            c.append(Bu.indices[right])
            w.append(vals[left] * Bu.data[right])
            src.append((a * d + b) * P + np.repeat(pa, rep))
    r, c, w, src = map(np.concatenate, (r, c, w, src))
    indptr, indices, inv = csc_pattern(r, c, nf, nf)
    M = sp.csr_matrix((w, (inv, src)), shape=(len(indices), d * d * P))
    return casadi_sparsity(nf, nf, indptr, indices), dm(M)


def _contact_inputs(S: StepSystemView, X: ca.MX, V: ca.MX):
    """Per dissipation call (kernel, element inputs Z = [x; v] (2 nd x N), parameters, idx, nd, N)."""
    for element, effect, gauss, idx, P in contact.dissipation_calls(S.asm.mesh):
        N, nd = idx.shape
        Z = ca.vertcat(ca.reshape(X[idx.ravel().tolist()], nd, N), ca.reshape(V[idx.ravel().tolist()], nd, N))
        yield element, effect, None if gauss == 5 else gauss, Z, ca.DM(P.T), idx, nd, N


def contact_dissipation_mx(S: StepSystemView, X: ca.MX, V: ca.MX, cc: ca.MX | None = None):
    """(f, df/dx, df/dv) on the unknowns of step system S, for full coordinates X and velocities V (MX in S's
    unknowns x, v), or None without dissipative contact. From the kernels' _rows companions (the force dD/dv and
    its Jacobian blocks [df/dq, df/dv], the v-rows of D's Hessian): exact tangents, no differentiation through
    the compiled calls, no work on the Hessian's q-q block. With cc (the step's velocity coefficient, MX): (f,
    df/dx + cc df/dv), the two blocks of each element summed before one scatter (the step matrix's term: half the
    scatter work)."""
    if not contact.dissipation_calls(S.asm.mesh):
        return None
    if cc is not None:
        return _contact_step_tangent(S, X, V, cc)
    nf, pos = S.nf, S.pos
    fv, ft, hv, rx, cx, sx, rv, cv, sv = [], [], [], [], [], [], [], [], []
    n_h, balls = 0, {}
    for element, effect, gauss, Z, Pd, idx, nd, N in _contact_inputs(S, X, V):
        rows = kernels.load_rows(element, effect, gauss)  # (only the blocks in reach: ancf_sym.system.contact_reach)
        F, J = contact_reach.call(rows.map, element, effect, idx, Z, Pd, X, S.asm.scene.dim, balls)
        # F (nd x N), J (nd x 2nd N)
        fv.append(ca.vec(F))
        ft.append(pos[idx.ravel()])  # vec of F: element e, row a -> coordinate idx[e, a]
        hv.append(ca.vec(J))
        # vec(J) entry e nd 2nd + b nd + a is df_a / dz_b; columns b < nd (x), >= nd (v)
        e, b, a = np.meshgrid(np.arange(N), np.arange(2 * nd), np.arange(nd), indexing="ij")
        src = n_h + (e * (2 * nd * nd) + b * nd + a).ravel()
        e, b, a = e.ravel(), b.ravel(), a.ravel()
        row = pos[idx[e, a]]
        col = pos[idx[e, b % nd]]
        ok = (row >= 0) & (col >= 0)
        for sel, R, C, S_ in ((ok & (b < nd), rx, cx, sx), (ok & (b >= nd), rv, cv, sv)):
            R.append(row[sel])
            C.append(col[sel])
            S_.append(src[sel])
        n_h += N * 2 * nd * nd
    f = gather_sum(fv, np.concatenate(ft), nf)
    dfx = scatter(hv, np.concatenate(rx), np.concatenate(cx), nf, np.concatenate(sx), n_h)
    dfv = scatter(hv, np.concatenate(rv), np.concatenate(cv), nf, np.concatenate(sv), n_h)
    return f, dfx, dfv


def _contact_step_tangent(S: StepSystemView, X: ca.MX, V: ca.MX, cc: ca.MX) -> tuple:
    """(f, df/dx + cc df/dv) of contact_dissipation_mx: per element the x block plus cc times the v block of the
    kernel's Jacobian (nd x 2 nd), then one scatter of the nd x nd sums."""
    nf, pos = S.nf, S.pos
    fv, ft, hv, rr, cl, srcs = [], [], [], [], [], []
    n_h, balls = 0, {}
    for element, effect, gauss, Z, Pd, idx, nd, N in _contact_inputs(S, X, V):
        rows = kernels.load_rows(element, effect, gauss)  # (only the blocks in reach: ancf_sym.system.contact_reach)
        F, J = contact_reach.call(rows.map, element, effect, idx, Z, Pd, X, S.asm.scene.dim, balls)
        fv.append(ca.vec(F))
        ft.append(pos[idx.ravel()])
        # J's columns: element e's x block at 2 e nd + b, its v block at (2 e + 1) nd + b; as nd^2 x 2N the blocks
        # are the even and odd columns
        Jr = ca.reshape(J, nd * nd, 2 * N)
        hv.append(ca.vec(Jr[:, 0::2] + cc * Jr[:, 1::2]))  # entry e nd^2 + b nd + a: d f_a / d z_b
        e, b, a = np.meshgrid(np.arange(N), np.arange(nd), np.arange(nd), indexing="ij")
        row, col = pos[idx[e, a]].ravel(), pos[idx[e, b]].ravel()
        ok = (row >= 0) & (col >= 0)
        rr.append(row[ok])
        cl.append(col[ok])
        srcs.append(n_h + np.flatnonzero(ok))
        n_h += N * nd * nd
    f = gather_sum(fv, np.concatenate(ft), nf)
    return f, scatter(hv, np.concatenate(rr), np.concatenate(cl), nf, np.concatenate(srcs), n_h)


def contact_dissipation_force_mx(S: StepSystemView, X: ca.MX, V: ca.MX):
    """The force f of contact_dissipation_mx alone, from the kernels' (energy, gradient) companions: no Hessian
    work (the same gradient, summed in the same order), or None without dissipative contact."""
    if not contact.dissipation_calls(S.asm.mesh):
        return None
    fv, ft, balls = [], [], {}
    for element, effect, gauss, Z, Pd, idx, nd, N in _contact_inputs(S, X, V):
        grad = kernels.load_grad(element, effect, gauss)
        _, G = contact_reach.call(grad.map, element, effect, idx, Z, Pd, X, S.asm.scene.dim, balls)
        fv.append(ca.vec(G[nd:, :]))
        ft.append(S.pos[idx.ravel()])
    return gather_sum(fv, np.concatenate(ft), S.nf)


def _reach_switch(S: StepSystemView, xf: ca.MX, vf: ca.MX, X: ca.MX, dc: tuple, extra: tuple = ()) -> tuple:
    """The contact dissipation dc = (f, df/dx, df/dv) evaluated only where some element is in reach of a dissipative
    contact's surface at the iterate x itself: elsewhere every kernel returns exact zeros (the law is 0 at a positive
    gap, contact.gap's hull bound is below every gap the kernels sample), so a switch that skips them gives the same
    values bit for bit, and no margin is needed (the test is made at each point the step evaluates). A drum carried
    by a body (no fixed centre for the bound) keeps the kernels always on."""
    from ancf_sym.contact import gap as contact_gap

    bounds = []
    for c in getattr(S.asm.scene, "contacts", ()):
        if not c.dissipative:
            continue
        b = contact_gap.gap_lower_bound_mx(S.asm, c, X)
        if b is None:
            return dc
        # out of reach only by more than round-off of the positions: the kernels' own gaps then stay positive
        floor = contact_gap.FLOOR * float(np.max(S.asm.mesh.members[c.member].elem_length))
        bounds.append(ca.mmin(b) - floor)
    ins = [xf, vf, *extra]  # (extra: the step's velocity coefficient of the summed tangent)
    reach = ca.Function("contact_dissipation_all", ins, list(dc))
    none = ca.Function("contact_out_of_reach", ins, [ca.MX.zeros(o.sparsity()) for o in dc])
    switch = ca.Function.conditional("contact_dissipation_in_reach", [none], reach)  # 0: none in reach
    in_reach = ca.mmin(ca.vertcat(*bounds)) <= 0
    out = switch(in_reach, *ins)
    return (out,) if len(dc) == 1 else tuple(out)


def step_tangent_function(S: StepSystemView) -> ca.Function | None:
    """damp_step_f(x, v[, t], cc) -> (f_d, df_d/dx + cc df_d/dv): damp_f's force and its term of the step matrix,
    with dissipative contact's two blocks summed per element before their scatter (half its scatter work, one
    sparse sum less in the step); None where damp_f is None."""
    from ancf_sym.system import water

    if S.damp_f is None:
        return None
    nf = S.nf
    xf, vf, cc = ca.MX.sym("x", nf), ca.MX.sym("v", nf), ca.MX.sym("cc")
    t = ca.MX.sym("t") if water.timed(S.asm) else None
    ins, names = ([xf, vf], ["x", "v"]) if t is None else ([xf, vf, t], ["x", "v", "t"])
    X, V = S.x_full_mx(xf), ca.mtimes(dm(S.E), vf)
    parts = []  # (summed in damp_f's order: its force is the same, bit for bit)
    if contact.dissipation_calls(S.asm.mesh):
        parts.append(_reach_switch(S, xf, vf, X, contact_dissipation_mx(S, X, V, cc), (cc,)))
    dw = water.force_mx(S, xf, vf, X, V, t)
    if dw is not None:
        parts.append((dw[0], dw[1] + cc * dw[2]))
    f, T = parts[0] if parts else (None, None)
    for fp, Tp in parts[1:]:
        f, T = f + fp, T + Tp
    if S.strain_rate is not None:
        o = strain_rate_mx(S.strain_rate, xf, X, V, vf, E=S.E, cc=cc)
        f, T = (o[0], o[1]) if f is None else (o[0] + f, o[1] + T)
    return ca.Function("damp_step", ins + [cc], [f, T], names + ["cc"], ["f", "df_dx_cc_df_dv"])


def dissipation_functions(S: StepSystemView) -> tuple[ca.Function | None, ca.Function | None]:
    """(damp_f, damp_force_f) of the step system: damp_f(x, v[, t]) -> (f_d, df_d/dx, df_d/dv) of the strain-rate
    damping, dissipative contact and the water's forces together, damp_force_f(x, v[, t]) -> f_d alone; (None,
    None) without any. The time input t only where the water has waves (ancf_sym.system.water.timed)."""
    from ancf_sym.system import water

    sr = S.strain_rate
    if sr is None and not contact.dissipation_calls(S.asm.mesh) and not water.has_forces(S.asm):
        return None, None  # (no graph to build: ~0.3 ms of set-up)
    nf = S.nf
    xf, vf = ca.MX.sym("x", nf), ca.MX.sym("v", nf)
    t = ca.MX.sym("t") if water.timed(S.asm) else None
    ins, names = ([xf, vf], ["x", "v"]) if t is None else ([xf, vf, t], ["x", "v", "t"])
    X, V = S.x_full_mx(xf), ca.mtimes(dm(S.E), vf)
    dc = contact_dissipation_mx(S, X, V)
    fc = None
    if dc is not None:
        fc = _reach_switch(S, xf, vf, X, (contact_dissipation_force_mx(S, X, V),))[0]
        dc = _reach_switch(S, xf, vf, X, dc)
    dw = water.force_mx(S, xf, vf, X, V, t)  # (lines in water: drag, the water line, waves; ancf_sym.system.water)
    if dw is not None:
        dc = dw if dc is None else tuple(a + b for a, b in zip(dc, dw))
        fc = dw[0] if fc is None else fc + dw[0]
    if sr is None:
        if dc is None:
            return None, None
        return (ca.Function("contact_dissipation", ins, list(dc), names, ["f", "df_dx", "df_dv"]),
                ca.Function("contact_force", ins, [fc], names, ["f"]))
    outs = strain_rate_mx(sr, xf, X, V, vf, E=S.E)
    force = outs[0]
    if dc is not None:
        outs = [a + b for a, b in zip(outs, dc)]
        force = force + fc
    return (ca.Function("strain_rate_damping", ins, outs, names, ["f", "df_dx", "df_dv"]),
            ca.Function("strain_rate_force", ins, [force], names, ["f"]))


def timed(S: StepSystemView) -> bool:
    """Does the dissipation force take the time as a third input (lines in water under waves)?"""
    return S.damp_f is not None and S.damp_f.n_in() == 3


def damping_force(S: StepSystemView, xf: np.ndarray, vf: np.ndarray, t: float | None = None) -> np.ndarray | None:
    """Damping force on the unknowns at (x, v) and time t (read by the water's forces under waves only): Rayleigh
    C v (with the current K_el values) + strain rate, contact dissipation and the water's forces; None for an
    undamped system."""
    f = None
    C = rayleigh_matrix(S, S.kel)
    if C is not None:
        f = C @ vf
    if S.damp_force_f is not None:  # the force alone: damp_f's tangents cost 2x more and are not needed here
        if timed(S):
            if t is None:
                raise ValueError("damping_force: the water's forces under waves need the time t")
            fd = np.asarray(S.damp_force_f(xf, vf, t)).ravel()
        else:
            fd = _force_alone(S, xf, vf)
        f = fd if f is None else f + fd
    return f


def _force_alone(S: StepSystemView, xf: np.ndarray, vf: np.ndarray) -> np.ndarray:
    """S.damp_force_f(xf, vf) through a buffer bound once per system (kept in S.damp_force_maps under "bound"):
    the DM call's conversions cost as much as the graph (0.1 ms a step on the tracked vehicle)."""
    if not S.damp_force_f.sparsity_out(0).is_dense():
        return np.asarray(ca.densify(S.damp_force_f(xf, vf))).ravel()
    b = S.damp_force_maps.get("bound")
    if b is None:
        arrays = (np.zeros(S.nf), np.zeros(S.nf), np.zeros(S.nf))
        b = S.damp_force_maps["bound"] = (bind(S.damp_force_f, arrays[:2], arrays[2:]), arrays)
    (_, evaluate), (x, v, out) = b
    x[:], v[:] = xf, vf
    evaluate()
    return out.copy()


def damping_force_rows(S: StepSystemView, Q: np.ndarray, V: np.ndarray, T: np.ndarray | None = None) -> np.ndarray:
    """(n, nf) damping_force at the states Q, V (n, nf) and times T (n,) of a chunk's accepted steps: without
    Rayleigh damping one mapped call of the dissipation force over the states (per-call overhead paid once per
    chunk, not per step: the same values), else row by row."""
    if len(Q) == 0:
        return np.zeros((0, S.nf))
    if timed(S) and T is None:
        raise ValueError("damping_force_rows: the water's forces under waves need the times T")
    T = [None] * len(Q) if T is None else np.asarray(T, float)
    if S.rayleigh is not None or S.damp_force_f is None:
        return np.array([damping_force(S, q, v, t) for q, v, t in zip(Q, V, T)])
    mapped = S.damp_force_maps
    f = mapped.get(len(Q))
    if f is None:
        f = mapped[len(Q)] = S.damp_force_f.map(len(Q))
    return np.asarray(f(Q.T, V.T, T[None, :]) if timed(S) else f(Q.T, V.T)).T
