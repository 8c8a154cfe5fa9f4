"""The Lowe & Langley (2006) flexible jumper as in MoorDyn's test suite: statics beside MoorDyn's reference.

Jumper: D 0.396 m, 165 kg/m, EA 500e6 N, EI 120.8e3 N m^2, Cd = Ca = 1, unstretched length 170 m, ends at
(-100, -55) and (0, -5) m (planar x-z; water 1000 kg/m^3, g 9.807, no seabed within reach). MoorDyn's static forces
of the supports on the line: top (11.40, 45.71) kN, bottom (-11.40, 24.04) kN. The top end is a fairlead held by a
position drive (Scene.drive_position, its t = 0 value), the bottom end a pin. The jumper is one member with a straight,
stress-free reference; the statics start from the hinged V of the same length (two members joined by a hinge, solved
by the scene's own statics), whose coordinates are handed over as the warm start of the continuous jumper: the
Newton on the residual (ancf_sym.water.statics) then brings back the bending stiffness at the apex.
Records: n, H_kN, V_top_kN, V_bottom_kN, their MoorDyn references and differences, lowest_z_m, iterations, wall_s.

Run: python examples/lowe_langley_jumper.py [--quick] [--json out.json] [--out DIR]
"""
from __future__ import annotations

import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common as C  # noqa: E402  (first: it limits BLAS threads before numpy loads)

import numpy as np  # noqa: E402

from ancf_sym import Material, Scene, Section, solve_static  # noqa: E402

D, MASS, EA, EI, LENGTH, RHO_W, G = 0.396, 165.0, 500e6, 120.8e3, 170.0, 1000.0, 9.807
BOTTOM, TOP = np.array([-100.0, -55.0]), np.array([0.0, -5.0])
REF = {"H_kN": 11.40, "V_top_kN": 45.71, "V_bottom_kN": 24.04}


def _kw(bending: bool = True) -> dict:
    area = math.pi * D * D / 4
    E = EA / area
    return dict(material=Material(E=E, density=MASS / area), section=Section(area=area, I=EI / E), axial="biot",
                bending=bending)


def _water(s: Scene, members) -> None:
    s.set_water(density=RHO_W, lines={m: {"cd": 1.0, "ca": 1.0} for m in members})


def jumper(n: int) -> Scene:
    s = Scene(dim=2, gravity=[0.0, -G], name="jumper")
    s.member("jumper", [BOTTOM, BOTTOM + [LENGTH, 0.0]], n, **_kw())
    s.pin("jumper", "start")
    s.drive_position([float(TOP[0]), float(TOP[1])], member="jumper", at="end", name="top")
    _water(s, ["jumper"])
    return s


def hinged_v(n: int) -> Scene:
    """Two legs of LENGTH/2 from the bottom and the top to an apex below the chord's middle, joined by a hinge."""
    mid, chord = (BOTTOM + TOP) / 2, TOP - BOTTOM
    c = np.linalg.norm(chord)
    down = np.array([chord[1], -chord[0]]) / c
    down = down if down[1] < 0 else -down
    apex = mid + down * math.sqrt((LENGTH / 2) ** 2 - (c / 2) ** 2)
    s = Scene(dim=2, gravity=[0.0, -G], name="jumper_v")
    s.member("a", [BOTTOM, apex], n // 2, **_kw())
    s.member("b", [apex, TOP], n - n // 2, **_kw())
    s.hinge(("a", "end"), ("b", "start"))
    s.pin("a", "start")
    s.pin("b", "end")
    _water(s, ["a", "b"])
    return s


def warm_start(n: int) -> tuple[np.ndarray, object]:
    """The jumper's coordinates from the hinged V's equilibrium (the apex node's slope: the legs' mean)."""
    r = solve_static(hinged_v(n))
    if not r.success:
        raise RuntimeError(f"the hinged V start failed: {r.summary()}")
    a = r.assembly.member_coordinates(r.x, "a")
    b = r.assembly.member_coordinates(r.x, "b")
    apex = a[-1].copy()
    apex[2:] = 0.5 * (a[-1, 2:] + b[0, 2:])
    return np.vstack([a[:-1], apex, b[1:]]).ravel(), r


def solve(n: int) -> tuple[dict, np.ndarray]:
    t = time.perf_counter()
    x0, rv = warm_start(n)
    r = solve_static(jumper(n), warm_start=x0)
    wall = time.perf_counter() - t
    top = np.array(r.constraint_forces["top"]) / 1e3
    bottom = np.array(r.constraint_forces["pin jumper@start"]) / 1e3
    rec = dict(n=n, H_kN=top[0], V_top_kN=top[1], V_bottom_kN=bottom[1], H_bottom_kN=-bottom[0],
               lowest_z_m=float(r.nodes("jumper")[:, 1].min()), iterations=rv.iterations + r.iterations, wall_s=wall,
               status=r.status, success=r.success, stable=r.stable)
    for k, v in REF.items():
        rec[k.replace("_kN", "_ref_kN")] = v
        rec[k.replace("_kN", "_diff_kN")] = rec[k] - v
    return rec, r.nodes("jumper")


def plots(shapes, out):
    plt = C.pyplot()
    fig, ax = plt.subplots(figsize=(6, 4))
    for n, xy in shapes.items():
        ax.plot(xy[:, 0], xy[:, 1], ".-", ms=3, label=f"n = {n}")
    ax.set_aspect("equal"), ax.set_xlabel("x [m]"), ax.set_ylabel("z [m]"), ax.legend(fontsize=7)
    ax.set_title("Lowe & Langley jumper, static shape")
    C.save(fig, out, "lowe_langley_jumper.png")


def main(argv=None):
    a = C.parser("lowe_langley_jumper", __doc__).parse_args(argv)
    ns = (10, 40) if a.quick else (10, 20, 40, 80, 160)
    records, shapes = [], {}
    for n in ns:
        rec, shapes[n] = solve(n)
        records.append(rec)
    C.table(records, ["n", "H_kN", "V_top_kN", "V_bottom_kN", "H_diff_kN", "V_top_diff_kN", "V_bottom_diff_kN",
                      "lowest_z_m", "iterations", "wall_s", "status"],
            "Lowe & Langley jumper statics vs MoorDyn: top (11.40, 45.71) kN, bottom (-11.40, 24.04) kN",
            {k: "{:.4f}" for k in ("H_kN", "V_top_kN", "V_bottom_kN", "H_diff_kN", "V_top_diff_kN",
                                   "V_bottom_diff_kN")} | {"wall_s": "{:.3f}", "lowest_z_m": "{:.3f}"})
    return C.finish(records, a, plots, shapes)


if __name__ == "__main__":
    main()
