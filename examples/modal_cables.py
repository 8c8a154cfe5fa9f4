"""Natural frequencies of cables about their equilibrium (prestress from gravity and tension) against theory.

- hanging_chain: a 1 m chain (cable without bending, EA large: gravity strain 1e-6) pinned at the top, hanging under
  gravity: omega_n = (j0_n / 2) sqrt(g / L), j0_n = 2.404826, 5.520078, 8.653728 (the zeros of J0). The prestress is
  gravity's alone: without it the chain has no stiffness.
- taut_string: 1 m between two pins at T = 5 N (a prestrain, no gravity): f_n = n/(2L) sqrt(T/mu), with T the
  element's axial force at the prestrain (Green strain: EA(eps + eps^2/2)(1 + eps)) and mu = rho A / (1 + eps).
- irvine: a sagging cable between two pins 100 m apart, for Irvine's lambda^2 = 1, 10, 4 pi^2, 100, 1000 (sag/span
  1/200, 1/100 for the first two, 1/50 for the others; EA from lambda^2), in 3D: the first symmetric in-plane mode
  x/L sqrt(H/m) with tan(x/2) = x/2 - (4/lambda^2)(x/2)^3, the first antisymmetric in-plane 2 pi/L sqrt(H/m), the
  first out-of-plane pi/L sqrt(H/m); H and lambda^2 from the computed equilibrium. Shallow-cable theory neglects
  O((sag/span)^2) ~ 1e-3: the agreement is within 5e-3 (measured at 40 elements: 8e-5 .. 9e-4 for the symmetric and
  out-of-plane modes, 2e-3 for the antisymmetric one at sag/span 1/50, whose frequency the sag lowers at that order).
  Hanging chain: 5e-7 at 16 elements (the 6 digits of j0 and the 1e-6 stretch); taut string: 6e-7 on mode 3 at 16.

Records: case, n, mode, f_hz, reference_hz, rel_error, lambda2 (irvine), wall_s.
Run: python examples/modal_cables.py [--quick] [--json out.json] [--out DIR]
"""
from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common as C  # noqa: E402  (first: it limits BLAS threads before numpy loads)

import numpy as np  # noqa: E402
from scipy.optimize import brentq  # noqa: E402

from ancf_sym import Material, Scene, Section, modal_analysis  # noqa: E402
from ancf_sym.modal.output import plot_modes  # noqa: E402

G = 9.81
J0 = np.array([2.404826, 5.520078, 8.653728])


def record(case: str, n: int, mode, f: float, ref: float, r, **extra) -> dict:
    return {"case": case, "n": n, "mode": mode, "f_hz": float(f), "reference_hz": float(ref),
            "rel_error": abs(f / ref - 1), "wall_s": r.wall_s, **extra}


def hanging_chain(n: int):
    s = Scene(dim=2, gravity=(0.0, -G), name=f"hanging_chain_{n}")
    s.member("chain", [(0, 0), (0, -1.0)], n, Material(E=1e10, density=1000.0), Section(area=1e-4), bending=False)
    s.pin("chain", "start")
    r = modal_analysis(s, modes=3)
    ref = J0 / 2 * np.sqrt(G / 1.0) / (2 * np.pi)
    return r, [record("hanging_chain", n, k + 1, r.frequencies[k], ref[k], r) for k in range(3)]


def taut_string(n: int):
    L, A, E, rho, T = 1.0, np.pi * 0.2e-3 ** 2 / 4, 2e11, 7800.0, 5.0
    eps = T / (E * A)
    s = Scene(dim=2, gravity=(0.0, 0.0), name=f"taut_string_{n}")
    s.member("string", [(0, 0), (L, 0)], n, Material(E=E, density=rho), Section(area=A), bending=False,
             prestrain=eps)
    s.pin("string", "start")
    s.pin("string", "end")
    r = modal_analysis(s, modes=3)
    Tg, mu = E * A * (eps + eps ** 2 / 2) * (1 + eps), rho * A / (1 + eps)
    return r, [record("taut_string", n, k + 1, r.frequencies[k], (k + 1) / (2 * L) * np.sqrt(Tg / mu), r)
               for k in range(3)]


