"""Buckling: a clamped-free column under a dead axial tip load P, below and past the Euler load.

Column: L = 1 m, EI = 1 N m^2, EA = 1e5 N, axial="decoupled", no gravity, clamped at (0, 0), axis along +y, tip
load (0, -P); P_cr = pi^2 EI / (4 L^2) (the half of a pinned-pinned column of length 2L; the scene API has no roller
support for a pinned-pinned column). No imperfection and no lateral load: the straight state is an equilibrium for
every P, stable below P_cr and a saddle above it. solve_static (escape_saddle=True, the default) finds the straight
state, sees a negative curvature of the reduced Hessian (result.stable False), steps along that direction and
minimises again; its `attempts` say so. Each load is also solved with escape_saddle=False to show the saddle.

Reference: the inextensible elastica of the clamped-free column (Timoshenko & Gere): with k = sin(theta0/2),
theta0 the tip rotation, P/P_cr = (2 K(k) / pi)^2, tip lateral deflection 2 k L / K(k), axial shortening
(2 - 2 E(k)/K(k)) L (K, E complete elliptic integrals, parameter m = k^2). EA L^2/EI = 1e5 shifts the critical
load and the post-buckled shape by ~P/EA <= 1e-4 relative (measured: the tip rotation at 2..3 P_cr converges to
2.5e-4 rad above the elastica with n; it drops to 2.4e-5 rad with EA x 10).

The full run adds a stiff wire, EA L^2/EI = 1e7, 32 elements. Before the fix in StaticProblem.stability (threshold
100 eps ||H|| instead of 1e-10 ||H||, tests/statics/test_statics_stability.py) that column at 1.1 and 2 P_cr came back
straight with stable=True after 2 iterations ('full steps' only, no attempt to leave): its negative eigenvalue,
-0.063 at 2 P_cr, was below 1e-10 of the reduced Hessian's norm (1.5e9). Already at EA L^2/EI = 1e5, 32 elements,
1.01 P_cr was missed the same way (eigenvalue -4e-11 of the norm).
The lateral direction (+x or -x) is the solver's pick; results are compared as magnitudes.

Records: load_over_pcr, n, escape_saddle, branch, tip_lateral_m, ref_tip_lateral_m, tip_rotation_rad,
ref_tip_rotation_rad, axial_shortening_m, ref_axial_shortening_m, stable, potential, iterations, wall_s, status,
attempts.
Run: python examples/buckling.py [--quick] [--json out.json] [--out DIR]
"""
from __future__ import annotations

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common as C  # noqa: E402  (first: it limits BLAS threads before numpy loads)

import numpy as np  # noqa: E402
from scipy.optimize import brentq  # noqa: E402
from scipy.special import ellipe, ellipk  # noqa: E402

from ancf_sym import Material, Scene, Section, solve_static  # noqa: E402

L, EI, EA = 1.0, 1.0, 1e5
P_CR = math.pi**2 * EI / (4 * L**2)


def elastica_column(lam: float) -> tuple[float, float, float]:
    """(tip lateral, tip rotation, axial shortening) of the inextensible clamped-free elastica at P = lam P_cr."""
    if lam <= 1.0:
        return 0.0, 0.0, 0.0
    k = brentq(lambda k: (2 * ellipk(k * k) / math.pi) ** 2 - lam, 1e-14, 1 - 1e-15, xtol=1e-16, rtol=1e-15)
    K, E = ellipk(k * k), ellipe(k * k)
    return 2 * k * L / K, 2 * math.asin(k), (2 - 2 * E / K) * L


def column(n: int, lam: float, ea: float = EA) -> Scene:
    s = Scene(dim=2, name="column")
    s.member("column", points=[(0.0, 0.0), (0.0, L)], elements=n, material=Material(E=1e7, density=1.0),
             section=Section(area=ea / 1e7, I=EI / 1e7), axial="decoupled", bending=True, gravity=False)
    s.clamp("column", at="start")
    s.force("column", at="end", force=(0.0, -lam * P_CR))
    return s


