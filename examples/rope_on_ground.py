"""Rope on the ground: statics with exact unilateral contact against the catenary with touchdown, and a dropped rope
coming to rest on a penalty/Hertz ground (dynamics).

Statics. A steel rope (d = 10 mm, E = 200 GPa, rho = 7850, no bending stiffness, Biot strain) of unstretched length
L0 = 12.5 m, pinned at (0, h) and (S, h), S = 10 m, h = 2 m, above a frictionless ground y = 0. Its centre line lies
at y = t = 5 mm (the section's radius) where it touches. Contact is `method="exact"`: the rows n.r - t >= 0 at the
Gauss points are inequality constraints of the IPOPT problem (no stiffness to choose); their multipliers are the
contact forces. Reference: the elastic catenary with touchdown. On the ground the tension is the horizontal H
(frictionless) and the vertical force is zero at the touchdown point, so each hanging part is an elastic catenary
starting horizontally there (Irvine, Cable Structures, 1981): at unstretched distance s from the touchdown
    x(s) = H s / EA + (H / w) asinh(w s / H),   y(s) = w s^2 / (2 EA) + (sqrt(H^2 + w^2 s^2) - H) / w,
with the hanging length s1 and H from y(s1) = h - t and 2 x(s1) + (L0 - 2 s1)(1 + H / EA) = S. The model starts
from a trapezoid reference (two legs and a grounded middle, joined by hinges: a rope without bending transmits no
moment). Records: max_error_m (positions at the nodes' material points), touchdown_m (first Gauss point carrying
contact force) vs touchdown_ref_m, H_N (pin multiplier) vs H_ref_N, ground_force_N (sum of the contact
multipliers) vs the grounded weight w (L0 - 2 s1).

Dynamics. A 1 m rope (d = 10 mm, E = 2 GPa, rho = 1000) dropped from 5 cm onto a ground with the linear or the
Hertz law, contact damping and friction: it comes to rest with the normal force equal to its weight. Records:
final speed, normal force vs weight, penetration vs the static one, damping work vs initial energy.

Run: python examples/rope_on_ground.py [--quick] [--json out.json] [--out DIR]
"""
from __future__ import annotations

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common as C  # noqa: E402  (first: it limits BLAS threads before numpy loads)

import numpy as np  # noqa: E402
from scipy.optimize import brentq  # noqa: E402

from ancf_sym import Material, Scene, Section, solve_static  # noqa: E402
from ancf_sym import contact  # noqa: E402
from ancf_sym.model.assembly import Assembly  # noqa: E402
from ancf_sym.dynamics import DynamicOptions, simulate  # noqa: E402

G = 9.81
S, HGT, L0, D = 10.0, 2.0, 12.5, 0.01
STEEL = Material(E=200e9, density=7850.0)
# A wire rope's bending stiffness is a small fraction of the solid bar's; this one's bending length sqrt(EI / H)
# is 8 mm, far below the mesh size, so the catenary (EI = 0) is the reference, while the tangent stays regular
# where the rope lies slack on the ground at the start (a rope without EI has no stiffness there at all).
BEND_I = 1e-15


# -- closed form ------------------------------------------------------------------------------------------------
def hanging(s, H, w, EA):
    s = np.asarray(s, float)
    return H * s / EA + H / w * np.arcsinh(w * s / H), w * s**2 / (2 * EA) + (np.hypot(H, w * s) - H) / w


def touchdown_reference(w: float, EA: float, t: float) -> tuple[float, float, float]:
    """(H, s1, x_touchdown) of the elastic catenary with touchdown: for a given H the hanging length s1 solves
    y(s1) = h - t (y grows with s); H then closes the span. A rope longer than S + 2 (h - t) would lie slack."""
    def s1_of(H):
        return brentq(lambda s: hanging(s, H, w, EA)[1] - (HGT - t), 0.0, L0 / 2, xtol=1e-15, rtol=1e-15)

    def span(H):
        if hanging(L0 / 2, H, w, EA)[1] < HGT - t:  # so flat that half the rope does not reach the pin: no touchdown
            return L0
        s1 = s1_of(H)
        return 2 * hanging(s1, H, w, EA)[0] + (L0 - 2 * s1) * (1 + H / EA) - S

    H = brentq(span, 1e-6 * w * L0, 1e3 * w * L0, xtol=1e-14, rtol=1e-15)
    s1 = s1_of(H)
    return H, s1, float(S / 2 - (L0 / 2 - s1) * (1 + H / EA))


