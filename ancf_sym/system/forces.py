"""The force graphs of a step system: the potential's gradient and Hessian on the unknowns, assembled from the
mapped compiled kernels by constant index gathers (no Python loop over elements, no numpy scatter).

forces_pf(x, par) -> (g, K[, kel]): gradient and Hessian of the nonlinear potential (elastic terms, penalty
joints, contact laws), and the elastic tangent values for Rayleigh stiffness damping; grad_pf(x, par) -> g from
the kernels' (energy, gradient) companions (no Hessian work); the energies and kinetic energy for the outputs.
`par` holds the kernels' element parameters (material, section, lengths), inputs rather than constants of the
graphs.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ancf_sym import kernels
from ancf_sym.model.assembly import map_elements
from ancf_sym.util.mx_ops import add, mul, neg, reshape, vec
from ancf_sym.util.sparsity import assemble_mx, elements_key, gather_sum, group_calls, hessian_entries, mx_nonzeros, scatter
from ancf_sym.system import contact_reach
from ancf_sym.system.band import PAD_PIVOT, BandLayout
from ancf_sym.system.interface import StepSystemView


ELASTIC_LABELS = ("axial", "bending", "torsion", "continuum")


def _parameters(S: StepSystemView, par: ca.MX) -> tuple[list, list]:
    """Each kernel call's parameters (n_p x N) from the input vector: (force terms', nonlinear terms')."""
    Ps, o = [], 0
    for P in [ft.P for ft in S.force_terms] + [mk.P for mk in S.nonlinear]:
        Ps.append(reshape(par[o:o + P.size], P.shape[1], P.shape[0]))
        o += P.size
    return Ps[:len(S.force_terms)], Ps[len(S.force_terms):]


def _element_coordinates(x: ca.MX, idx: np.ndarray, nd: int, N: int, seen: dict | None = None) -> ca.MX:
    """The elements' coordinates x[idx] as nd x N; `seen` keeps them by element table, so that the terms on the same
    elements (a cable's axial and bending energies, its fused force kernel) share one gather of x."""
    key = elements_key(idx)
    if seen is not None and key in seen:
        return seen[key]
    Xe = reshape(x[idx.ravel().tolist()], nd, N)
    if seen is not None:
        seen[key] = Xe
    return Xe


def _kernel_calls(S: StepSystemView, x: ca.MX, Pft: list, seen: dict | None = None) -> list:
    """(elements, G, H) of every force term's mapped kernel call at the scene coordinates x."""
    calls, balls = [], {}
    for ft, Pk in zip(S.force_terms, Pft):
        Xe = _element_coordinates(x, ft.idx, ft.nd, ft.N, seen)
        _, G, H = _call(S, ft, "", x, Xe, Pk, balls)
        calls.append((ft.idx, G, H))
    return calls


def _call(S: StepSystemView, ft, kind: str, x: ca.MX, Xe: ca.MX, Pk: ca.MX, balls: dict) -> list:
    """A force term's mapped kernel call (kind "": energy, gradient, Hessian; "_grad": energy, gradient); a contact
    law's kernels only on the blocks of elements in reach of its surface (ancf_sym.system.contact_reach)."""
    load = kernels.load if not kind else kernels.load_grad
    if not ft.effect.startswith("contact_"):
        return (ft.mapped() if not kind else ft.mapped_grad()).call([Xe, Pk])

    def mapper(n: int) -> ca.Function:
        return map_elements(load(ft.element, ft.effect, ft.gauss),
                            kernels.load_batch(ft.element, ft.effect, ft.gauss, kind), n)
    return contact_reach.call(mapper, ft.element, ft.effect, ft.idx, Xe, Pk, x, S.asm.scene.dim, balls)


