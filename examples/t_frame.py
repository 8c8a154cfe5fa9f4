"""Frames: members joined by a rigid joint (L and T) or a hinge (two-bar truss), exact constraints and penalties.

Steel members as in paper 002's T-pendulum: E = 210 GPa, solid circle d = 20 mm, 0.5 m long; no gravity.
- L frame: column (0,0)-(0,H) clamped at its base, beam (0,H)-(Lb,H) joined rigidly at the column top
  (`Scene.rigid`), dead load P downward at the beam tip. Linear frame theory (Euler-Bernoulli, axial strain kept):
      tip_x = P Lb H^2 / (2 EI)                          (the column top moment P Lb bends the column)
      tip_y = -(P Lb^3 / (3 EI) + P Lb^2 H / EI + P H / EA)  (beam bending + joint rotation + column shortening)
  ANCF's cubic Hermite element represents these linear solutions exactly, so what is left at a finite load is the
  geometric nonlinearity, proportional to P; the compliance extrapolated to P -> 0 from P = 0.1 N and 1 N is
  compared with the closed form.
- T frame: the same column carrying a bar (-a,H)-(a,H) joined rigidly at its middle node; load at the right tip.
  Linear theory: the right arm as the L frame's beam; the left tip rises by the joint rotation times a.
- Hinged pair: two bars from pins at (-b, 0) and (b, 0) meeting at a hinge (`Scene.hinge`) at (0, h), load P down
  at the hinge. Linear truss theory: apex drop P L / (2 EA sin^2 beta), no bending (the hinge carries no moment).
- Penalty variant of the L frame's rigid joint (method='penalty', factor k on EA/(1 m) for the shared point and
  EI/(1 m) for the angle, paper 002): tip error against the exact-constraint solution and the joint's angle error,
  vs the factor.

Records: case, method, penalty, n, load_N, tip_x, tip_y (DISPLACEMENT of the loaded tip / apex [m]), ref_tip_x,
ref_tip_y (linear theory), angle_error_deg (change of the joint's angle), constraint_violation, iterations, status
(+ rel_err_x/y against linear theory, err_vs_exact_m and moved for the penalties, bending_J for the truss).
Run: python examples/t_frame.py [--quick] [--json out.json] [--out DIR]
"""
from __future__ import annotations

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common as C  # noqa: E402  (first: it limits BLAS threads before numpy loads)

import numpy as np  # noqa: E402

from ancf_sym import Material, Scene, Section, solve_static  # noqa: E402
from ancf_sym.model import fields  # noqa: E402

STEEL = Material(E=210e9, density=7850.0)
SEC = Section.circle(0.02)
EI, EA = STEEL.E * SEC.I, STEEL.E * SEC.area
H = LB = 0.5  # column height, beam length [m]
TRUSS_B, TRUSS_H = 0.5, 0.3  # truss half-span, rise [m]


def linear_L(P: float) -> tuple[float, float]:
    return P * LB * H**2 / (2 * EI), -(P * LB**3 / (3 * EI) + P * LB**2 * H / EI + P * H / EA)


def _members(s: Scene, names_points, n):
    for name, pts in names_points:
        s.member(name, points=pts, elements=n, material=STEEL, section=SEC, axial="biot", bending=True, gravity=False)


def frame(kind: str, n: int, P: float, method: str = "exact", penalty: float | None = None) -> Scene:
    s = Scene(dim=2, name=f"{kind}_frame")
    if kind == "L":
        _members(s, [("column", [(0, 0), (0, H)]), ("beam", [(0, H), (LB, H)])], n)
        s.rigid(("column", "end"), ("beam", "start"), method=method, penalty=penalty)
        s.force("beam", at="end", force=(0.0, -P))
    elif kind == "T":
        _members(s, [("column", [(0, 0), (0, H)])], n)
        _members(s, [("beam", [(-LB, H), (LB, H)])], 2 * n)  # node n is the bar's middle
        s.rigid(("column", "end"), ("beam", n), method=method, penalty=penalty)
        s.force("beam", at="end", force=(0.0, -P))
    else:
        raise ValueError(kind)
    s.clamp("column", at="start")
    return s


def joint_angle_error_deg(r, node_b: int | str = "start") -> float:
    """Change of the angle between the column's top tangent and the beam's tangent at the joint [deg]."""
    a = r.assembly
    tc, tb = r.slopes("column")[-1], r.slopes("beam")[0 if node_b == "start" else node_b]
    x0 = a.x0
    mmc, mmb = a.mesh.members["column"], a.mesh.members["beam"]
    tc0 = a.member_coordinates(x0, "column")[mmc.public_nodes][-1, 2:4]
    tb0 = a.member_coordinates(x0, "beam")[mmb.public_nodes][0 if node_b == "start" else node_b, 2:4]
    return math.degrees(C.turn_angle(tc, tb) - C.turn_angle(tc0, tb0))