def irvine(lam2: float, sag: float, n: int):
    span, A, rho = 100.0, 1e-3, 1000.0
    m = rho * A
    H = m * G * span / (8 * sag)
    EA = lam2 * H ** 3 / (m * G * span) ** 2 * (1 + 8 * sag ** 2)
    arc = span * (1 + 8 / 3 * sag ** 2)
    s = Scene(dim=3, gravity=(0.0, 0.0, -G), name=f"irvine_{lam2:.4g}")
    s.member("cable", [(0, 0, 0), (span, 0, 0)], n, Material(E=EA / A, density=rho), Section(area=A), bending=False,
             prestrain=span / (arc / (1 + H / EA)) - 1)
    s.pin("cable", "start")
    s.pin("cable", "end")
    r = modal_analysis(s, modes=4)
    st = r.static
    Hm = abs(st.constraint_forces["pin cable@start"][0])
    d = -st.nodes("cable")[:, 2].min()
    lam2_m = (m * G * span / Hm) ** 2 * span / (Hm * span * (1 + 8 * (d / span) ** 2) / EA)
    x = brentq(lambda x: np.tan(x / 2) - x / 2 + 4 / lam2_m * (x / 2) ** 3, np.pi * (1 + 1e-9), 3 * np.pi * (1 - 1e-9))
    base = np.sqrt(Hm / m) / span / (2 * np.pi)  # [Hz per unit x]
    ref = {"out_of_plane": np.pi * base, "antisymmetric": 2 * np.pi * base, "symmetric": x * base}
    found = {}
    for k in range(r.modes):
        u = r.displacements(k, "cable")
        kind = "out_of_plane" if np.abs(u[:, 1]).max() > np.abs(u[:, 2]).max() else \
            ("symmetric" if abs(u[len(u) // 2, 2]) > 0.1 * np.abs(u[:, 2]).max() else "antisymmetric")
        found.setdefault(kind, k)
    return r, [record("irvine", n, kind, r.frequencies[found[kind]], ref[kind], r, lambda2=lam2_m, x_over_pi=x / np.pi,
                      sag_over_span=d / span) for kind in ref]


def main(argv=None):
    a = C.parser("modal_cables", __doc__).parse_args(argv)
    ns = (4, 16) if a.quick else (4, 8, 16, 32)
    records, shown = [], {}
    for n in ns:
        shown["hanging_chain"], recs = hanging_chain(n)
        records += recs
    for n in (8, 16) if a.quick else (8, 16, 32):
        shown["taut_string"], recs = taut_string(n)
        records += recs
    cases = ((100.0, 1 / 50),) if a.quick else \
        ((1.0, 1 / 200), (10.0, 1 / 100), (4 * np.pi ** 2, 1 / 50), (100.0, 1 / 50), (1000.0, 1 / 50))
    for lam2, sag in cases:
        shown[f"irvine_{lam2:.4g}"], recs = irvine(lam2, sag, 40)
        records += recs
    C.table(records, ["case", "n", "mode", "f_hz", "reference_hz", "rel_error", "lambda2", "x_over_pi", "wall_s"],
            "Cable frequencies about the equilibrium against theory",
            {"rel_error": "{:.2e}", "wall_s": "{:.3f}", "lambda2": "{:.4g}", "x_over_pi": "{:.6f}"})
    C.write_json(records, a.json)
    if not a.no_plots:
        os.makedirs(a.out, exist_ok=True)
        for name, r in shown.items():
            print("figure:", plot_modes(r, os.path.join(a.out, f"modes_{name}.png"), count=min(r.modes, 4)))
    return records


if __name__ == "__main__":
    main()