def reference_position(s, H, s1, xT, w, EA, t):
    """Centre line at unstretched distance s from the left pin (left half; the right half mirrors it)."""
    s = np.asarray(s, float)
    x_h, y_h = hanging(s1 - np.minimum(s, s1), H, w, EA)
    on_ground = s > s1
    x = np.where(on_ground, xT + (s - s1) * (1 + H / EA), xT - x_h)
    y = np.where(on_ground, t, t + y_h)
    return np.stack([x, y], axis=-1)


# -- statics model ------------------------------------------------------------------------------------------------
def static_case(n_leg: int, n_ground: int) -> tuple[dict, np.ndarray, np.ndarray]:
    sec = Section(area=math.pi * D**2 / 4, I=BEND_I)
    t = D / 2
    w, EA = STEEL.density * sec.area * G, STEEL.E * sec.area
    # trapezoid reference of length L0: legs from the pins down to the ground, a grounded middle
    a = brentq(lambda a: 2 * math.hypot(a, HGT - t) + S - 2 * a - L0, 0.0, S / 2)
    sc = Scene(dim=2, gravity=(0.0, -G), name="rope_on_ground")
    kw = dict(material=STEEL, section=sec, axial="biot", bending=True)
    sc.member("left", [(0.0, HGT), (a, t)], n_leg, **kw)
    sc.member("ground", [(a, t), (S - a, t)], n_ground, **kw)
    sc.member("right", [(S - a, t), (S, HGT)], n_leg, **kw)
    sc.pin("left", "start")
    sc.pin("right", "end")
    sc.hinge(("left", "end"), ("ground", "start"))
    sc.hinge(("ground", "end"), ("right", "start"))
    for m in ("left", "ground", "right"):
        sc.contact_ground(m, method="exact")
    r = solve_static(sc)
    H, s1, xT = touchdown_reference(w, EA, t)
    asm = r.assembly
    err, pts, ref = 0.0, [], []
    offset = {"left": 0.0, "ground": asm.mesh.members["left"].elem_length.sum()}
    for name, s0 in offset.items():
        mm = asm.mesh.members[name]
        xn = asm.member_coordinates(r.x, name)[:, :2]
        s = s0 + mm.s_node
        left = s <= L0 / 2 + 1e-12
        rr = reference_position(s[left], H, s1, xT, w, EA, t)
        err = max(err, float(np.abs(xn[left] - rr).max()))
        pts.append(xn)
        ref.append(rr)
    # contact points carrying force: the leftmost is the touchdown
    forces = np.asarray(r.constraint_forces.get("contact", []))
    A, b, labels = contact.unilateral(asm)
    xs = np.array([_point_x(asm, r.x, m, e, xi) for m, e, xi in labels])
    carrying = forces > 1e-6 * w * L0
    touchdown = float(xs[carrying].min()) if carrying.any() else float("nan")
    lam = r.constraint_forces.get("pin left@start", [float("nan")] * 2)
    rec = {"case": "statics_exact", "n": 2 * n_leg + n_ground, "success": r.success, "status": r.status,
           "iterations": r.iterations, "wall_s": r.wall_s, "max_error_m": err, "touchdown_m": touchdown,
           "touchdown_ref_m": xT, "H_N": abs(lam[0]), "H_ref_N": H, "ground_force_N": float(forces.sum()),
           "ground_weight_ref_N": w * (L0 - 2 * s1), "constraint_violation": r.constraint_violation}
    return rec, np.vstack(pts), np.vstack(ref)