def base_record(case, method, penalty, n, P, r, tip, ref):
    return {"case": case, "method": method, "penalty": penalty, "n": n, "load_N": P, "tip_x": tip[0], "tip_y": tip[1],
            "ref_tip_x": ref[0], "ref_tip_y": ref[1], "constraint_violation": r.constraint_violation,
            "iterations": r.iterations, "wall_s": r.wall_s, "status": r.status, "success": r.success,
            "stable": r.stable}


def run_L(n, P, method="exact", penalty=None):
    r = solve_static(frame("L", n, P, method, penalty))
    d = r.tip("beam") - np.array([LB, H])
    ref = linear_L(P)
    rec = base_record("L_rigid", method, penalty, n, P, r, d, ref)
    rec.update(rel_err_x=d[0] / ref[0] - 1, rel_err_y=d[1] / ref[1] - 1, angle_error_deg=joint_angle_error_deg(r))
    return rec


def run_T(n, P):
    r = solve_static(frame("T", n, P))
    bx, by = linear_L(P)
    theta = P * LB * H / EI  # joint rotation (clockwise)
    nodes = r.nodes("beam")
    right, left = nodes[-1] - [LB, H], nodes[0] - [-LB, H]
    rec = base_record("T_rigid", "exact", None, n, P, r, right, (bx, by))
    rec.update(rel_err_x=right[0] / bx - 1, rel_err_y=right[1] / by - 1,
               angle_error_deg=joint_angle_error_deg(r, node_b=n),
               left_tip_x=left[0], left_tip_y=left[1], ref_left_tip_x=bx, ref_left_tip_y=theta * LB - P * H / EA)
    return rec


def run_truss(n, P):
    s = Scene(dim=2, name="hinged_pair")
    _members(s, [("left", [(-TRUSS_B, 0), (0, TRUSS_H)]), ("right", [(TRUSS_B, 0), (0, TRUSS_H)])], n)
    s.pin("left", at="start")
    s.pin("right", at="start")
    s.hinge(("left", "end"), ("right", "end"))
    s.force("left", at="end", force=(0.0, -P))
    r = solve_static(s)
    Lm = math.hypot(TRUSS_B, TRUSS_H)
    sin_b = TRUSS_H / Lm
    ref = (0.0, -P * Lm / (2 * EA * sin_b**2))
    d = r.tip("left") - np.array([0.0, TRUSS_H])
    rec = base_record("hinged_pair", "exact", None, n, P, r, d, ref)
    tl, tr = r.slopes("left")[-1], r.slopes("right")[-1]
    tl0, tr0 = np.array([TRUSS_B, TRUSS_H]) / Lm, np.array([-TRUSS_B, TRUSS_H]) / Lm
    rec.update(rel_err_x=float("nan"), rel_err_y=d[1] / ref[1] - 1, angle_error_deg=None,
               hinge_rotation_deg=math.degrees(C.turn_angle(tl, tr) - C.turn_angle(tl0, tr0)),
               bending_J=r.energies.get("bending", 0.0), axial_J=r.energies.get("axial", 0.0))
    return rec


def extrapolated_compliance(records, case="L_rigid", n=2):
    """Linear compliance [m/N] from two loads: d(P) = c P + b P^2 -> c = (d1/P1 P2 - d2/P2 P1) / (P2 - P1)."""
    rs = sorted((r for r in records if r["case"] == case and r["method"] == "exact" and r["n"] == n),
                key=lambda r: r["load_N"])
    (r1, r2) = rs[0], rs[-1]
    P1, P2 = r1["load_N"], r2["load_N"]
    out = {}
    for k in ("tip_x", "tip_y"):
        out[k] = (r1[k] / P1 * P2 - r2[k] / P2 * P1) / (P2 - P1)
    ref = linear_L(1.0)
    out["rel_err_x"], out["rel_err_y"] = out["tip_x"] / ref[0] - 1, out["tip_y"] / ref[1] - 1
    return out


