"""Elastica: cantilever under a dead tip force perpendicular to the undeformed beam, PL^2/EI = 0.01 .. 10.

Reference (inextensible, unshearable Euler elastica), computed here two independent ways that must agree:
1. shooting: theta'' = -(PL^2/EI) cos(theta) on s in [0, 1], theta(0) = 0, theta'(1) = 0, with x' = cos(theta),
   y' = sin(theta) integrated alongside (solve_ivp DOP853, rtol 1e-12; brentq on theta'(0));
2. elliptic integrals: with k^2 = (1 + sin(theta0))/2 and sin(phi1) = 1/(k sqrt 2), theta0 the tip rotation,
   sqrt(PL^2/EI) = K(k) - F(phi1, k),  w/L = 1 - 2 [E(k) - E(phi1, k)] / sqrt(PL^2/EI),
   u/L = 1 - sqrt(2 sin(theta0) / (PL^2/EI)).
They agree to about 1e-14 and give PL^2/EI = 1: w/L = 0.30172, u/L = 0.05643; = 10: w/L = 0.81061, u/L = 0.55500
(classic tables, e.g. Mattiasson 1981, list these digits). Small loads: w/L -> PL^2/(3EI) (PL^3/3EI).

ANCF model: L = 1 m, EI = 1 N m^2, EA = 1e7 N, so extensibility moves the tip by about P/EA <= 1e-6 L at PL^2/EI = 10
(checked: EA x 10 changes the n = 32 results by < 2e-6); no gravity. axial="decoupled" (paper 000) is the main
series; axial="biot" (coupled) is shown too: with EA L^2/EI = 1e7 its spurious axial strain locks the elements
(10-150x the error of the decoupled element at equal n, n >= 4). Tolerances in the tests come from this convergence study:
the error of w(n) stays below half the change w(n) - w(n/2) (observed order 2..4), plus 2e-6 for extensibility
(full run: true for every load and n >= 2 with the decoupled strain; the locking biot element needs n >= 4).

Records: load (PL^2/EI), axial, n, w_over_L, u_over_L, reference_w_over_L, reference_u_over_L, tip_rotation_rad,
reference_tip_rotation_rad, linear_w_over_L (PL^2/3EI), err_w, err_u, iterations, wall_s, status.
Run: python examples/elastica.py [--quick] [--json out.json] [--out DIR]
"""
from __future__ import annotations

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common as C  # noqa: E402  (first: it limits BLAS threads before numpy loads)

import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402
from scipy.optimize import brentq  # noqa: E402
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc  # noqa: E402

from ancf_sym import Material, Scene, Section, solve_static  # noqa: E402

L, EI, EA = 1.0, 1.0, 1e7
TABLE = {1.0: (0.3017, 0.0564), 10.0: (0.8106, 0.5550)}  # w/L, u/L to 4 digits (Bisshopp-Drucker / Mattiasson)