def band_force_graph(S: StepSystemView, layout: "BandLayout") -> ca.Function:
    """forces_band(x, par) -> (g, K band): the gradient as forces_pf's and the Hessian gathered straight into the
    lower band storage of `layout` (ancf_sym.system.band; its padding pivots included), for S without penalty
    joints (their Hessian is not a kernel call)."""
    xf, par = ca.MX.sym("x", S.nf), ca.MX.sym("par", S.par.size)
    groups = group_calls(_kernel_calls(S, S.x_full_mx(xf), _parameters(S, par)[0]))  # (as assemble_mx sums them)
    g, _ = assemble_mx(groups, S.pos, S.nf, hessian=False)
    vals, targets = [], []
    for idx, _, H in groups:
        ia, ib, keep = hessian_entries(S.pos, idx)
        t = -np.ones(ia.size, dtype=np.int64)
        t[keep] = layout.slots(ib[keep], ia[keep])  # (row ib, column ia)
        vals.append(vec(H))
        targets.append(t)
    pad = layout.padding_slots()
    vals.append(ca.DM.ones(len(pad)) * PAD_PIVOT)
    targets.append(pad)
    Kb = gather_sum(vals, np.concatenate(targets), layout.size)
    return ca.Function("forces_band", [xf, par], [g, Kb], ["x", "par"], ["g", "K_band"])


def gradient_graph(S: StepSystemView) -> ca.Function:
    """gradient(x, par) -> g from the kernels' (energy, gradient) companions: no Hessian work (the residuals of
    modified Newton). Built on first use (StepSystem.grad_pf): a full-Newton run never needs it."""
    xf, par = ca.MX.sym("x", S.nf), ca.MX.sym("par", S.par.size)
    x = S.x_full_mx(xf)
    gcalls, balls = [], {}
    for ft, Pk in zip(S.force_terms, _parameters(S, par)[0]):
        Xe = _element_coordinates(x, ft.idx, ft.nd, ft.N)
        gcalls.append((ft.idx, _call(S, ft, "_grad", x, Xe, Pk, balls)[1], None))
    gg, _ = assemble_mx(gcalls, S.pos, S.nf, hessian=False)
    pen = _penalty_energy(S, x)
    if pen is not None:
        gg += ca.gradient(pen, xf)
    return ca.Function("gradient", [xf, par], [gg], ["x", "par"], ["g"])


def _penalty_energy(S: StepSystemView, x: ca.MX) -> ca.MX | None:
    """The penalty joints' energy 1/2 sum k c(x)^2 at the scene coordinates x, or None without penalty joints."""
    pc = S.asm.penalty
    if pc is None:
        return None
    c = S.asm.casadi_constraint(pc, x)
    return 0.5 * ca.sum1(ca.DM(pc.k) * c * c)


@dataclass
class ForceGraphs:
    """What build_force_graphs returns (the step system keeps them)."""
    exprs: tuple | None  # the force graph's (x, par, outputs): the step graph built next uses them as they are
    forces: ca.Function | None  # forces(x, par) -> (g, K[, kel])
    kel_sparsity: ca.Sparsity | None  # the Rayleigh elastic tangent's pattern (None: no stiffness damping)
    energies: ca.Function | None  # energies_kinetic(x, v, par, lin) -> [potentials by label; kinetic]
    energy_labels: list | None


def build_force_graphs(S: StepSystemView, forces: bool = True, energies: bool = True) -> ForceGraphs:
    """From S's kernel calls the force graph and the Rayleigh elastic tangent's pattern (None without stiffness
    damping), and the energy graph with its labels: the two read the same element coordinates. forces False: the
    force graph is left to be built on first use (the band path's iteration has a force graph of its own, and it
    runs without Rayleigh damping). The force graph's expressions come back too: the step graph built next uses them
    as they are, where inlining a call of the force graph would copy the same nodes."""
    nf = S.nf
    xf = ca.MX.sym("x", nf)
    par = ca.MX.sym("par", S.par.size)
    x = S.x_full_mx(xf)
    Pft, Pmk = _parameters(S, par)
    seen: dict = {}  # (the elements' coordinates, shared by the force and energy graphs' terms)
    pen = _penalty_energy(S, x)
    outs, f, kel = _force_graph(S, xf, par, x, Pft, seen, pen) if forces else (None, None, None)
    ef, labels = _energy_graph(S, xf, par, x, Pmk, seen, pen) if energies else (None, None)
    return ForceGraphs(None if outs is None else (xf, par, outs), f, kel, ef, labels)