def main(argv=None):
    a = C.parser("t_frame", __doc__).parse_args(argv)
    ns = (2,) if a.quick else (1, 2, 4)
    loads = (0.1, 1.0) if a.quick else (0.1, 1.0, 10.0)
    factors = (1.0, 1e2, 1e4, 1e6, 1e8) if a.quick else (1e-2, 1.0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e10)
    P_pen = 1.0
    records = []
    for n in ns:
        for P in loads:
            records.append(run_L(n, P))
    exact = next(r for r in records if r["n"] == 2 and r["load_N"] == P_pen)
    for k in factors:
        rec = run_L(2, P_pen, "penalty", k)
        rec["err_vs_exact_m"] = math.hypot(rec["tip_x"] - exact["tip_x"], rec["tip_y"] - exact["tip_y"])
        rec["moved"] = rec["iterations"] > 0
        records.append(rec)
    for P in loads[:2]:
        records.append(run_T(2, P))
    for n in ns:
        records.append(run_truss(n, 1000.0))
    fmt = {"tip_x": "{:.4e}", "tip_y": "{:.4e}", "ref_tip_x": "{:.4e}", "ref_tip_y": "{:.4e}", "rel_err_x": "{:+.2e}",
           "rel_err_y": "{:+.2e}", "angle_error_deg": "{:.1e}", "constraint_violation": "{:.1e}",
           "err_vs_exact_m": "{:.2e}", "penalty": "{:g}", "wall_s": "{:.3f}"}
    exact_recs = [r for r in records if r["method"] == "exact"]
    C.table(exact_recs, ["case", "n", "load_N", "tip_x", "ref_tip_x", "rel_err_x", "tip_y", "ref_tip_y", "rel_err_y",
                         "angle_error_deg", "constraint_violation", "iterations", "status"],
            "Exact joints vs linear frame / truss theory (rel_err grows with the load: geometric nonlinearity)", fmt)
    ex = extrapolated_compliance(records)
    print(f"L frame, compliance extrapolated to P -> 0 from P = {min(loads)} and 1 N: relative error vs closed form "
          f"x {ex['rel_err_x']:+.2e}, y {ex['rel_err_y']:+.2e}")
    for r in records:
        if r["case"] == "T_rigid":
            print(f"T frame P={r['load_N']:g} N: left tip ({r['left_tip_x']:.4e}, {r['left_tip_y']:.4e}) m, "
                  f"linear ({r['ref_left_tip_x']:.4e}, {r['ref_left_tip_y']:.4e}) m")
        if r["case"] == "hinged_pair":
            print(f"hinged pair n={r['n']}: bending energy {r['bending_J']:.1e} J (axial {r['axial_J']:.3e} J), "
                  f"hinge opened by {r['hinge_rotation_deg']:+.2e} deg")
    pen = [r for r in records if r["method"] == "penalty"]
    C.table(pen, ["penalty", "tip_x", "tip_y", "err_vs_exact_m", "rel_err_y", "angle_error_deg", "constraint_violation",
                  "iterations", "moved", "status"],
            f"L frame, penalty rigid joint (factor x EA/1m, EI/1m), P = {P_pen} N; exact-constraint tip "
            f"({exact['tip_x']:.4e}, {exact['tip_y']:.4e}) m", fmt)
    stuck = [r["penalty"] for r in pen if not r["moved"]]
    if stuck:
        print(f"WARNING: with penalty factors {stuck} IPOPT reported {pen[-1]['status']} after 0 iterations: its "
              "tolerance (relative to the largest stiffness) exceeded the load, so the unloaded start was accepted.")
    C.write_json(records, a.json)
    if not a.no_plots:
        plt = C.pyplot()
        fig, axes = plt.subplots(1, 2, figsize=(11, 4))
        ks = [r["penalty"] for r in pen]
        axes[0].loglog(ks, [max(r["err_vs_exact_m"], 1e-16) for r in pen], "o-", label="|tip - exact| [m]")
        axes[0].loglog(ks, [max(abs(r["angle_error_deg"]), 1e-16) for r in pen], "s--", label="joint angle error [deg]")
        stuck = [r for r in pen if not r["moved"]]
        if stuck:
            axes[0].annotate("IPOPT stopped at the start\n(0 iterations, 'success')",
                             (stuck[0]["penalty"], stuck[0]["err_vs_exact_m"]), xytext=(1e3, 1e-2), fontsize=7,
                             arrowprops={"arrowstyle": "->"})
        axes[0].set_xlabel("penalty factor"), axes[0].grid(alpha=0.3, which="both"), axes[0].legend(fontsize=7)
        axes[0].set_title(f"L frame, penalty rigid joint, P = {P_pen} N")
        # deformed L and T frames, displacements magnified
        scale = 0.1 / abs(linear_L(1.0)[1])
        for kind, col in (("L", "C0"), ("T", "C1")):
            r = solve_static(frame(kind, 4, 1.0))
            for name in ("column", "beam"):
                rd = r.along(name)["r"]
                r0 = fields.sample(r.assembly.mesh.members[name], r.assembly.member_coordinates(r.assembly.x0, name),
                                   8)["r"]
                axes[1].plot(r0[:, 0], r0[:, 1], ":", color="gray", lw=0.8)
                axes[1].plot(r0[:, 0] + scale * (rd[:, 0] - r0[:, 0]), r0[:, 1] + scale * (rd[:, 1] - r0[:, 1]),
                             "-", color=col, label=f"{kind} frame" if name == "column" else None)
        axes[1].set_aspect("equal"), axes[1].legend(fontsize=7), axes[1].grid(alpha=0.3)
        axes[1].set_title(f"deformed shapes, P = 1 N, displacements x {scale:.0f}")
        C.save(fig, a.out, "frames.png")
    return records


if __name__ == "__main__":
    main()
