"""Catenary: a cable without bending stiffness (bending=False, no bending kernel at all) hanging between two pins.

Reference: the ELASTIC catenary (Irvine, Cable Structures, 1981), derived for a linear-elastic, perfectly flexible
cable of unstretched length L0, weight w per unstretched length and axial stiffness EA. With the material coordinate
s in [0, L0] from the left pin, horizontal tension H and the left pin's vertical reaction V (so the vertical
tension component is w s - V):
    x(s) = H s / EA + H / w [asinh((w s - V) / H) - asinh(-V / H)]
    y(s) = (w s^2 / 2 - V s) / EA + [sqrt(H^2 + (w s - V)^2) - sqrt(H^2 + V^2)] / w
H and V solve x(L0) = span, y(L0) = height. The cable uses axial="biot" (eps = |r_x| - 1, tension EA eps), which
is exactly this constitutive law, so the comparison is exact for any EA: the only error left is the mesh's. We
compare positions at the same material point s (stronger than comparing the shapes).

Cases:
- taut_level / taut_inclined: one member whose reference (unstretched) state is the straight chord between the pins
  (L0 = chord), a rubber rope (E = 50 MPa, d = 10 mm, rho = 1100): the sag comes from the stretch (about 0.47 m on
  10 m). The solver starts from the straight reference, where a cable without bending has a singular tangent
  stiffness (no transverse stiffness at zero tension). If that start failed, the example would retry from a
  parabola and say so in the record's `start` field (measured: it never failed; IPOPT's inertia correction copes).
- slack_level / slack_inclined: a steel rope (E = 200 GPa, d = 10 mm, rho = 7850) of unstretched length 12 m between
  pins 10 m apart (level) or 10 m / 3 m apart. The scene API fixes a pin at the reference position, so a slack cable
  needs a reference longer than the chord: two straight members forming a V of total length L0, joined by a hinge
  (shared point, free slopes; a cable without bending transmits no moment, so the hinge changes nothing physically).
  With this stiff EA the elastic catenary is within `inextensible_gap_m` (~1 mm) of the inextensible one.

Records: case, n (total elements), max_error_m, sag_m, H_N (from the pin multiplier), H_ref_N, iterations, wall_s,
status, start.
Run: python examples/catenary.py [--quick] [--json out.json] [--out DIR]
"""
from __future__ import annotations

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common as C  # noqa: E402  (first: it limits BLAS threads before numpy loads)

import numpy as np  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

from ancf_sym import Material, Scene, Section, solve_static  # noqa: E402

G = 9.81
ROPE = {"rubber": (Material(E=50e6, density=1100.0), Section.circle(0.01)),
        "steel": (Material(E=200e9, density=7850.0), Section.circle(0.01))}
CASES = {  # name: (span, height, unstretched length or None = chord, rope)
    "taut_level": (10.0, 0.0, None, "rubber"),
    "taut_inclined": (10.0, 3.0, None, "rubber"),
    "slack_level": (10.0, 0.0, 12.0, "steel"),
    "slack_inclined": (10.0, 3.0, 12.0, "steel"),
}


# -- analytic elastic catenary --------------------------------------------------------------------------------
def catenary_xy(s, H, V, w, EA):
    s = np.asarray(s, float)
    vt = w * s - V
    c = 0.0 if math.isinf(EA) else 1.0 / EA
    x = H * s * c + H / w * (np.arcsinh(vt / H) - np.arcsinh(-V / H))
    y = (w * s**2 / 2 - V * s) * c + (np.hypot(H, vt) - np.hypot(H, V)) / w
    return np.stack([x, y], axis=-1)


