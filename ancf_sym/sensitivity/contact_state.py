"""Is an equilibrium with exact (unilateral) contact differentiable in the parameters, and through which rows?

At an equilibrium with exact contact, the points held (gap zero, force positive) are equality rows of the implicit
function theorem and the points lifted off (gap positive, force zero) are free (ancf_sym.modal.contact_rows decides
which is which, as the statics' sensitivity does). The equilibrium, its reactions and its frequencies are then
differentiable as long as small parameter changes keep that active set: strict complementarity. A point with zero gap
AND zero force (weakly active: touching without pressing) breaks it: a change of the parameter one way presses it
(a row), the other way lifts it (no row), and the derivative is one-sided. IPOPT's interior-point answer has no exact
zeros: its barrier leaves f_i g_i ~ mu at every point (here in the relative units g / L, f / F, L the structure's
length and F the largest contact force or reaction, as ancf_sym.modal.contact_rows measures them). A strictly
complementary point has one of the two far above sqrt(mu) and the other far below; a point at zero gap and zero force has both near sqrt(mu), where the solver's answer does
not tell on which side it lies. So a point counts as touching without pressing where the smaller of its relative gap
and force exceeds WEAK_RATIO times the larger (or both are below RESOLUTION), and the derivative is refused with
those points named.
"""
from __future__ import annotations

import numpy as np

from ancf_sym import kernels, registry
from ancf_sym.contact import exact as contact_exact, laws as contact
from ancf_sym.modal.contact_rows import contact_points, force_scale
from ancf_sym.statics.problem import StaticResult

WEAK_RATIO = 1e-3  # (smaller / larger) of the relative gap and force above which a point touches without pressing
RESOLUTION = 1e-9  # relative gap and force below which both are zero to the solver's accuracy


class ContactStateError(ValueError):
    """The contact state at the equilibrium is not differentiable (a point at zero gap and zero force)."""


def weak_points(asm, result: StaticResult) -> list[tuple[str, float, float]]:
    """(where: member, element, xi; gap [m]; force [N]) of the exact-contact points at zero gap and zero force."""
    if not contact.exact_contacts(asm):
        return []
    f, g, _ = contact_points(asm, result)
    labels = [lbl for r in contact_exact.rows(asm) for lbl in r.labels]
    f_hat = f / force_scale(result)
    g_hat = g / asm.mesh.length_scale
    small, large = np.minimum(np.abs(g_hat), np.abs(f_hat)), np.maximum(np.abs(g_hat), np.abs(f_hat))
    weak = (small > WEAK_RATIO * large) | (large < RESOLUTION)
    return [(f"member {labels[i][0]!r} element {labels[i][1]} xi {labels[i][2]:.3g}", float(g[i]), float(f[i]))
            for i in np.flatnonzero(weak)]


def check_differentiable(asm, result: StaticResult, what: str) -> None:
    """Raise ContactStateError naming the points at zero gap and zero force (see the module docstring)."""
    weak = weak_points(asm, result)
    if weak:
        pts = "; ".join(f"{w}: gap {g:.3g} m, force {f:.3g} N" for w, g, f in weak[:5])
        more = f" and {len(weak) - 5} more" if len(weak) > 5 else ""
        raise ContactStateError(
            f"{what}: the contact state is not differentiable: {len(weak)} exact-contact point(s) touch without "
            f"pressing (gap and force both at the solver's resolution, zero gap and zero force: {pts}{more}); a "
            "parameter change one way presses them, the other way lifts them off")


def curved_contact_rows(asm) -> list[str]:
    """The members of the exact contacts whose gap rows are curved (drums) and whose gap kernel has no compiled third
    derivatives (beam3d, spatial bodies' drums): their rows' curvature changes with the state."""
    return [str(getattr(r.contact, "member", "?")) for r in contact_exact.rows(asm)
            if r.A is None and not registry.has_third_derivatives(r.element, r.effect, None)]


def drum_terms(asm, x: np.ndarray, f: np.ndarray, active: np.ndarray, df: np.ndarray, nu: np.ndarray,
               phi: np.ndarray, dx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The drum rows' share of the differentiated mode equation for a mode phi (full coordinates), with f the contact
    forces (all points, row order), active their mask, df the held points' force derivatives and nu the mode's
    multipliers of the held points' rows (in the order of the active points):

        v = sum_i (-df_i Hess g_i phi - f_i (D Hess g_i [dx]) phi) + sum_held nu_i Hess g_i dx   (full coordinates)
        t_i = dx' Hess g_i phi   (per held point: the row's turn dG_i phi)

    (K_L holds -sum f_i Hess g_i; a held row's Jacobian turns by Hess g_i dx). The gap kernels' Hessians and their
    compiled Hessian-vector companion (third derivatives); ground rows are linear and add nothing."""
    n = len(x)
    act = np.flatnonzero(active)
    dfa, nua = np.zeros(len(f)), np.zeros(len(f))
    dfa[act], nua[act] = df, nu
    v, turn, o = np.zeros(n), np.zeros(len(f)), 0
    for r in contact_exact.rows(asm):
        N = r.m
        if r.A is not None:
            o += N
            continue
        const = np.asarray(r.const, float) if r.const is not None else np.zeros(0)
        pad = np.zeros(len(const))
        Z, Fz, Dz = np.r_[x, const][r.idx], np.r_[phi, pad][r.idx], np.r_[dx, pad][r.idx]
        nin = r.idx.shape[1]
        H = kernels.load(r.element, r.effect).map(N)(Z.T, r.P.T)[2]
        H = H.full().reshape(nin, N, nin).transpose(1, 0, 2)
        T = kernels.load_hvp(r.element, r.effect).map(N)(Z.T, r.P.T, Fz.T)[1].full()
        T = T.reshape(nin, N, nin).transpose(1, 0, 2)  # per point d(Hess g phi)/dz (symmetric in its use here)
        sl = slice(o, o + N)
        Hphi, Hdx, Tdx = (np.einsum("eij,ej->ei", H, Fz), np.einsum("eij,ej->ei", H, Dz),
                          np.einsum("eij,ej->ei", T, Dz))
        per = -dfa[sl, None] * Hphi - f[sl, None] * Tdx + nua[sl, None] * Hdx
        real = r.idx < n  # (the constants after x: the drum's centre, fixed)
        v += np.bincount(r.idx[real], per[real], minlength=n)
        turn[sl] = np.einsum("ei,ei->e", Dz, Hphi)
        o += N
    return v, turn[act]


def drum_form(asm, x: np.ndarray, f: np.ndarray, active: np.ndarray, df: np.ndarray, nu: np.ndarray,
              phi: np.ndarray, dx: np.ndarray) -> float:
    """The drum rows' share of d(w^2)/dp for a mode phi (drum_terms' arguments):

        sum_i (-df_i phi'Hess g_i phi - f_i phi'(D Hess g_i [dx]) phi) + 2 sum_held nu_i dx'Hess g_i phi

    = phi'v + nu't of drum_terms."""
    v, turn = drum_terms(asm, x, f, active, df, nu, phi, dx)
    return float(phi @ v + np.asarray(nu) @ turn)
