"""A chain on the seabed at 50, 200 and 600 m depth, solved statically (no dynamic pre-run), against the quasi-static
chain cases MoorDyn checks against OrcaFlex.

Chain: volume-equivalent diameter 0.252 m, 390 kg/m, EA 1.674e9 N, in water of 1025 kg/m^3 (g 9.80665); anchor on
the seabed, fairlead at the surface; (horizontal offset, depth, length) = (400, 50, 410), (700, 200, 760),
(1500, 600, 1700) m. OrcaFlex's fairlead / anchor tensions: 991.6/826.2, 2065.4/1402.2, 5232.6/3244.2 kN. The seabed
is the ground contact at the depth (ancf_sym.water: seabed.stiffness = 3 MPa/m x d as MoorDyn's default, no
friction: the anchor tension is then the horizontal tension). A chain has no bending stiffness (bending = false), so
the start geometry is two straight members, one along the seabed and one up to the fairlead, joined by a hinge (the
scene API pins an end where the reference puts it). A second reference is the elastic catenary with a grounded
part (Irvine): x(s) = H s/EA + H/w asinh(w s/H), y(s) = w s^2/(2 EA) + (sqrt(H^2 + w^2 s^2) - H)/w for the
hanging length s from the touchdown point, the rest lying on the seabed at tension H. Records: case, n, T_fairlead_kN,
T_anchor_kN, their references and relative differences, H_catenary_kN, catenary_rel_diff, iterations, wall_s, status.

Run: python examples/seabed_chain.py [--quick] [--json out.json] [--out DIR]
"""
from __future__ import annotations

import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common as C  # noqa: E402  (first: it limits BLAS threads before numpy loads)

import numpy as np  # noqa: E402
from scipy.optimize import brentq  # noqa: E402

from ancf_sym import Material, Scene, Section, solve_static  # noqa: E402

D, MASS, EA, RHO_W, G = 0.252, 390.0, 1.674e9, 1025.0, 9.80665
CASES = {"50m": (400.0, 50.0, 410.0, 991.6, 826.2), "200m": (700.0, 200.0, 760.0, 2065.4, 1402.2),
         "600m": (1500.0, 600.0, 1700.0, 5232.6, 3244.2)}


def submerged_weight() -> float:
    return (MASS - RHO_W * math.pi * D * D / 4) * G


def catenary(X: float, h: float, L: float) -> tuple[float, float]:
    """(H, fairlead tension) [N] of the elastic catenary with its grounded part (frictionless seabed)."""
    w = submerged_weight()

    def hanging(H):
        return brentq(lambda s: w * s * s / (2 * EA) + (math.hypot(H, w * s) - H) / w - h, 1e-9, 100 * L)

    def gap(H):
        s = hanging(H)
        return H * s / EA + H / w * math.asinh(w * s / H) + (L - s) * (1 + H / EA) - X
    H = brentq(gap, 1e-3 * w * L, 1e3 * w * L, xtol=1e-9, rtol=1e-14)
    return H, math.hypot(H, w * hanging(H))


def scene(case: str, n: int) -> Scene:
    X, h, L = CASES[case][:3]
    xp = brentq(lambda x: x + math.hypot(X - x, h) - L, 0.0, X)  # where the grounded straight part ends
    n_bed = max(2, round(n * xp / L))
    sec = Section.circle(D)
    kw = dict(material=Material(E=EA / sec.area, density=MASS / sec.area), section=sec, axial="biot", bending=False)
    s = Scene(dim=2, gravity=[0.0, -G], name=f"chain_{case}")
    s.member("bed", [(0.0, -h), (xp, -h)], n_bed, **kw)
    s.member("hang", [(xp, -h), (X, 0.0)], n - n_bed, **kw)
    s.hinge(("bed", "end"), ("hang", "start"))
    s.pin("bed", "start")
    s.pin("hang", "end")
    s.set_water(density=RHO_W, depth=h, seabed={"stiffness": 3e6 * D})
    return s


def solve(case: str, n: int) -> tuple[dict, np.ndarray]:
    X, h, L, Tf_ref, Ta_ref = CASES[case]
    t = time.perf_counter()
    r = solve_static(scene(case, n))
    wall = time.perf_counter() - t
    fa = np.array(r.constraint_forces["pin bed@start"])
    ff = np.array(r.constraint_forces["pin hang@end"])
    Tf, Ta = np.linalg.norm(ff) / 1e3, np.linalg.norm(fa) / 1e3
    H_cat, T_cat = catenary(X, h, L)
    rec = dict(case=case, n=n, T_fairlead_kN=Tf, T_anchor_kN=Ta, T_fairlead_ref_kN=Tf_ref, T_anchor_ref_kN=Ta_ref,
               fairlead_rel_diff=Tf / Tf_ref - 1, anchor_rel_diff=Ta / Ta_ref - 1, H_kN=abs(ff[0]) / 1e3,
               H_catenary_kN=H_cat / 1e3, T_fairlead_catenary_kN=T_cat / 1e3,
               catenary_rel_diff=max(abs(abs(ff[0]) / H_cat - 1), abs(Tf * 1e3 / T_cat - 1)),
               iterations=r.iterations, wall_s=wall, status=r.status, success=r.success, stable=r.stable)
    shape = np.vstack([r.nodes("bed"), r.nodes("hang")])
    return rec, shape


def plots(shapes, out):
    plt = C.pyplot()
    fig, ax = plt.subplots(figsize=(8, 4))
    for case, xy in shapes.items():
        ax.plot(xy[:, 0], xy[:, 1], ".-", ms=3, label=case)
    ax.set_xlabel("x [m]"), ax.set_ylabel("z [m]"), ax.legend(fontsize=7), ax.set_title("chains on the seabed")
    C.save(fig, out, "seabed_chain.png")


def main(argv=None):
    a = C.parser("seabed_chain", __doc__).parse_args(argv)
    ns = (10, 40) if a.quick else (10, 20, 40, 80, 160)
    records, shapes = [], {}
    for case in CASES:
        for n in ns:
            rec, shape = solve(case, n)
            records.append(rec)
            shapes[case] = shape
    C.table(records, ["case", "n", "T_fairlead_kN", "T_fairlead_ref_kN", "T_anchor_kN", "T_anchor_ref_kN",
                      "catenary_rel_diff", "iterations", "wall_s", "status"],
            "Chain on the seabed: tensions vs OrcaFlex (MoorDyn's quasi-static cases) and the elastic catenary",
            {"T_fairlead_kN": "{:.1f}", "T_anchor_kN": "{:.1f}", "catenary_rel_diff": "{:.2e}", "wall_s": "{:.3f}"})
    return C.finish(records, a, plots, shapes)


if __name__ == "__main__":
    main()