# -- references ---------------------------------------------------------------------------------------------------
def elastica_shooting(alpha: float) -> tuple[float, float, float]:
    """(w/L, u/L, tip rotation) of theta'' = -alpha cos(theta), theta(0) = 0, theta'(1) = 0, by shooting."""
    def rhs(s, y):
        return [y[1], -alpha * math.cos(y[0]), math.cos(y[0]), math.sin(y[0])]

    def end(k0):
        return solve_ivp(rhs, (0.0, 1.0), [0.0, k0, 0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]

    # theta'(0) = alpha x_tip / L lies in (0, alpha]; theta'(1) goes from < 0 (k0 -> 0) to >= 0 (k0 = alpha)
    k0 = brentq(lambda k: end(k)[1], 0.0, alpha, xtol=1e-15, rtol=1e-15)
    th, _, x, y = end(k0)
    return y, 1.0 - x, th


def elastica_elliptic(alpha: float) -> tuple[float, float, float]:
    """The same from the closed form in elliptic integrals (tip rotation theta0 < pi/2 for a dead transverse load)."""
    def parts(th0):
        m = (1 + math.sin(th0)) / 2
        return m, math.asin(1 / math.sqrt(2 * m))

    def f(th0):
        m, phi1 = parts(th0)
        return ellipk(m) - ellipkinc(phi1, m) - math.sqrt(alpha)

    th0 = brentq(f, 1e-14, math.pi / 2 - 1e-14, xtol=1e-16, rtol=1e-15)
    m, phi1 = parts(th0)
    w = 1 - 2 / math.sqrt(alpha) * (ellipe(m) - ellipeinc(phi1, m))
    return w, 1 - math.sqrt(2 * math.sin(th0) / alpha), th0


# -- ANCF ---------------------------------------------------------------------------------------------------------
def solve(alpha: float, n: int, axial: str, ea: float = EA):
    s = Scene(dim=2, name="elastica")
    # E = 1e7 Pa, A = EA/E, I = EI/E: only the products matter
    s.member("beam", points=[(0.0, 0.0), (L, 0.0)], elements=n, material=Material(E=1e7, density=1.0),
             section=Section(area=ea / 1e7, I=EI / 1e7), axial=axial, bending=True, gravity=False)
    s.clamp("beam", at="start")
    s.force("beam", at="end", force=(0.0, -alpha * EI / L**2))
    return solve_static(s)


def main(argv=None):
    a = C.parser("elastica", __doc__).parse_args(argv)
    if a.quick:
        loads, ns, axials = (0.01, 1.0, 10.0), (4, 8, 16), ("decoupled",)
    else:
        loads, ns, axials = (0.01, 0.1) + tuple(float(k) for k in range(1, 11)), (1, 2, 4, 8, 16, 32), \
            ("decoupled", "biot")
    refs = {}
    for alpha in loads:
        sh, el = elastica_shooting(alpha), elastica_elliptic(alpha)
        refs[alpha] = sh
        refs[("gap", alpha)] = max(abs(p - q) for p, q in zip(sh, el))
    records = []
    for axial in axials:
        for alpha in loads:
            for n in ns:
                r = solve(alpha, n, axial)
                tip, t_end = r.tip("beam"), r.slopes("beam")[-1]
                w, u = -tip[1] / L, 1.0 - tip[0] / L
                rw, ru, rth = refs[alpha]
                records.append({"load": alpha, "axial": axial, "n": n, "w_over_L": w, "u_over_L": u,
                                "reference_w_over_L": rw, "reference_u_over_L": ru,
                                "tip_rotation_rad": -math.atan2(t_end[1], t_end[0]), "reference_tip_rotation_rad": rth,
                                "linear_w_over_L": alpha / 3, "err_w": w - rw, "err_u": u - ru,
                                "reference_gap": refs[("gap", alpha)], "iterations": r.iterations,
                                "wall_s": r.wall_s, "status": r.status, "success": r.success, "stable": r.stable})
    C.table(records, ["load", "axial", "n", "w_over_L", "reference_w_over_L", "err_w", "u_over_L",
                      "reference_u_over_L", "err_u", "iterations", "wall_s", "status"],
            "Cantilever, dead tip load: ANCF vs elastica (EA L^2/EI = 1e7)",
            {"w_over_L": "{:.6f}", "u_over_L": "{:.6f}", "reference_w_over_L": "{:.6f}",
             "reference_u_over_L": "{:.6f}", "err_w": "{:+.2e}", "err_u": "{:+.2e}", "wall_s": "{:.3f}"})
    for alpha, (tw, tu) in TABLE.items():
        if alpha in refs:
            rw, ru, _ = refs[alpha]
            print(f"reference PL^2/EI={alpha:g}: w/L {rw:.5f} u/L {ru:.5f} (table {tw} / {tu}; shooting vs elliptic "
                  f"{refs[('gap', alpha)]:.1e})")
    if 0.01 in refs:
        fine = [r for r in records if r["load"] == 0.01 and r["n"] == max(ns) and r["axial"] == "decoupled"][0]
        print(f"PL^2/EI=0.01: ANCF w/L {fine['w_over_L']:.8f}, PL^3/3EI {0.01 / 3:.8f} "
              f"({fine['w_over_L'] / (0.01 / 3) - 1:+.2e}), elastica {fine['reference_w_over_L']:.8f}")
    C.write_json(records, a.json)
    if not a.no_plots:
        plt = C.pyplot()
        fig, axes = plt.subplots(1, 2, figsize=(11, 4))
        big = [x for x in loads if x >= 1]
        fine = {(r["axial"], r["load"]): r for r in records if r["n"] == max(ns)}
        axes[0].plot(big, [refs[x][0] for x in big], "k-", label="elastica w/L")
        axes[0].plot(big, [refs[x][1] for x in big], "k--", label="elastica u/L")
        axes[0].plot(big, [fine[("decoupled", x)]["w_over_L"] for x in big], "o", label=f"ANCF n={max(ns)} w/L")
        axes[0].plot(big, [fine[("decoupled", x)]["u_over_L"] for x in big], "s", label=f"ANCF n={max(ns)} u/L")
        axes[0].set_xlabel("PL^2/EI"), axes[0].set_ylabel("tip displacement / L"), axes[0].legend(fontsize=7)
        axes[0].grid(alpha=0.3), axes[0].set_title("tip displacements (decoupled axial strain)")
        for axial, mk in zip(axials, ("o-", "s--")):
            for alpha in (1.0, 10.0):
                rs = [r for r in records if r["axial"] == axial and r["load"] == alpha]
                axes[1].loglog([r["n"] for r in rs], [max(abs(r["err_w"]), 1e-16) for r in rs], mk,
                               label=f"{axial}, PL^2/EI={alpha:g}")
        axes[1].xaxis.set_minor_locator(plt.NullLocator())
        axes[1].set_xticks(ns, [str(n) for n in ns])
        axes[1].set_xlabel("elements n"), axes[1].set_ylabel("|w/L - elastica|"), axes[1].legend(fontsize=7)
        axes[1].grid(alpha=0.3, which="both"), axes[1].set_title("convergence")
        C.save(fig, a.out, "elastica.png")
    return records


if __name__ == "__main__":
    main()