def solve(n: int, lam: float, escape: bool, ea: float = EA) -> tuple[dict, np.ndarray]:
    r = solve_static(column(n, lam, ea), escape_saddle=escape)
    tip, t = r.tip("column"), r.slopes("column")[-1]
    ref = elastica_column(lam)
    lateral = abs(tip[0])
    rec = {"load_over_pcr": lam, "n": n, "EA": ea, "escape_saddle": escape,
           "branch": "bent" if lateral > 1e-6 * L else "straight",
           "tip_lateral_m": lateral, "ref_tip_lateral_m": ref[0],
           "tip_rotation_rad": math.atan2(abs(t[0]), t[1]), "ref_tip_rotation_rad": ref[1],
           "axial_shortening_m": L - tip[1], "ref_axial_shortening_m": ref[2],
           "stable": r.stable, "potential": r.potential, "iterations": r.iterations, "wall_s": r.wall_s,
           "status": r.status, "success": r.success, "attempts": C.attempts_text(r)}
    return rec, r.along("column")["r"]


def main(argv=None):
    a = C.parser("buckling", __doc__).parse_args(argv)
    if a.quick:
        loads, ns = (0.9, 1.1, 1.5, 2.0), (8,)
    else:
        loads, ns = (0.5, 0.9, 0.99, 1.01, 1.05, 1.1, 1.2, 1.5, 2.0, 2.5, 3.0), (4, 8, 16)
    records, shapes = [], {}
    for n in ns:
        for lam in loads:
            for escape in (True, False):
                rec, r = solve(n, lam, escape)
                records.append(rec)
                shapes[(n, lam, escape)] = r
    if not a.quick:  # a stiff wire: EA L^2/EI = 1e7 (see the docstring)
        for lam in (1.1, 2.0):
            for escape in (True, False):
                records.append(solve(32, lam, escape, ea=1e7)[0])
    fmt = {"tip_lateral_m": "{:.6f}", "ref_tip_lateral_m": "{:.6f}", "tip_rotation_rad": "{:.5f}",
           "ref_tip_rotation_rad": "{:.5f}", "potential": "{:+.6f}", "wall_s": "{:.3f}"}
    C.table(records, ["load_over_pcr", "n", "EA", "escape_saddle", "branch", "stable", "tip_lateral_m", "ref_tip_lateral_m",
                      "tip_rotation_rad", "ref_tip_rotation_rad", "potential", "iterations", "status"],
            f"Clamped-free column, dead axial load, P_cr = {P_CR:.5f} N (no imperfection)", fmt)
    print("solver attempts with escape_saddle=True:")
    for r in records:
        if r["escape_saddle"] and (r["n"] == ns[-1] or r["EA"] != EA):
            print(f"  P/P_cr = {r['load_over_pcr']:g}, n = {r['n']}, EA = {r['EA']:g}: {r['attempts']}")
    C.write_json(records, a.json)
    if not a.no_plots:
        plt = C.pyplot()
        fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
        lam_f = np.linspace(1.0, max(loads), 200)
        refs = np.array([elastica_column(x) for x in lam_f])
        axes[0].plot(refs[:, 1], lam_f, "k-", label="elastica")
        axes[0].plot([0, 0], [0, max(loads)], "k:", lw=0.8, label="straight (unstable above 1)")
        for n, mk in zip(ns, "osd^"):
            rs = [r for r in records if r["n"] == n and r["escape_saddle"] and r["EA"] == EA]
            axes[0].plot([r["tip_rotation_rad"] for r in rs], [r["load_over_pcr"] for r in rs], mk, mfc="none",
                         label=f"ANCF n={n}")
        axes[0].set_xlabel("tip rotation [rad]"), axes[0].set_ylabel("P / P_cr"), axes[0].grid(alpha=0.3)
        axes[0].legend(fontsize=7), axes[0].set_title("post-buckling: load vs tip rotation")
        n = ns[-1]
        for lam in loads:
            r = shapes[(n, lam, True)]
            axes[1].plot(np.abs(r[:, 0]), r[:, 1], label=f"P/P_cr = {lam:g}")
        axes[1].set_aspect("equal"), axes[1].set_xlabel("|x| [m]"), axes[1].set_ylabel("y [m]"), axes[1].grid(alpha=0.3)
        axes[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
        axes[1].set_title(f"equilibrium shapes (n = {n})")
        C.save(fig, a.out, "buckling.png")
    return records


if __name__ == "__main__":
    main()
