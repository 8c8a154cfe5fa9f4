"""Shortest crane move under trolley bounds and a swing limit: the same rope and payload as crane_ocp.py, moved
2 m from rest to rest (no residual swing), minimising the time T (plus 1e-3 x the control effort, which makes the
bang-bang-like optimum unique) with |x_T''| <= 1 m/s^2, |x_T'| <= 1 m/s and, at every collocation point, the payload
no further than a limit from below the trolley: |x_payload - x_T| <= limit. The acceleration is constant in each
collocation interval (control_form="constant"), so its bound holds at every instant, not only at the points.

A rigid load needs T = d/v + v/a = 3 s under these bounds; arriving without swing costs more, and a tighter swing
limit costs more still. The horizon is a decision variable (ControlProblem with MinimumTime, horizon = (lower,
guess, upper)); each optimum is re-simulated by the dynamics integrator, which also shows how far the payload
exceeds the limit between collocation points.

Run: python examples/minimum_time_swing.py [--quick] [--json PATH] [--out DIR] [--no-plots]
Records (flat): n, intervals, swing_limit_m (None: no limit), T_s, cost, max_offset_m (re-simulated, during the move),
residual_swing_m (re-simulated, after T), mismatch_m, ipopt_status, iterations, wall_s, build_s.
"""
from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common as C  # noqa: E402  (first: it limits BLAS threads before numpy loads)

import numpy as np  # noqa: E402

from crane_ocp import DISTANCE, PAYLOAD, crane_scene  # noqa: E402
from ancf_sym.control import ControlProblem, Effort, MinimumTime, PathConstraint, PointMass, SupportMotion

A_MAX, V_MAX = 1.0, 1.0


def offset(view):
    """Payload x minus trolley x: the swing the path constraint limits."""
    return view.point("rope", "end")[0] - view["trolley.position"]


def problem(n: int, K: int, limit: float | None) -> ControlProblem:
    path = [] if limit is None else [PathConstraint(offset, -limit, limit, "swing")]
    return ControlProblem(crane_scene(n), controls=[SupportMotion("rope", "start", axes=(0,), name="trolley")],
                          horizon=(1.0, 5.0, 12.0), point_masses=[PointMass("rope", "end", PAYLOAD)],
                          cost=[MinimumTime(), Effort(1e-3)], end={"trolley.position": DISTANCE},
                          bounds={"trolley.acceleration": (-A_MAX, A_MAX), "trolley.velocity": (-V_MAX, V_MAX)},
                          path=path, intervals=K, stages=3, control_form="constant")


def run(quick: bool):
    n, K = (2, 12) if quick else (4, 24)
    limits = (None, 0.1) if quick else (None, 0.3, 0.2, 0.1, 0.05)
    records, curves = [], {}
    for lim in limits:
        prob = problem(n, K, lim)
        res = prob.solve()
        rep = res.resimulate() if res.success else None
        during = rep.t <= res.T if rep else None
        off = (rep.payload[:, 0] - rep.support[:, 0]) if rep else None
        rec = {"n": n, "intervals": K, "swing_limit_m": lim, "T_s": res.T, "cost": res.cost,
               "max_offset_m": float(np.max(np.abs(off[during]))) if rep else None,
               "residual_swing_m": rep.residual_swing_m if rep else None,
               "mismatch_m": rep.mismatch_m if rep else None, "ipopt_status": res.status,
               "iterations": res.iterations, "wall_s": res.wall_s, "build_s": res.build_s}
        records.append(rec)
        curves[lim] = (prob, res, rep)
        print(f"limit {lim}: {res.status} in {res.iterations} iterations ({res.wall_s:.2f} s): T = {res.T:.4f} s",
              flush=True)
    return records, curves


def plots(curves, out):
    plt = C.pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    for lim, (prob, res, rep) in curves.items():
        lab = "no swing limit" if lim is None else f"|swing| <= {lim} m"
        t = np.linspace(0, res.T, 400)
        x, v, a = (np.asarray(z)[:, 0] for z in res.support_motion()(t))
        axes[0].plot(t, v, label=f"{lab}: T = {res.T:.3f} s")
        axes[1].plot(t, a)
        if rep is not None:
            axes[2].plot(rep.t, rep.payload[:, 0] - rep.support[:, 0], label=lab)
        if lim is not None:
            axes[2].axhline(lim, color="k", lw=0.5, ls=":")
            axes[2].axhline(-lim, color="k", lw=0.5, ls=":")
    axes[0].set_ylabel("x_T' [m/s]"), axes[1].set_ylabel("x_T'' [m/s^2]")
    axes[2].set_ylabel("payload x - trolley x [m]"), axes[2].set_xlabel("t [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[2].set_xlim(0, max(res.T for _, res, _ in curves.values()) + 3.0)
    fig.suptitle(f"Minimum-time move of {DISTANCE} m, |a| <= {A_MAX} m/s^2, |v| <= {V_MAX} m/s (re-simulated swing)")
    C.save(fig, out, "minimum_time.png")


def main(argv=None):
    p = C.parser("minimum_time_swing", __doc__)
    a = p.parse_args(argv)
    records, curves = run(a.quick)
    C.table(records, ["n", "intervals", "swing_limit_m", "T_s", "max_offset_m", "residual_swing_m", "mismatch_m",
                      "ipopt_status", "iterations", "wall_s"],
            f"Minimum-time crane move (rigid load under the same bounds: {DISTANCE / V_MAX + V_MAX / A_MAX:.1f} s)",
            {"T_s": "{:.4f}", "max_offset_m": "{:.4f}", "residual_swing_m": "{:.2e}", "mismatch_m": "{:.2e}",
             "wall_s": "{:.2f}"})
    return C.finish(records, a, plots, curves)


if __name__ == "__main__":
    main()