def _force_graph(S: StepSystemView, xf: ca.MX, par: ca.MX, x: ca.MX, Pft: list, seen: dict,
                 pen: ca.MX | None) -> tuple[list, ca.Function, ca.Sparsity | None]:
    nf, pos = S.nf, S.pos
    kel_vals, kel_rows, kel_cols = [], [], []
    weights = S.rayleigh.element_weight if (S.rayleigh is not None and S.rayleigh.beta) else {}
    calls = _kernel_calls(S, x, Pft, seen)  # (elements, G, H); assemble_mx sums calls on the same elements first
    for ft, (_, _, H) in zip(S.force_terms, calls):
        if weights and all(lbl in ELASTIC_LABELS for lbl in ft.labels):
            ti, rows = ft.sources[0]  # fused rows have equal weights (row_keys)
            w = weights.get(ti)
            if w is not None and np.any(np.asarray(w)[rows]):
                ia, ib, keep = hessian_entries(pos, ft.idx)
                we = np.repeat(np.asarray(w, float)[rows], ft.nd * ft.nd)[keep]
                hv = vec(H)
                kel_vals.append((hv[keep.tolist()] if len(keep) < hv.shape[0] else hv) * ca.DM(we))
                kel_rows.append(ib[keep])
                kel_cols.append(ia[keep])
    g, K = assemble_mx(calls, pos, nf)
    outs = [g, K]
    kel_sparsity = None
    if kel_vals:
        Kel = scatter(kel_vals, np.concatenate(kel_rows), np.concatenate(kel_cols), nf)
        kel_sparsity = Kel.sparsity()
        outs.append(mx_nonzeros(Kel))
    if pen is not None:
        outs[0] = outs[0] + ca.gradient(pen, xf)
        outs[1] = outs[1] + ca.hessian(pen, xf)[0]
    f = ca.Function("forces", [xf, par], outs, ["x", "par"], ["g", "K"] + (["kel"] if kel_vals else []))
    return outs, f, kel_sparsity


def _energy_graph(S: StepSystemView, xf: ca.MX, par: ca.MX, x: ca.MX, Pmk: list, seen: dict,
                  pen: ca.MX | None) -> tuple[ca.Function, list]:
    asm, nf = S.asm, S.nf
    # energies for the outputs from the energy-only compiled functions (no gradient, no Hessian)
    elist = []
    for mk, Pk in zip(S.nonlinear, Pmk):
        t = mk.term
        Xe = _element_coordinates(x, t.idx, mk.nd, mk.N, seen)
        ef = map_elements(kernels.load_energy(t.element, t.effect, t.gauss),
                          kernels.load_batch(t.element, t.effect, t.gauss, "_energy"), mk.N)
        elist.append((t.label, ca.sum2(ef(Xe, Pk))))
    if pen is not None:
        elist.append(("penalty", pen))
    # the outputs' energies in one call: the potentials (the linear ones, U = c + G.x, as dot products with the
    # input `lin` = [G_1 .. G_k, c_1 .. c_k, Q]) and the kinetic energy
    lin = ca.MX.sym("lin", S.lin.size)
    n, k = asm.n, len(S.lin_energy)
    for j, (_, _, _, label) in enumerate(S.lin_energy):
        elist.append((label, add(lin[k * n + j], ca.dot(lin[j * n:(j + 1) * n], x))))
    if np.any(asm.Q):
        elist.append(("loads", neg(ca.dot(lin[k * n + k:], x))))
    vf = ca.MX.sym("v", nf)
    return ca.Function("energies_kinetic", [xf, vf, par, lin], [
        ca.vertcat(*[e for _, e in elist], mul(0.5, ca.dot(vf, S.mass_mx(vf))))]), [lbl for lbl, _ in elist]
