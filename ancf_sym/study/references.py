"""Independent references for the statics studies: the planar rod with the cable's own energy, solved without any
ANCF discretisation, by two methods that check each other.

The cable energy per reference length is W = EA/2 e(lam)^2 + EI/2 kappa^2 with r' = lam (cos th, sin th),
kappa = |r' x r''| / |r'|^3 = th'/lam (ancf_sym/elements/cable.py). Its Euler-Lagrange equations, with the internal
force n(s) = F_tip + int_s^L f (dead loads per reference length f, dead tip force F_tip):
    x' = lam cos th,  y' = lam sin th,  th' = m lam^2 / EI,  m' = -lam n . (-sin th, cos th),
    EA e(lam) e'(lam) - m^2 lam / EI = n . (cos th, sin th)            (axial balance, solved for lam),
with th(0) = 0, r(0) = 0 (clamp) and m(L) = 0 (free end). Strain measures: green e = (lam^2 - 1)/2, biot e = lam - 1.
The potential (strain energy + load potentials) is integrated alongside, so energies are referenced too.

Dead loads make n(s) known in closed form, so the boundary-value problem has a single unknown, the clamp moment
m(0): `method="shooting"` integrates from the clamp (solve_ivp, DOP853, no mesh to run out of) and finds m(0) with
m(L) = 0, the load continued from zero. `method="bvp"` is scipy's collocation solve_bvp on the same equations (load
continuation with step halving, a bounded mesh). The equations are scaled by L and EI/L so that tolerances mean the
same for a 1 m steel bar and a 3 m rubber rope. `rod_reference` runs both and reports their difference as part of
the reference's own error bound.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_bvp, solve_ivp
from scipy.optimize import brentq


class ReferenceError(RuntimeError):
    """A reference solve that did not reach its tolerance (its message says which method and where)."""


@dataclass(frozen=True)
class RodReference:
    tip: np.ndarray  # (x, y) of the free end [m]
    potential: float  # strain energy + potential of the loads (zero at the undeformed clamp height) [J]
    strain_energy: float  # [J]
    max_residual: float  # shooting: |m(L)| / (EI/L); bvp: solve_bvp's largest relative residual
    nodes: int  # ODE steps (shooting) or mesh nodes (bvp)
    how: str  # one line saying how it was obtained


def _stretch(N: float, m: float, ea: float, strain: str) -> float:
    """lam solving ea e e' - m^2 lam = N (scaled: ea = EA L^2/EI, N in EI/L^2, m in EI/L; Newton from the
    axial-only guess; strains are small to moderate)."""
    if strain == "biot":
        return (N + ea) / (ea - m * m)
    lam = math.sqrt(max(1.0 + 2.0 * N / ea, 0.25))
    for _ in range(40):
        f = ea * (lam**3 - lam) / 2 - m * m * lam - N
        step = f / (ea * (3 * lam**2 - 1) / 2 - m * m)
        lam -= step
        if abs(step) < 1e-15 * lam:
            break
    return lam


class _ScaledRod:
    """The rod equations in s/L, r/L, m L/EI, forces L^2/EI, energies L/EI."""

    def __init__(self, L, EA, EI, w, tip_force, strain):
        if strain not in ("green", "biot"):
            raise ValueError(f"strain must be green or biot, got {strain!r}")
        self.L, self.EI, self.strain = L, EI, strain
        self.ea = EA * L * L / EI
        self.w = np.asarray(w, float) * L**3 / EI
        self.F = np.asarray(tip_force, float) * L**2 / EI

    def rhs(self, s, y, scale):
        """y = (x, y, th, m, strain energy, -work of the distributed load); s may be an array (bvp)."""
        x_, y_, th, m = y[0], y[1], y[2], y[3]
        nx, ny = scale * (self.F[0] + self.w[0] * (1 - s)), scale * (self.F[1] + self.w[1] * (1 - s))
        c, si = np.cos(th), np.sin(th)
        N = nx * c + ny * si
        lam = (np.vectorize(_stretch)(N, m, self.ea, self.strain) if np.ndim(N)
               else _stretch(float(N), float(m), self.ea, self.strain))
        e = (lam**2 - 1) / 2 if self.strain == "green" else lam - 1
        W = self.ea / 2 * e**2 + m * m * lam**2 / 2
        return np.array([lam * c, lam * si, m * lam**2, -lam * (-nx * si + ny * c), W,
                         -scale * (self.w[0] * x_ + self.w[1] * y_)])

    def result(self, end, residual, nodes, how) -> RodReference:
        L, E0 = self.L, self.EI / self.L
        potential = end[4] + end[5] - (self.F[0] * end[0] + self.F[1] * end[1])
        return RodReference(tip=end[:2] * L, potential=float(potential * E0), strain_energy=float(end[4] * E0),
                            max_residual=float(residual), nodes=int(nodes), how=how)


def _shoot(rod: _ScaledRod, tol: float, load_steps: int) -> RodReference:
    def end_of(m0, scale):
        sol = solve_ivp(lambda s, y: rod.rhs(s, y, scale), (0.0, 1.0), [0, 0, 0, m0, 0, 0], method="DOP853",
                        rtol=tol, atol=tol * 1e-2)
        if sol.status != 0:
            raise ReferenceError(f"reference rod (shooting): solve_ivp failed: {sol.message}")
        return sol.y[:, -1], sol.t.size

    m0 = 0.0
    for k in range(1, load_steps + 1):
        scale = k / load_steps
        M = scale * (np.abs(rod.F).sum() + np.abs(rod.w).sum() / 2) + 1e-300  # |m(0)| of the straight rod
        g = lambda m: end_of(m, scale)[0][3]  # noqa: E731 - m(L) as a function of the clamp moment
        # bracket around the previous load step's root scaled up (the clamp moment grows with the load)
        guess = m0 * k / (k - 1) if k > 1 else 0.0
        lo, hi, width = guess, guess, 0.05 * M
        glo = ghi = g(guess)
        for _ in range(60):
            if glo * ghi <= 0:
                break
            lo, hi, width = lo - width, hi + width, 2 * width
            glo, ghi = g(lo), g(hi)
        else:
            raise ReferenceError(f"reference rod (shooting): no clamp moment found at load factor {k}/{load_steps}")
        m0 = guess if glo == ghi == 0 else brentq(g, lo, hi, xtol=1e-15 * M, rtol=4 * np.finfo(float).eps,
                                                 maxiter=200)
    end, steps = end_of(m0, 1.0)
    return rod.result(end, abs(end[3]), steps,
                      f"planar rod with the cable's {rod.strain} energy, shooting on the clamp moment (DOP853, rtol "
                      f"{tol:g}, {steps} steps), load continued in {load_steps} steps")


def _bvp(rod: _ScaledRod, tol: float, load_steps: int, max_nodes: int) -> RodReference:
    def bc(ya, yb):
        return np.array([ya[0], ya[1], ya[2], yb[3], ya[4], ya[5]])

    s = np.linspace(0.0, 1.0, 201)
    y = np.zeros((6, s.size))
    y[0] = s
    done, step, halvings = 0.0, 1.0 / load_steps, 0
    while done < 1.0 - 1e-12:
        scale = min(1.0, done + step)
        sol = solve_bvp(lambda x, yy: rod.rhs(x, yy, scale), bc, s, y, tol=tol, max_nodes=max_nodes, bc_tol=1e-12)
        if sol.status != 0:  # a smaller load increment gives a closer guess (and a smaller mesh)
            halvings += 1
            if halvings > 8:
                raise ReferenceError(f"reference rod (solve_bvp): failed at load factor {scale:.4g}: {sol.message}")
            step /= 2
            continue
        done, s, y = scale, sol.x, sol.y
    return rod.result(y[:, -1], float(np.max(sol.rms_residuals)), s.size,
                      f"planar rod with the cable's {rod.strain} energy, solve_bvp (tol {tol:g}, {s.size} nodes), "
                      f"load continued in {load_steps}+ steps")


def clamped_rod(L: float, EA: float, EI: float, w: tuple[float, float] = (0.0, 0.0),
                tip_force: tuple[float, float] = (0.0, 0.0), strain: str = "green", tol: float = 1e-11,
                load_steps: int = 4, method: str = "shooting", max_nodes: int = 20000) -> RodReference:
    """Rod clamped at the origin along +x under a dead distributed load w [N/m] and a dead tip force [N].

    method "shooting" (default; tol = solve_ivp rtol on the scaled equations) or "bvp" (solve_bvp, tol its
    relative residual, at most max_nodes mesh nodes). Raises ReferenceError if the method does not converge."""
    rod = _ScaledRod(L, EA, EI, w, tip_force, strain)
    if method == "shooting":
        return _shoot(rod, tol, load_steps)
    if method == "bvp":
        return _bvp(rod, tol, load_steps, max_nodes)
    raise ValueError(f"method must be shooting or bvp, got {method!r}")


def rod_reference(L: float, EA: float, EI: float, w: tuple[float, float] = (0.0, 0.0),
                  tip_force: tuple[float, float] = (0.0, 0.0), quick: bool = False) -> dict:
    """The study reference (green rod by shooting at rtol 1e-11) and its own error bound, relative to the tip
    displacement: the change at rtol 1e-9 (integration error), the biot rod (the limits of the strain measures
    differ by O(strain^2)) and solve_bvp at tol 1e-8 (an independent method; skipped, and said so, if it does not
    converge on this machine). quick: the integration-error check only."""
    fine = clamped_rod(L, EA, EI, w, tip_force, "green", tol=1e-11)
    scale = float(np.hypot(fine.tip[0] - L, fine.tip[1])) or 1.0
    checks = {"rtol 1e-9": lambda: clamped_rod(L, EA, EI, w, tip_force, "green", tol=1e-9)}
    if not quick:
        checks["the biot rod"] = lambda: clamped_rod(L, EA, EI, w, tip_force, "biot", tol=1e-11)
        checks["solve_bvp"] = lambda: clamped_rod(L, EA, EI, w, tip_force, "green", tol=1e-8, method="bvp")
    bounds, notes = [1e-10], []
    for name, solve in checks.items():
        try:
            bounds.append(float(np.linalg.norm(solve().tip - fine.tip)) / scale)
            notes.append(name)
        except ReferenceError as exc:
            notes.append(f"{name} skipped ({exc})")
    return {"how": fine.how + "; error bound from " + ", ".join(notes), "L": L, "tip_x": float(fine.tip[0]),
            "tip_y": float(fine.tip[1]), "potential": fine.potential, "error_bound": max(bounds), "success": True}