def _point_x(asm, x, member, e, xi) -> float:
    mm = asm.mesh.members[member]
    X = asm.member_coordinates(x, member)
    a, b = mm.elem_nodes[e]
    L = mm.elem_length[e]
    h = [1 - 3 * xi**2 + 2 * xi**3, xi - 2 * xi**2 + xi**3, 3 * xi**2 - 2 * xi**3, -(xi**2) + xi**3]
    return float(h[0] * X[a, 0] + L * h[1] * X[a, 2] + h[2] * X[b, 0] + L * h[3] * X[b, 2])


# -- dynamics: a dropped rope ---------------------------------------------------------------------------------------
def drop_case(law: str, t_end: float) -> tuple[dict, np.ndarray, np.ndarray]:
    mat, sec = Material(E=2e9, density=1000.0), Section.circle(D)
    w = mat.density * sec.area * G
    sc = Scene(dim=2, gravity=(0.0, -G), name=f"rope_drop_{law}")
    sc.member("rope", [(0.0, 0.05), (1.0, 0.05)], 20, mat, sec)
    k = 1e4 if law == "linear" else 0.0
    kh = 1e6 if law == "hertz" else 0.0
    sc.contact_ground("rope", stiffness=k, hertz=kh, damping=3e4 if law == "linear" else 3e5, mu=0.3, eps=1e-2)
    asm = Assembly(sc)
    res = simulate(asm, DynamicOptions(dt=1e-3, t_end=t_end, integrator="generalized_alpha"))
    rep = contact.report(asm, res.x)[0]
    delta_static = w / k if law == "linear" else (w / kh) ** (2 / 3)
    en = res.energies
    rec = {"case": f"drop_{law}", "success": res.success, "status": res.status, "steps": res.steps,
           "newton_per_step": res.counters["newton_iterations"] / max(res.steps, 1), "wall_s": res.wall_s,
           "final_speed_m_s": float(np.abs(res.v).max()), "normal_force_N": rep["normal_force"], "weight_N": w,
           "penetration_m": -rep["min_gap"], "penetration_ref_m": delta_static,
           "damping_work_J": en["damping_work"][-1], "initial_energy_J": en["total"][0],
           "energy_error_J": en["algorithmic"][-1]}
    return rec, np.asarray(res.t), np.asarray(en["total"])


def main(argv=None):
    a = C.parser("rope_on_ground", __doc__).parse_args(argv)
    n_leg, n_ground = 16, 32  # finer meshes converge too (each starts from the twice coarser one: docs/contact.md)
    rec, pts, ref = static_case(n_leg, n_ground)
    records = [rec]
    drops = []
    for law in ("linear", "hertz"):
        r, t, e = drop_case(law, 1.5 if a.quick else 2.5)
        records.append(r)
        drops.append((law, t, e))
    C.table(records[:1], ["case", "n", "max_error_m", "touchdown_m", "touchdown_ref_m", "H_N", "H_ref_N",
                          "ground_force_N", "ground_weight_ref_N", "iterations", "status"])
    C.table(records[1:], ["case", "final_speed_m_s", "normal_force_N", "weight_N", "penetration_m",
                          "penetration_ref_m", "newton_per_step", "energy_error_J", "status"])

    def plots(out):
        plt = C.pyplot()
        fig, axes = plt.subplots(1, 2, figsize=(11, 4))
        axes[0].plot(ref[:, 0], ref[:, 1], "-", lw=3, alpha=0.35, label="catenary with touchdown")
        axes[0].plot(pts[:, 0], pts[:, 1], "o", ms=3, label="ANCF, exact unilateral contact")
        axes[0].axhline(0.0, color="k", lw=0.8)
        axes[0].set_xlabel("x [m]"), axes[0].set_ylabel("y [m]"), axes[0].legend()
        for law, t, e in drops:
            axes[1].plot(t, e, label=f"{law} law")
        axes[1].set_xlabel("t [s]"), axes[1].set_ylabel("mechanical energy [J]"), axes[1].legend()
        axes[1].set_title("dropped rope: energy")
        C.save(fig, out, "rope_on_ground.png")

    return C.finish(records, a, plots)


if __name__ == "__main__":
    main()
