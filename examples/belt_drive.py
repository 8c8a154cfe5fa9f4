"""Belt drive: a closed belt over two pulleys of different radii, the driver at a prescribed angular velocity, the
driven pulley against a resisting torque; speed ratio (creep) and span tensions against the belt laws.

Two pulleys, rigid bodies on revolute joints (driver r_driver = 0.1 m at the origin, driven r_driven at D = 0.5 m to
the right), carry a closed belt (`Scene.loop` along `closed.belt_path`, prestrained by 0.5 %: EA = 1e5 N, so about
500 N in both spans at rest) through circle contacts carried by the bodies (linear penalty, regularised Coulomb
friction mu = 0.4, eps = 1 mm/s); the belt's path lies inside each pulley by the penetration that carries the
prestress round the arcs, so the run starts near equilibrium. The driver's angular velocity is prescribed
(`Scene.drive`): a smooth ramp from rest to omega_driver in 0.2 s, then constant; the driven pulley's resisting
torque M (`Scene.torque`) follows the same smooth ramp. No gravity.

Laws checked in the records:
- torque balance of the driven pulley at steady speed: (T_tight - T_slack) r_driven = M (exact for a massless span;
  the belt's own mass adds its centrifugal tension rho A v^2 to both spans, which cancels);
- the capstan (Euler-Eytelwein) limit of the belt on its smaller pulley: T_tight / T_slack <= e^(mu theta), theta
  the wrap angle of the belt path there; a drive below that limit sticks on most of the wrap (no gross slip);
- speed ratio omega_driven / omega_driver = (r_driver / r_driven) (1 - s): elastic creep s ~ (T_tight - T_slack) /
  (EA + T) (the belt leaves the driver shorter than it arrives: slip on the exit arcs), plus the regularised
  friction's own creep speed (a few eps).
Tensions are EA (|r_x| - 1) averaged over the nodes of the middle half of each straight span and over the last
third of the run. Records (one per case): case, r_driver, r_driven, omega_driver, omega_driven_steady, ratio_radii,
speed_ratio, creep, creep_elastic, T_tight, T_slack, tension_ratio, capstan_limit, torque, torque_from_tensions,
status.

Run: python examples/belt_drive.py [--quick] [--json out.json] [--out DIR]
"""
from __future__ import annotations

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common as C  # noqa: E402  (first: it limits BLAS threads before numpy loads)

import numpy as np  # noqa: E402

from ancf_sym import Material, Scene, Section  # noqa: E402
from ancf_sym.closed import belt_path  # noqa: E402
from ancf_sym.assembly import Assembly  # noqa: E402
from ancf_sym.dynamics import run_dynamics  # noqa: E402
from ancf_sym.statics import solve_static  # noqa: E402

D, R1 = 0.5, 0.1
EA, RHO_A, PRESTRAIN = 1e5, 0.1, 5e-3  # [N], [kg/m]
AREA = 1e-4
MU, EPS, K_H = 0.4, 5e-3, 1e9  # Hertz law k_h delta^1.5 [N/m^2.5]: C2 energy, no Hessian jump at touch-down
T_RAMP = 0.2


def wrap_angle(r_small: float, r_big: float) -> float:
    """Wrap of an open belt on its smaller pulley: pi - 2 asin((r_big - r_small) / D)."""
    return math.pi - 2 * math.asin((r_big - r_small) / D)


def _delta(r: float) -> float:
    """Penetration that carries the prestress round a pulley of radius r: k_h delta^1.5 = T0 / r."""
    return (EA * PRESTRAIN / (r * K_H)) ** (2 / 3)


