"""Towed cable: a long cable towed at U = 2 m/s through still water, normal Morison drag only, solved statically.

In the cable's frame the water streams past at U. A cable with submerged weight w per length and normal drag only
(rho = 1025 kg/m^3, Cd = 1.2, d = 0.02 m, w = 10 N/m) trails straight at the angle phi to the flow where the weight's
normal component balances the normal drag: w cos(phi) = 1/2 rho Cd d U^2 sin^2(phi) (the tangential weight is carried
by the tension, which grows from zero at the free end). The drag is not conservative: the statics solve the residual
grad Pi - f_drag = 0 by Newton on its exact Jacobian (ancf_sym.statics.water). Records: n, angle_deg (the straight
part's angle to the flow, between the middle and the free end), angle_ref_deg, error_deg, iterations, wall_s, status.

Run: python examples/towed_cable.py [--quick] [--json out.json] [--out DIR]
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

RHO_W, CD, D, U, W, G, LENGTH = 1025.0, 1.2, 0.02, 2.0, 10.0, 9.81, 100.0


def reference_angle() -> float:
    """phi [rad] of w cos(phi) = 1/2 rho Cd d U^2 sin^2(phi)."""
    return brentq(lambda p: W * math.cos(p) - 0.5 * RHO_W * CD * D * U ** 2 * math.sin(p) ** 2, 1e-9, math.pi / 2)


def scene(n: int) -> Scene:
    sec = Section.circle(D)
    rho_a = W / G + RHO_W * sec.area  # mass per length whose weight less the displaced water's is W
    s = Scene(dim=2, gravity=[0.0, -G], name="towed_cable")
    s.member("cable", [(0.0, 0.0), (0.0, -LENGTH)], n, Material(E=1e11, density=rho_a / sec.area), sec,
             axial="biot", bending=False)
    s.pin("cable", "start")
    s.set_water(density=RHO_W, current=[U, 0.0], lines={"cable": {"cd": CD}})
    return s


def solve(n: int) -> dict:
    t = time.perf_counter()
    r = solve_static(scene(n))
    wall = time.perf_counter() - t
    nodes = r.nodes("cable")
    d = nodes[-1] - nodes[len(nodes) // 2]
    ang = math.degrees(math.atan2(-d[1], d[0]))
    ref = math.degrees(reference_angle())
    return dict(n=n, angle_deg=ang, angle_ref_deg=ref, error_deg=ang - ref, iterations=r.iterations, wall_s=wall,
                status=r.status, success=r.success, stable=r.stable)


def plots(records, shapes, out):
    plt = C.pyplot()
    fig, ax = plt.subplots(figsize=(6, 4))
    for n, xy in shapes.items():
        ax.plot(xy[:, 0], xy[:, 1], "o-", ms=3, label=f"n = {n}")
    phi = reference_angle()
    ax.plot([0, LENGTH * math.cos(phi)], [0, -LENGTH * math.sin(phi)], "k--", lw=1, label="closed form")
    ax.set_aspect("equal"), ax.set_xlabel("x (downstream) [m]"), ax.set_ylabel("y [m]"), ax.legend(fontsize=7)
    ax.set_title("towed cable in a 2 m/s stream")
    C.save(fig, out, "towed_cable.png")


def main(argv=None):
    a = C.parser("towed_cable", __doc__).parse_args(argv)
    ns = (4, 16) if a.quick else (4, 16, 64)
    records, shapes = [], {}
    for n in ns:
        rec = solve(n)
        records.append(rec)
        shapes[n] = solve_static(scene(n)).nodes("cable") if not a.no_plots else None
    C.table(records, ["n", "angle_deg", "angle_ref_deg", "error_deg", "iterations", "wall_s", "status"],
            "Towed cable: angle to the flow vs w cos(phi) = 1/2 rho Cd d U^2 sin^2(phi)",
            {"angle_deg": "{:.6f}", "angle_ref_deg": "{:.6f}", "error_deg": "{:.2e}", "wall_s": "{:.3f}"})
    return C.finish(records, a, plots, records, shapes)


if __name__ == "__main__":
    main()
