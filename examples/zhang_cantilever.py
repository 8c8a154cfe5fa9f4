"""Paper 000 (section 3.1): 3 m cantilever under gravity, coupled (Green) vs decoupled axial strain.

Beam: L = 3 m, A = 7.854e-5 m^2, I = 4.909e-10 m^4, rho = 7200 kg/m^3, E = 20, 4, 2, 1 GPa, clamped at x = 0,
gravity -y. Elements n = 3, 6, 9, 12, 15, 18 and n = 60 as the converged reference.
Potential = strain energy + gravity potential with the zero level at the clamp height (y = 0): this is
`StaticResult.potential` (the gravity term is -int rhoA g.r dx, r measured from the clamp at the origin).

Paper's statements checked here (E = 20 GPa): potential -11.41 J with 3 decoupled elements, -11.47 J with 18
coupled ones; decoupled 3 lies between coupled 6 and 9, decoupled 6 between coupled 15 and 18 (fig. 7).

Fig. 13 case: the same clamped beam (E = 20 GPa, gravity kept) with an end tension F = 300 N along the undeformed
axis (+x, `Scene.tension`), an end moment M = 30 N m (`Scene.moment`) and a distributed load P = 200 N/m downward
(`Scene.distributed`). The text of the paper gives no sign for M (the figure is not in the text we have): we take
M counter-clockwise (+z, right-hand rule), `--moment-sign -1` flips it.

Run: python examples/zhang_cantilever.py [--quick] [--json out.json] [--out DIR]
"""
from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common as C  # noqa: E402  (first: it limits BLAS threads before numpy loads)

import numpy as np  # noqa: E402

from ancf_sym import Material, Scene, Section, solve_static  # noqa: E402

L, AREA, INERTIA, RHO, G = 3.0, 7.854e-5, 4.909e-10, 7200.0, 9.81
PAPER = {"decoupled3": -11.41, "green18": -11.47}  # J, E = 20 GPa (paper 000, fig. 9 text)
STRAINS = ("green", "decoupled")  # green = the paper's coupled (original ANCF) element


def scene(strain: str, n: int, E: float, fig13: bool = False, moment_sign: float = 1.0) -> Scene:
    s = Scene(dim=2, gravity=(0.0, -G), name="zhang_cantilever")
    s.member("beam", points=[(0.0, 0.0), (L, 0.0)], elements=n, material=Material(E=E, density=RHO),
             section=Section(area=AREA, I=INERTIA), axial=strain, bending=True, gravity=True)
    s.clamp("beam", at="start")
    if fig13:
        s.tension("beam", at="end", tension=300.0)
        s.moment("beam", at="end", moment=moment_sign * 30.0)
        s.distributed("beam", force_per_length=(0.0, -200.0))
    return s