def settled_belt(r_driven: float, elements: int) -> np.ndarray:
    """Belt coordinates in static equilibrium on the pulleys (frictionless fixed drums at their centres, one belt
    node pinned against sliding round the loop): the dynamic run starts from rest without the impact of a belt
    whose discretised arcs do not press evenly on the pulleys."""
    s = Scene(dim=2, gravity=(0.0, 0.0), name="belt_drive_statics")
    T0 = EA * PRESTRAIN
    path = belt_path([((0.0, 0.0), R1 - _delta(R1)), ((D, 0.0), r_driven - _delta(r_driven))])
    s.loop("belt", path, elements, *_belt_material(), axial="biot", prestrain=PRESTRAIN)
    for c, r in (((0.0, 0.0), R1), ((D, 0.0), r_driven)):
        s.contact_drum("belt", c, r, hertz=K_H, thickness=0.0)
    s.pin("belt", 0)
    res = solve_static(s)
    if not res.success:
        raise RuntimeError(f"belt statics failed: {res.status}")
    return np.asarray(res.x)


def _belt_material():
    return Material(E=EA / AREA, density=RHO_A / AREA), Section(area=AREA, I=AREA * 1e-6)


def scene(r_driven: float, omega: float, torque: float, elements: int) -> Scene:
    s = Scene(dim=2, gravity=(0.0, 0.0), name="belt_drive")
    s.body("driver", 1.0, 0.5 * 1.0 * R1**2, position=(0.0, 0.0))
    s.body("driven", 1.0, 0.5 * 1.0 * r_driven**2, position=(D, 0.0))
    s.revolute("driver")
    s.revolute("driven")
    # the belt turns counter-clockwise: along the bottom from the driver to the driven pulley, back along the top;
    # its path lies inside each pulley by the penetration delta = T0 / (k r) that carries the prestress T0 round
    # the arcs (k delta = T0 / r): the run starts near equilibrium instead of with the belt slamming onto them
    T0 = EA * PRESTRAIN
    path = belt_path([((0.0, 0.0), R1 - _delta(R1)), ((D, 0.0), r_driven - _delta(r_driven))])
    # a thin belt: bending stiffness EA 1e-6 m^2 = 0.1 N m^2 (regularises the mesh only)
    s.loop("belt", path, elements, *_belt_material(), axial="biot", prestrain=PRESTRAIN)
    for b, r in (("driver", R1), ("driven", r_driven)):
        s.contact_drum("belt", radius=r, body=b, hertz=K_H, mu=MU, eps=EPS, damping=1e2, thickness=0.0)
    # smooth ramp omega (3 tau^2 - 2 tau^3), tau = t / T_RAMP: starts from rest with zero angular acceleration
    s.drive("driver", omega=[[0.0, [0.0, 0.0, 3 * omega / T_RAMP**2, -2 * omega / T_RAMP**3]], [T_RAMP, [omega]]])
    s.torque("driven", [[0.0, [0.0, 0.0, -3 * torque / T_RAMP**2, 2 * torque / T_RAMP**3]], [T_RAMP, [-torque]]])
    s.strain_rate_damping(axial=EA * 2e-4, members=["belt"])
    return s


def span_tensions(res, elements: int) -> tuple[float, float, np.ndarray]:
    """(T_top, T_bottom) averaged over the last third of the outputs and the middle half of each span, and the
    time series of both."""
    X = np.stack([np.asarray(res.sensors[f"n{k}"]) for k in range(elements)], axis=1)  # (time, node, 4)
    T = EA * (np.linalg.norm(X[:, :, 2:4], axis=2) - 1.0)
    x, y = X[:, :, 0], X[:, :, 1]
    mid = (x > 0.25 * D) & (x < 0.75 * D)
    top = np.array([T[i][mid[i] & (y[i] > 0)].mean() for i in range(len(T))])
    bot = np.array([T[i][mid[i] & (y[i] < 0)].mean() for i in range(len(T))])
    late = res.t >= res.t[-1] * 2 / 3
    return float(top[late].mean()), float(bot[late].mean()), np.c_[top, bot]


