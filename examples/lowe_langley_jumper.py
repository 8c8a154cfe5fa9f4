"""The Lowe & Langley (2006) flexible jumper as in MoorDyn's test suite: statics beside MoorDyn's reference.

Jumper: D 0.396 m, 165 kg/m, EA 500e6 N, EI 120.8e3 N m^2, Cd = Ca = 1, unstretched length 170 m, ends at
(-100, -55) and (0, -5) m (planar x-z; water 1000 kg/m^3, g 9.807, no seabed within reach). MoorDyn's static forces
of the supports on the line: top (11.40, 45.71) kN, bottom (-11.40, 24.04) kN. The top end is a fairlead held by a
position drive (Scene.drive_position, its t = 0 value), the bottom end a pin. The jumper is one member with a straight,
stress-free reference; the statics start from the hinged V of the same length (two members joined by a hinge, solved
by the scene's own statics), whose coordinates are handed over as the warm start of the continuous jumper: the
Newton on the residual (ancf_sym.statics.water) then brings back the bending stiffness at the apex.
Records (statics): n, H_kN, V_top_kN, V_bottom_kN, their MoorDyn references and differences, lowest_z_m, iterations,
wall_s.

Dynamic case 1 (MoorDyn's test): the top moved in surge, x(t) = x0 + f(t) A sin(2 pi t / T), A = 10 m, T = 27 s,
f = s^3 (6 s^2 - 15 s + 10), s = t / T (a ramp over the first period), 27 + 80 s from the static state; axial damping
0.5 of critical per 2.5 m segment (MoorDyn's -0.5) as strain-rate damping; generalized-alpha at dt and dt / 2.
Records (kind "dynamic_case1"): n, dt, top tension max / min after the ramp [kN], the largest relative difference
of the top tension history to the run at half the step, cpu_s. MoorDyn itself runs beside it in
bench/mooring_vs_moordyn.py (measured: within 0.42 % at dt 0.25 s, 0.12 of its CPU time).

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
A_SURGE, PERIOD, T_AFTER, ZETA, SEGMENT = 10.0, 27.0, 80.0, 0.5, 2.5


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
    top = -np.array(r.constraint_forces["top"]) / 1e3  # (the supports' forces on the jumper: minus the reported
    bottom = -np.array(r.constraint_forces["pin jumper@start"]) / 1e3  # jumper's force on them)
    rec = dict(n=n, H_kN=top[0], V_top_kN=top[1], V_bottom_kN=bottom[1], H_bottom_kN=-bottom[0],
               lowest_z_m=float(r.nodes("jumper")[:, 1].min()), iterations=rv.iterations + r.iterations, wall_s=wall,
               status=r.status, success=r.success, stable=r.stable)
    for k, v in REF.items():
        rec[k.replace("_kN", "_ref_kN")] = v
        rec[k.replace("_kN", "_diff_kN")] = rec[k] - v
    return rec, r.nodes("jumper")


def ramp(t: float) -> tuple[float, float, float]:
    """MoorDyn's test ramp f = s^3 (6 s^2 - 15 s + 10), s = t / PERIOD (clipped), and its two derivatives."""
    if t >= PERIOD:
        return 1.0, 0.0, 0.0
    s = max(t, 0.0) / PERIOD
    return (s ** 3 * (6 * s * s - 15 * s + 10), 30 * s * s * (s - 1) ** 2 / PERIOD,
            60 * s * (2 * s * s - 3 * s + 1) / PERIOD ** 2)


def surge(t: float) -> tuple[float, float, float]:
    """x(t) - x0 = f(t) A sin(w t) and its first two derivatives."""
    w = 2 * math.pi / PERIOD
    f, df, ddf = ramp(t)
    s, c = math.sin(w * t), math.cos(w * t)
    return (f * A_SURGE * s, df * A_SURGE * s + f * A_SURGE * w * c,
            ddf * A_SURGE * s + 2 * df * A_SURGE * w * c - f * A_SURGE * w * w * s)


def dynamic_case1(n: int, dt: float, output_dt: float = 0.5) -> dict:
    """The top tension history |F_top(t)| [N] of case 1 from the static state (see the module docstring)."""
    from ancf_sym.dynamics import DynamicOptions, simulate

    x0, _ = warm_start(n)
    st = solve_static(jumper(n), warm_start=x0)
    if not st.success:
        raise RuntimeError(f"the static start failed: {st.summary()}")
    s = jumper(n)
    s.drives.clear()
    s.drive_position([(lambda t: TOP[0] + surge(t)[0], lambda t: surge(t)[1], lambda t: surge(t)[2]), float(TOP[1])],
                     member="jumper", at="end", name="top")
    s.strain_rate_damping(axial=ZETA * SEGMENT * math.sqrt(EA * MASS), members=["jumper"])
    c0 = time.process_time()
    r = simulate(s, DynamicOptions(dt=dt, t_end=PERIOD + T_AFTER, q0=st.x, output_dt=output_dt, energies=False))
    cpu = time.process_time() - c0
    return dict(t=np.asarray(r.t), tension=np.linalg.norm(np.asarray(r.drive_reactions["top"]), axis=1), cpu_s=cpu,
                steps=r.steps, status=r.status, success=r.success)


def dynamic_record(n: int, dt: float) -> tuple[dict, dict]:
    run, half = dynamic_case1(n, dt), dynamic_case1(n, dt / 2)
    after = run["t"] >= PERIOD
    T = run["tension"][after]
    diff = np.max(np.abs(T - half["tension"][after]) / half["tension"][after])
    return dict(kind="dynamic_case1", n=n, dt=dt, T_top_max_kN=float(T.max() / 1e3), T_top_min_kN=float(T.min() / 1e3),
                half_step_rel_diff=float(diff), cpu_s=run["cpu_s"], steps=run["steps"], status=run["status"],
                success=bool(run["success"] and half["success"])), run


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
        records.append(dict(rec, kind="statics"))
    C.table(records, ["n", "H_kN", "V_top_kN", "V_bottom_kN", "H_diff_kN", "V_top_diff_kN", "V_bottom_diff_kN",
                      "lowest_z_m", "iterations", "wall_s", "status"],
            "Lowe & Langley jumper statics vs MoorDyn: top (11.40, 45.71) kN, bottom (-11.40, 24.04) kN",
            {k: "{:.4f}" for k in ("H_kN", "V_top_kN", "V_bottom_kN", "H_diff_kN", "V_top_diff_kN",
                                   "V_bottom_diff_kN")} | {"wall_s": "{:.3f}", "lowest_z_m": "{:.3f}"})
    dyn, _ = dynamic_record(20 if a.quick else 34, 0.25)
    records.append(dyn)
    C.table([dyn], ["n", "dt", "T_top_max_kN", "T_top_min_kN", "half_step_rel_diff", "cpu_s", "steps", "status"],
            "Dynamic case 1 (top surge 10 m, 27 s): top tension after the ramp",
            {"T_top_max_kN": "{:.3f}", "T_top_min_kN": "{:.3f}", "half_step_rel_diff": "{:.2e}", "cpu_s": "{:.2f}"})
    return C.finish(records, a, plots, shapes)


if __name__ == "__main__":
    main()