def elastic_catenary(L0, span, height, w, EA):
    """(H, V) of the elastic catenary (EA = inf: inextensible) and a function s -> r(s), by a multi-start solve of
    the two end conditions; refuses a residual above 1e-11 m."""
    def res(p):
        return catenary_xy(L0, math.exp(p[0]), p[1] * w * L0, w, EA) - [span, height]

    best = None
    with np.errstate(all="ignore"):  # far-off starts overflow harmlessly; the best residual is checked below
        for H0 in (w * L0 * f for f in (0.05, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0)):
            for v0 in (0.5, 0.0, 1.0):
                sol = least_squares(res, [math.log(H0), v0], xtol=1e-15, ftol=1e-15, gtol=1e-15, method="lm")
                if np.isfinite(sol.cost) and (best is None or sol.cost < best.cost):
                    best = sol
    r = np.abs(res(best.x)).max()
    if r > 1e-11:
        raise RuntimeError(f"elastic catenary: end conditions not met (residual {r:.2e} m)")
    H, V = math.exp(best.x[0]), best.x[1] * w * L0
    return H, V, lambda s: catenary_xy(s, H, V, w, EA)


# -- ANCF model ---------------------------------------------------------------------------------------------
def v_apex(span, height, L0):
    """Apex of the V reference: two legs of L0/2 each from (0, 0) and (span, height), below the chord."""
    d = math.hypot(span, height)
    u = np.array([span, height]) / d
    nrm = np.array([u[1], -u[0]])
    a = L0 / 2
    return u * d / 2 + nrm * math.sqrt(a * a - d * d / 4)