def run_case(name: str, r_driven: float, omega: float, torque: float, elements: int, t_end: float, dt: float):
    s = scene(r_driven, omega, torque, elements)
    asm = Assembly(s)
    q0 = asm.x0.copy()
    xb = settled_belt(r_driven, elements)
    q0[:len(xb)] = xb  # (the belt's coordinates come first, the bodies' after them)
    sensors = [{"name": f"n{k}", "kind": "coordinates", "member": "belt", "at": k} for k in range(elements)]
    sensors += [{"name": b, "kind": "body", "member": b} for b in ("driver", "driven")]
    res = run_dynamics(asm, {"integrator": "generalized_alpha", "rho_inf": 0.6, "dt": dt, "t_end": t_end,
                             "output_dt": 5 * dt, "sensors": sensors, "energies": False, "q0": q0})
    t = np.asarray(res.t)
    late = t >= t[-1] * 2 / 3
    w1 = float(np.mean(res.sensors["driver"][late, 3])) if res.success else float("nan")
    w2 = float(np.mean(res.sensors["driven"][late, 3])) if res.success else float("nan")
    T_top, T_bot, series = span_tensions(res, elements) if res.success else (float("nan"),) * 2 + (None,)
    tight, slack = max(T_top, T_bot), min(T_top, T_bot)
    ratio_radii = R1 / r_driven
    speed_ratio = w2 / w1
    return {"case": name, "r_driver": R1, "r_driven": r_driven, "omega_driver": omega, "omega_driver_measured": w1,
            "omega_driven_steady": w2, "ratio_radii": ratio_radii, "speed_ratio": speed_ratio,
            "creep": 1 - speed_ratio / ratio_radii, "creep_elastic": (tight - slack) / (EA + tight),
            "T_tight": tight, "T_slack": slack, "tight_span": "top" if T_top > T_bot else "bottom",
            "tension_ratio": tight / slack, "capstan_limit": math.exp(MU * wrap_angle(min(R1, r_driven),
                                                                                       max(R1, r_driven))),
            "torque": torque, "torque_from_tensions": (tight - slack) * r_driven, "success": res.success,
            "status": res.status, "steps": res.steps, "wall_s": res.wall_s}, (t, series, res)


CASES = [("r0.15_M20", 0.15, 20.0, 20.0), ("r0.15_M40", 0.15, 20.0, 40.0), ("r0.2_M20", 0.2, 20.0, 20.0)]


def main(argv=None):
    a = C.parser("belt_drive", __doc__).parse_args(argv)
    cases = CASES[:1] if a.quick else CASES
    elements, t_end, dt = (48, 0.6, 1e-3) if a.quick else (72, 1.0, 5e-4)
    runs = [run_case(n, r2, w, M, elements, t_end, dt) for n, r2, w, M in cases]
    records = [r for r, _ in runs]
    C.table(records, ["case", "r_driven", "omega_driven_steady", "speed_ratio", "ratio_radii", "creep",
                      "creep_elastic", "T_tight", "T_slack", "tension_ratio", "capstan_limit", "torque",
                      "torque_from_tensions", "status"])

    def plots(out):
        plt = C.pyplot()
        fig, axs = plt.subplots(1, 2, figsize=(11, 4))
        for (r, (t, series, res)) in zip(records, runs):
            if series is None:
                continue
            axs[0].plot(t, res.sensors["driven"][:, 3] / res.sensors["driver"][:, 3].clip(1e-9), label=r["case"])
            axs[0].axhline(r["ratio_radii"], color="k", lw=0.6, ls=":")
            axs[1].plot(t, series[:, 0], label=f"{r['case']} top span")
            axs[1].plot(t, series[:, 1], "--", label=f"{r['case']} bottom span")
        axs[0].set_ylim(0, 1.1), axs[0].set_xlabel("t [s]"), axs[0].set_ylabel("omega_driven / omega_driver")
        axs[0].set_title("speed ratio (dotted: r_driver / r_driven)"), axs[0].legend(fontsize=7)
        axs[1].set_xlabel("t [s]"), axs[1].set_ylabel("span tension [N]"), axs[1].legend(fontsize=7)
        axs[1].set_title("tight and slack span tensions")
        C.save(fig, out, "belt_drive.png")

    return C.finish(records, a, plots)


if __name__ == "__main__":
    main()
