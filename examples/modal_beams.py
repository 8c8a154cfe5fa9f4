"""Natural frequencies of beams against Euler-Bernoulli and torsion theory (ancf_sym.modal_analysis).

- cantilever: a steel bar 1 m x 10 mm x 10 mm clamped at x = 0 (cable2d element with bending: Euler-Bernoulli),
  beta L = (w^2 rho A / EI)^(1/4) L against 1.875104, 4.694091, 7.854757; the error falls ~h^4 with the elements
  (16 elements: 2e-5 on the third mode).
- free_free: the same bar without support (no load: its modes about the reference): three rigid motions reported at
  zero frequency, then beta L = 4.730041, 7.853205.
- foundation: the bar pinned at x = 0 and pressed into the ground by gravity (linear penalty contact k = 5 kN/m^2,
  penetrated everywhere): a beam on a Winkler foundation, w^2 = (EI beta^4 + k)/(rho A) with beta L = 0 (the rigid
  rotation on the foundation), 3.926602, 7.068583.
- beam3d: a 20 mm x 10 mm steel bar (beam3d, continuum), bending about both axes (beta L = 1.875104 with Iy and Iz)
  and torsion w = pi/(2L) sqrt(G J / (rho Ip)); the continuum element converges ~h^2 (16 elements: 4e-4 .. 7e-4)
  toward a shear-deformable bar: bending in the 20 mm direction settles ~2.4e-4 below Euler-Bernoulli (Timoshenko's
  shear and rotary-inertia correction for depth/L = 1/50), so its error stops falling below ~1e-4 at 32 elements.

Records: case, n (elements), mode, f_hz, reference_hz, rel_error, zero (rigid), wall_s.
Run: python examples/modal_beams.py [--quick] [--json out.json] [--out DIR]
"""
from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common as C  # noqa: E402  (first: it limits BLAS threads before numpy loads)

import numpy as np  # noqa: E402

from ancf_sym import Material, Scene, Section, modal_analysis  # noqa: E402
from ancf_sym.modal.output import plot_modes  # noqa: E402

STEEL = Material(E=2e11, density=7800.0, poisson=0.3)
BAR = Section.rectangle(0.01, 0.01)
EI, RA = STEEL.E * BAR.bending_inertia, STEEL.density * BAR.area


def eb_hz(beta_l) -> np.ndarray:
    """Euler-Bernoulli frequencies [Hz] of the 1 m bar for beta L values."""
    return np.asarray(beta_l) ** 2 * np.sqrt(EI / RA) / (2 * np.pi)


def bar2d(n: int, support: str | None, gravity: float = 0.0) -> Scene:
    s = Scene(dim=2, gravity=(0.0, -gravity), name=f"bar_{support or 'free'}_{n}")
    y = 0.004 if gravity else 0.0
    s.member("beam", [(0, y), (1.0, y)], n, STEEL, BAR)
    if support == "clamp":
        s.clamp("beam", "start")
    elif support == "pin":
        s.pin("beam", "start")
    return s


def beam3d(n: int) -> tuple[Scene, dict]:
    sec = Section.rectangle(0.02, 0.01)
    s = Scene(dim=3, gravity=(0.0, 0.0, 0.0), name=f"beam3d_{n}")
    s.member("bar", [(0, 0, 0), (1.0, 0, 0)], n, STEEL, sec, element="beam3d")
    s.clamp("bar", "start")
    bend = {ax: 1.875104 ** 2 * np.sqrt(STEEL.E * I / (STEEL.density * sec.area)) / (2 * np.pi)
            for ax, I in (("z", sec.Iy), ("y", sec.Iz))}
    G = STEEL.E / (2 * (1 + STEEL.poisson))
    bend["torsion"] = np.pi / 2 * np.sqrt(G * sec.J / (STEEL.density * (sec.Iy + sec.Iz))) / (2 * np.pi)
    return s, bend


def records_of(case: str, n: int, r, ref: np.ndarray, modes: list[int]) -> list[dict]:
    out = []
    for k, fr in zip(modes, ref):
        f = float(r.frequencies[k])
        err = abs(f / fr - 1) if fr else abs(f)
        out.append({"case": case, "n": n, "mode": k + 1, "f_hz": f, "reference_hz": float(fr), "rel_error": err,
                    "zero": bool(r.zero[k]), "wall_s": r.wall_s})
    return out


def beam3d_kinds(r) -> dict:
    """The first bending mode about each axis and the first torsion mode, from the shapes."""
    kinds: dict = {}
    for k in range(r.modes):
        u = r.displacements(k, "bar")
        key = "torsion" if np.abs(u).max() < 1e-6 * np.abs(r.shapes[:, k]).max() else \
            ("z" if abs(u[-1, 2]) > abs(u[-1, 1]) else "y")
        kinds.setdefault(key, k)
    return kinds


def main(argv=None):
    a = C.parser("modal_beams", __doc__).parse_args(argv)
    ns = (4, 8, 16) if a.quick else (4, 8, 16, 32, 64)
    records, shown = [], {}
    for n in ns:
        r = modal_analysis(bar2d(n, "clamp"), modes=3)
        records += records_of("cantilever", n, r, eb_hz([1.875104, 4.694091, 7.854757]), [0, 1, 2])
        shown["cantilever"] = r
    r = modal_analysis(bar2d(60, None), modes=5)
    records += records_of("free_free", 60, r, np.r_[0.0, 0.0, 0.0, eb_hz([4.730041, 7.853205])], list(range(5)))
    shown["free_free"] = r
    k = 5e3
    for n in ns:
        s = bar2d(n, "pin", gravity=9.81)
        s.contact_ground("beam", stiffness=k, thickness=0.005, gauss=5)
        r = modal_analysis(s, modes=3)
        ref = np.sqrt((EI * np.array([0.0, 3.926602, 7.068583]) ** 4 + k) / RA) / (2 * np.pi)
        records += records_of("foundation", n, r, ref, [0, 1, 2])
        shown["foundation"] = r
    for n in ns[:-1] if a.quick else ns[1:]:
        s, ref = beam3d(n)
        r = modal_analysis(s, modes=12)
        kinds = beam3d_kinds(r)
        for kind in ("z", "y", "torsion"):
            rec = records_of("beam3d", n, r, [ref[kind]], [kinds[kind]])[0]
            records.append({**rec, "case": f"beam3d_{kind}"})
        shown["beam3d"] = r
    C.table(records, ["case", "n", "mode", "f_hz", "reference_hz", "rel_error", "zero", "wall_s"],
            "Beam frequencies against theory", {"rel_error": "{:.2e}", "wall_s": "{:.3f}"})
    C.write_json(records, a.json)
    if not a.no_plots:
        os.makedirs(a.out, exist_ok=True)
        for name, r in shown.items():
            print("figure:", plot_modes(r, os.path.join(a.out, f"modes_{name}.png"), count=6 if r.modes >= 6 else 3))
        plt = C.pyplot()
        fig, ax = plt.subplots(figsize=(6, 4))
        for case in ("cantilever", "foundation", "beam3d_z", "beam3d_torsion"):
            rs = [x for x in records if x["case"] == case and x["mode"] == max(y["mode"] for y in records
                                                                              if y["case"] == case)]
            ax.loglog([x["n"] for x in rs], [x["rel_error"] for x in rs], "o-", label=f"{case} (mode {rs[0]['mode']})")
        ax.set_xlabel("elements"), ax.set_ylabel("relative frequency error"), ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7), ax.set_title("refinement against theory")
        C.save(fig, a.out, "modal_beams_refinement.png")
    return records


if __name__ == "__main__":
    main()