def build(case: str, n: int) -> tuple[Scene, list[tuple[str, float]]]:
    """Scene and its members with the material coordinate of each member's start."""
    span, height, L0, rope = CASES[case]
    mat, sec = ROPE[rope]
    s = Scene(dim=2, gravity=(0.0, -G), name=f"catenary_{case}")
    kw = dict(material=mat, section=sec, axial="biot", bending=False, gravity=True)
    if L0 is None:
        s.member("cable", points=[(0.0, 0.0), (span, height)], elements=n, **kw)
        s.pin("cable", at="start")
        s.pin("cable", at="end")
        return s, [("cable", 0.0)]
    if n % 2:
        raise ValueError("slack cases need an even element count (two members)")
    apex = v_apex(span, height, L0)
    s.member("left", points=[(0.0, 0.0), apex], elements=n // 2, **kw)
    s.member("right", points=[apex, (span, height)], elements=n // 2, **kw)
    s.pin("left", at="start")
    s.pin("right", at="end")
    s.hinge(("left", "end"), ("right", "start"))
    return s, [("left", 0.0), ("right", L0 / 2)]


def parabola_start(scene: Scene, members, case) -> np.ndarray:
    """Fallback initial guess: every node on a parabola through the pins with sag span/10, slopes along it."""
    from ancf_sym.model.assembly import Assembly
    span, height, L0, _ = CASES[case]
    a = Assembly(scene)
    x = a.x0.copy()
    for name, _ in members:
        mm = a.mesh.members[name]
        xn = mm.x0.copy()
        px = xn[:, 0]
        y = height * px / span - 0.4 * span * (px / span) * (1 - px / span)
        dy = height / span - 0.4 * (1 - 2 * px / span)
        xn[:, 1], xn[:, 2], xn[:, 3] = y, 1.0, dy
        x[mm.offset:mm.offset + xn.size] = xn.ravel()
    return x


def solve_case(case: str, n: int) -> tuple[dict, np.ndarray, np.ndarray]:
    span, height, L0, rope = CASES[case]
    mat, sec = ROPE[rope]
    L0 = math.hypot(span, height) if L0 is None else L0
    w, EA = mat.density * sec.area * G, mat.E * sec.area
    H, V, ref = elastic_catenary(L0, span, height, w, EA)
    scene, members = build(case, n)
    r = solve_static(scene)
    start, attempts = "reference (straight)" if case.startswith("taut") else "reference (V)", C.attempts_text(r)
    if not r.success:
        first = f"{r.status} after {attempts}"
        r = solve_static(scene, warm_start=parabola_start(scene, members, case))
        start = f"parabola (reference start failed: {first})"
        attempts = C.attempts_text(r)
    s_all, r_all = [], []
    for name, s0 in members:
        al = r.along(name, per_element=16)
        s_all.append(al["s"] + s0)
        r_all.append(al["r"])
    s_all, r_all = np.concatenate(s_all), np.vstack(r_all)
    err = np.linalg.norm(r_all - ref(s_all), axis=1).max() if r.success else float("nan")
    lam = r.constraint_forces.get(f"pin {members[0][0]}@start", [float("nan")] * 2)
    rec = {"case": case, "n": n, "max_error_m": err, "sag_m": float(-np.min(r_all[:, 1] - height * r_all[:, 0] / span)),
           "H_N": abs(lam[0]), "H_ref_N": H, "V_left_N": -lam[1], "V_left_ref_N": V, "L0_m": L0, "EA_N": EA,
           "w_N_per_m": w, "iterations": r.iterations, "wall_s": r.wall_s, "status": r.status,
           "success": r.success, "stable": r.stable, "start": start, "attempts": attempts,
           "constraint_violation": r.constraint_violation}
    if L0 > math.hypot(span, height):  # how far the stiff elastic catenary is from the inextensible one
        _, _, ref_inext = elastic_catenary(L0, span, height, w, math.inf)
        ss = np.linspace(0, L0, 401)
        rec["inextensible_gap_m"] = float(np.linalg.norm(ref(ss) - ref_inext(ss), axis=1).max())
    return rec, r_all, ref(np.linspace(0, L0, 401))


def main(argv=None):
    a = C.parser("catenary", __doc__).parse_args(argv)
    ns = (2, 8, 32) if a.quick else (2, 4, 8, 16, 32, 64)
    records, curves = [], {}
    for case in CASES:
        for n in ns:
            rec, rh, rref = solve_case(case, n)
            records.append(rec)
            curves[(case, n)] = (rh, rref)
    C.table(records, ["case", "n", "max_error_m", "sag_m", "H_N", "H_ref_N", "iterations", "wall_s", "status", "start"],
            "Cable (no bending) between two pins vs the elastic catenary (error at equal material points)",
            {"max_error_m": "{:.3e}", "sag_m": "{:.5f}", "H_N": "{:.5f}", "H_ref_N": "{:.5f}", "wall_s": "{:.3f}"})
    for case in CASES:
        gap = [r.get("inextensible_gap_m") for r in records if r["case"] == case][0]
        if gap is not None:
            print(f"{case}: elastic vs inextensible catenary, max distance {gap * 1e3:.3f} mm")
    C.write_json(records, a.json)
    if not a.no_plots:
        plt = C.pyplot()
        fig, axes = plt.subplots(1, 2, figsize=(11, 4))
        for case in CASES:
            rh, rref = curves[(case, ns[-1])]
            l, = axes[0].plot(rref[:, 0], rref[:, 1], "-", lw=3, alpha=0.35)
            axes[0].plot(rh[:, 0], rh[:, 1], "--", color=l.get_color(), lw=1, label=f"{case} (n={ns[-1]})")
            rs = [r for r in records if r["case"] == case]
            axes[1].loglog([r["n"] for r in rs], [r["max_error_m"] for r in rs], "o-", label=case)
        axes[0].set_aspect("equal"), axes[0].set_xlabel("x [m]"), axes[0].set_ylabel("y [m]")
        axes[0].set_title("ANCF (dashed) on the elastic catenary (thick)"), axes[0].legend(fontsize=7)
        axes[1].xaxis.set_minor_locator(plt.NullLocator())
        axes[1].set_xticks(ns, [str(n) for n in ns])
        axes[1].set_xlabel("elements n"), axes[1].set_ylabel("max |r_h(s) - r(s)| [m]"), axes[1].grid(alpha=0.3, which="both")
        axes[1].set_title("error at equal material points"), axes[1].legend(fontsize=7)
        C.save(fig, a.out, "catenary.png")
    return records


if __name__ == "__main__":
    main()