def solve(strain, n, E, case="gravity", moment_sign=1.0):
    r = solve_static(scene(strain, n, E, fig13=(case == "fig13"), moment_sign=moment_sign))
    tip = r.tip("beam")
    en = r.energies
    strain_energy = r.strain_energy
    rec = {"case": case, "strain": strain, "n": n, "E": E, "tip_x": tip[0], "tip_y": tip[1],
           "potential": r.potential, "axial_J": en.get("axial", 0.0), "bending_J": en.get("bending", 0.0),
           "gravity_J": en.get("gravity", 0.0), "loads_J": en.get("loads", 0.0),
           "axial_share": en.get("axial", 0.0) / strain_energy if strain_energy else float("nan"),
           "iterations": r.iterations, "wall_s": r.wall_s, "status": r.status, "success": r.success,
           "stable": r.stable}
    return rec, r.along("beam", per_element=max(4, 240 // n))["r"]


def run(quick: bool, moment_sign: float = 1.0):
    ns = (3, 6, 9, 15, 18) if quick else (3, 6, 9, 12, 15, 18)
    Es = (20e9,) if quick else (20e9, 4e9, 2e9, 1e9)
    records, shapes = [], {}
    for E in Es:
        for strain in STRAINS:
            for n in ns + (60,):
                rec, r = solve(strain, n, E)
                records.append(rec)
                shapes[("gravity", E, strain, n)] = r
    fig13_runs = [("decoupled", 6), ("green", 6), ("green", 12), ("decoupled", 60)] if quick else \
        [("decoupled", 3), ("decoupled", 6), ("green", 6), ("green", 12), ("green", 18), ("decoupled", 60),
         ("green", 60)]
    for strain, n in fig13_runs:
        rec, r = solve(strain, n, 20e9, "fig13", moment_sign)
        records.append(rec)
        shapes[("fig13", 20e9, strain, n)] = r
    return records, shapes


def summary(records) -> dict:
    """The key figures (E = 20 GPa) and the paper's statements, as numbers."""
    g = lambda s, n, E=20e9, case="gravity": C.find(records, case=case, strain=s, n=n, E=E)  # noqa: E731
    ref = g("decoupled", 60)["potential"]
    out = {"potential_decoupled3": g("decoupled", 3)["potential"], "potential_green18": g("green", 18)["potential"],
           "potential_ref60_decoupled": ref, "potential_ref60_green": g("green", 60)["potential"]}
    out["paper_rel_dev_decoupled3"] = out["potential_decoupled3"] / PAPER["decoupled3"] - 1
    out["paper_rel_dev_green18"] = out["potential_green18"] / PAPER["green18"] - 1
    out["ref60_rel_diff"] = abs(out["potential_ref60_green"] / ref - 1)
    for n in (3, 6):
        out[f"err_decoupled{n}"] = abs(g("decoupled", n)["potential"] - ref)
        out[f"err_green{n}"] = abs(g("green", n)["potential"] - ref)
    ty = lambda s, n: g(s, n)["tip_y"]  # noqa: E731
    out["decoupled3_between_green6_9"] = min(ty("green", 6), ty("green", 9)) <= ty("decoupled", 3) <= \
        max(ty("green", 6), ty("green", 9))
    out["decoupled6_between_green15_18"] = min(ty("green", 15), ty("green", 18)) <= ty("decoupled", 6) <= \
        max(ty("green", 15), ty("green", 18))
    f = lambda s, n: np.array([g(s, n, case="fig13")["tip_x"], g(s, n, case="fig13")["tip_y"]])  # noqa: E731
    out["fig13_tip_err_decoupled6"] = float(np.linalg.norm(f("decoupled", 6) - f("decoupled", 60)))
    out["fig13_tip_err_green6"] = float(np.linalg.norm(f("green", 6) - f("decoupled", 60)))
    out["fig13_tip_err_green12"] = float(np.linalg.norm(f("green", 12) - f("decoupled", 60)))
    return out


def plots(records, shapes, out):
    plt = C.pyplot()
    Es = sorted({r["E"] for r in records if r["case"] == "gravity"}, reverse=True)
    # figs 7-8: shapes
    fig, axes = plt.subplots(1, len(Es), figsize=(4.2 * len(Es), 4), squeeze=False)
    for ax, E in zip(axes[0], Es):
        for (case, e, strain, n), r in sorted(shapes.items(), key=lambda kv: (kv[0][2], kv[0][3])):
            if case != "gravity" or e != E or (strain == "decoupled" and n not in (3, 6, 60)) or \
                    (strain == "green" and n == 60):
                continue
            style = "-" if strain == "green" else "--"
            lw = 2.2 if n == 60 else 1.0
            ax.plot(r[:, 0], r[:, 1], style, lw=lw, color="k" if n == 60 else None,
                    label=f"{'coupled' if strain == 'green' else 'decoupled'} {n}")
        ax.set_title(f"E = {E / 1e9:g} GPa")
        ax.set_xlabel("x [m]"), ax.set_ylabel("y [m]"), ax.grid(alpha=0.3)  # unequal axes: differences visible
    axes[0][0].legend(fontsize=7)
    fig.suptitle("Cantilever under gravity: equilibrium shapes (paper 000 figs 7-8)")
    C.save(fig, out, "shapes.png")
    # figs 9-10: potential and axial share vs n
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for E in Es:
        for strain, mk in (("green", "o-"), ("decoupled", "s--")):
            rs = sorted((r for r in records if r["case"] == "gravity" and r["E"] == E and r["strain"] == strain
                         and r["n"] < 60), key=lambda r: r["n"])
            lab = f"{'coupled' if strain == 'green' else 'decoupled'}, E={E / 1e9:g} GPa"
            axes[0].plot([r["n"] for r in rs], [r["potential"] for r in rs], mk, label=lab)
            axes[1].plot([r["n"] for r in rs], [100 * r["axial_share"] for r in rs], mk, label=lab)
    axes[0].set_ylabel("equilibrium potential [J]"), axes[1].set_ylabel("axial / total strain energy [%]")
    for ax in axes:
        ax.set_xlabel("elements n"), ax.grid(alpha=0.3)
    axes[0].axhline(PAPER["decoupled3"], color="gray", lw=0.8, ls=":")
    axes[0].axhline(PAPER["green18"], color="gray", lw=0.8, ls=":")
    axes[0].legend(fontsize=7)
    fig.suptitle("Potential-energy convergence (paper 000 figs 9-10); dotted: paper's -11.41 / -11.47 J")
    C.save(fig, out, "potential_vs_n.png")
    # fig 13
    fig, ax = plt.subplots(figsize=(6, 4))
    for (case, e, strain, n), r in sorted(shapes.items(), key=lambda kv: (kv[0][2], kv[0][3])):
        if case == "fig13":
            ax.plot(r[:, 0], r[:, 1], "-" if strain == "green" else "--", lw=2.2 if n == 60 else 1.0,
                    label=f"{'coupled' if strain == 'green' else 'decoupled'} {n}")
    ax.set_xlabel("x [m]"), ax.set_ylabel("y [m]"), ax.set_aspect("equal"), ax.grid(alpha=0.3), ax.legend(fontsize=7)
    ax.set_title("End tension 300 N, end moment 30 N m, 200 N/m down (paper 000 fig 13)")
    C.save(fig, out, "fig13_tension_moment.png")


def main(argv=None):
    p = C.parser("zhang_cantilever", __doc__)
    p.add_argument("--moment-sign", type=float, default=1.0, choices=(1.0, -1.0),
                   help="+1: fig-13 end moment counter-clockwise (default), -1: clockwise")
    a = p.parse_args(argv)
    records, shapes = run(a.quick, a.moment_sign)
    cols = ["case", "strain", "E", "n", "tip_x", "tip_y", "potential", "axial_share", "iterations", "wall_s", "status"]
    fmt = {"E": "{:.0e}", "tip_x": "{:.5f}", "tip_y": "{:.5f}", "potential": "{:.4f}", "axial_share": "{:.2e}",
           "wall_s": "{:.3f}"}
    C.table(records, cols, "Paper 000 cantilever (potential: strain + gravity, zero at clamp height) [J]", fmt)
    s = summary(records)
    print(f"E=20 GPa: decoupled n=3 {s['potential_decoupled3']:.4f} J (paper -11.41, {100 * s['paper_rel_dev_decoupled3']:+.2f}%),"
          f" coupled n=18 {s['potential_green18']:.4f} J (paper -11.47, {100 * s['paper_rel_dev_green18']:+.2f}%),"
          f" n=60 decoupled {s['potential_ref60_decoupled']:.5f} / coupled {s['potential_ref60_green']:.5f} J")
    print(f"|potential(n) - potential(60)|: n=3 decoupled {s['err_decoupled3']:.2e} coupled {s['err_green3']:.2e};"
          f" n=6 decoupled {s['err_decoupled6']:.2e} coupled {s['err_green6']:.2e} J")
    print(f"fig 7: decoupled 3 between coupled 6 and 9: {s['decoupled3_between_green6_9']};"
          f" decoupled 6 between coupled 15 and 18: {s['decoupled6_between_green15_18']}")
    print(f"fig 13: tip distance to n=60: decoupled 6 {s['fig13_tip_err_decoupled6']:.4f} m, coupled 6"
          f" {s['fig13_tip_err_green6']:.4f} m, coupled 12 {s['fig13_tip_err_green12']:.4f} m")
    for E in sorted({r["E"] for r in records}):
        if E == 20e9:
            continue
        g6 = C.find(records, case="gravity", strain="green", n=6, E=E)
        d60 = C.find(records, case="gravity", strain="decoupled", n=60, E=E)
        d6 = C.find(records, case="gravity", strain="decoupled", n=6, E=E)
        print(f"E={E / 1e9:g} GPa: coupled-6 tip x vs decoupled-60 {100 * (g6['tip_x'] / d60['tip_x'] - 1):+.1f}%,"
              f" vs decoupled-6 {100 * (g6['tip_x'] / d6['tip_x'] - 1):+.1f}% (paper, 'same n': 10.2/22.4/38.5% for E=4/2/1)")
    return C.finish(records, a, plots, records, shapes)


if __name__ == "__main__":
    main()
