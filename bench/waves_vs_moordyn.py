"""The Lowe & Langley jumper in regular waves beside MoorDyn: both ends held at their static positions, Airy waves of
height H and period T travelling along x over 100 m of water, from the static state; the top tension histories
compared.

Both codes take the same wave kinematics: this package's (ancf_sym.model.waves, Wheeler stretching), evaluated in
its step graph at its quadrature points and, for MoorDyn (WaveKin = 1: kinematics set from outside), at MoorDyn's
nodes at the middle of each 5 ms coupling step (ExternalWaveKinSet; MoorDyn holds them over its 1 ms sub-steps).
MoorDyn's external kinematics carry no surface elevation: its buoyancy is the still water line's, as here. The same
line data as bench/mooring_vs_moordyn.py (MoorDyn's test input: D 0.396 m, 165 kg/m, EA 500e6 N, axial damping 0.5
of critical per segment, EI 120.8e3 N m^2, Cd = Ca = 1, CdAx = CaAx = 0, water 1000 kg/m^3, g 9.807, depth 100 m).
This package: generalized-alpha at --dt (default 0.1 s), --n elements (default 34); MoorDyn: 68 segments, dtM 1 ms.

Records: tension_rel_diff (largest difference of the top tension histories |F_top| over the largest MoorDyn tension,
once the start's transient has died out: after --settle wave periods, default 3; the waves start at once at t = 0
and ring the jumper's lightly damped transverse modes), tension_rel_diff_transient (the same after the first
period), tension_rel_diff_pointwise (the largest relative difference at a time),
tension_diff_over_wave_range (the largest difference over MoorDyn's peak-to-peak tension: the waves' part), the
tensions' ranges, the CPU times and their ratio.

Needs `pip install moordyn`. Run: python bench/waves_vs_moordyn.py [--json PATH] [--dt S] [--n N] [--height H]
[--period T] [--t-end S] [--settle PERIODS] [--plot PNG]
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples"))
sys.path.insert(0, str(ROOT / "bench"))

import numpy as np  # noqa: E402

import lowe_langley_jumper as J  # noqa: E402
from moordyn_jumper import top_tension  # noqa: E402

from ancf_sym import Scene, solve_static  # noqa: E402

DEPTH = 100.0


def scene(n: int, height: float, period: float) -> Scene:
    """The jumper (examples/lowe_langley_jumper.py) in water of DEPTH with waves along x."""
    s = Scene(dim=2, gravity=[0.0, -J.G], name="jumper_waves")
    s.member("jumper", [J.BOTTOM, J.BOTTOM + [J.LENGTH, 0.0]], n, **J._kw())
    s.pin("jumper", "start")
    s.drive_position([float(J.TOP[0]), float(J.TOP[1])], member="jumper", at="end", name="top")
    s.set_water(density=J.RHO_W, depth=DEPTH, waves={"height": height, "period": period},
                lines={"jumper": {"cd": 1.0, "ca": 1.0}})
    return s


def ours(n: int, dt: float, height: float, period: float, t_end: float) -> dict:
    from ancf_sym.dynamics import DynamicOptions, simulate

    x0, _ = J.warm_start(n)
    st = solve_static(scene(n, height, period), warm_start=x0)  # (the statics take no waves)
    if not st.success:
        raise RuntimeError(f"the static start failed: {st.summary()}")
    s = scene(n, height, period)
    s.strain_rate_damping(axial=J.ZETA * J.SEGMENT * math.sqrt(J.EA * J.MASS), members=["jumper"])
    c0 = time.process_time()
    r = simulate(s, DynamicOptions(dt=dt, t_end=t_end, q0=st.x, output_dt=0.5, energies=False))
    cpu = time.process_time() - c0
    return dict(t=np.asarray(r.t), tension=np.linalg.norm(np.asarray(r.drive_reactions["top"]), axis=1), cpu_s=cpu,
                steps=r.steps, status=r.status, water=s.water)


def moordyn(times: np.ndarray, water) -> dict:
    from ancf_sym.model.waves import kinematics

    def waves(p: np.ndarray, t: float):
        _, u, a = kinematics(water, J.G, p[:, [0, 2]], t)  # (the planar waves along x: x-z)
        U, A = np.zeros_like(p), np.zeros_like(p)
        U[:, [0, 2]], A[:, [0, 2]] = u, a
        return U, A

    return top_tension(times, waves=waves)


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--json", metavar="PATH")
    p.add_argument("--dt", type=float, default=0.1)
    p.add_argument("--n", type=int, default=34)
    p.add_argument("--height", type=float, default=6.0)
    p.add_argument("--period", type=float, default=10.0)
    p.add_argument("--t-end", type=float, default=60.0)
    p.add_argument("--settle", type=float, default=3.0, help="wave periods before the comparison")
    p.add_argument("--plot", metavar="PNG")
    a = p.parse_args(argv)
    mine = ours(a.n, a.dt, a.height, a.period, a.t_end)
    theirs = moordyn(mine["t"], mine["water"])
    # the waves start at once at t = 0: the jolt rings the jumper's lightly damped transverse modes (period ~2 s),
    # whose phase the start's discretisation sets; compared once they have died out (after `settle` wave periods),
    # and (tension_rel_diff_transient) after the first period
    after = mine["t"] >= a.settle * a.period
    first = mine["t"] >= a.period
    diff = np.abs(mine["tension"] - theirs["tension"])
    rec = dict(case="lowe_langley_regular_waves", n=a.n, dt=a.dt, height=a.height, period=a.period, t_end=a.t_end,
               steps=mine["steps"], status=mine["status"], cpu_s=mine["cpu_s"], moordyn_cpu_s=theirs["cpu_s"],
               ratio=mine["cpu_s"] / theirs["cpu_s"],
               tension_rel_diff=float(np.max(diff[after]) / np.max(theirs["tension"][after])),
               tension_rel_diff_pointwise=float(np.max(diff[after] / theirs["tension"][after])),
               tension_diff_over_wave_range=float(np.max(diff[after]) / np.ptp(theirs["tension"][after])),
               tension_rel_diff_transient=float(np.max(diff[first]) / np.max(theirs["tension"][first])),
               settle_periods=a.settle,
               top_tension_kN=[float(mine["tension"][after].min() / 1e3), float(mine["tension"][after].max() / 1e3)],
               top_tension_moordyn_kN=[float(theirs["tension"][after].min() / 1e3),
                                       float(theirs["tension"][after].max() / 1e3)])
    print(json.dumps(rec, indent=1))
    if a.json:
        Path(a.json).write_text(json.dumps(rec, indent=1))
    if a.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 3.5))
        ax.plot(mine["t"], mine["tension"] / 1e3, label=f"ancf_sym (n {a.n}, dt {a.dt} s)")
        ax.plot(mine["t"], theirs["tension"] / 1e3, "--", label="MoorDyn 2 (68 segments, 1 ms)")
        ax.set_xlabel("t [s]"), ax.set_ylabel("top tension [kN]"), ax.legend(fontsize=8)
        ax.set_title(f"Jumper in regular waves, H {a.height} m, T {a.period} s")
        fig.tight_layout()
        fig.savefig(a.plot, dpi=120)
    return rec


if __name__ == "__main__":
    main()
