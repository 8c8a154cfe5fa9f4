"""Belt drive: a closed belt over two pulleys of different radii, the driver at a prescribed angular velocity, the
driven pulley against a resisting torque; speed ratio (creep) and span tensions against the belt laws.

Two pulleys, rigid bodies on revolute joints (driver r_driver = 0.1 m at the origin, driven r_driven at D = 0.5 m to
the right), carry a closed belt (`Scene.loop` along `closed.belt_path`, prestrained by 0.5 %: EA = 1e5 N, so about
500 N in both spans at rest) through circle contacts carried by the bodies (Hertz law, regularised Coulomb friction
mu = 0.4, eps = 1 cm/s, 0.5 % of the belt speed); the belt starts in static equilibrium on the pulleys. The
driver's angular velocity is prescribed (`Scene.drive`): a smooth ramp from rest to omega_driver = 20 rad/s in
0.2 s, then constant; the driven pulley's resisting torque M (`Scene.torque`) follows the same ramp. No gravity.

Laws checked in the records:
- torque balance of the driven pulley at steady speed: (T_tight - T_slack) r_driven = M (exact for a massless span;
  the belt's own mass adds its centrifugal tension rho A v^2 to both spans, which cancels);
- the capstan (Euler-Eytelwein) limit of the belt on its smaller pulley: T_tight / T_slack <= e^(mu theta), theta
  the wrap angle there; below that limit the belt sticks on most of the wrap (no gross slip);
- speed ratio omega_driven / omega_driver = (r_driver / r_driven) (1 - s): the elastic creep
  s ~ (T_tight - T_slack) / (EA + T_tight) (the belt leaves the driver shorter than it arrives: slip on the exit
  arcs), plus the regularised friction's own creep: an arc that transmits the fraction f of mu f_n slides at
  eps f / sqrt(1 - f^2), so this creep is of order eps / (omega_driver r_driver) = 0.5 % and grows with the torque.
Tensions are EA (|r_x| - 1) averaged over the nodes of the middle half of each straight span and over the last
third of the run. Records (one per case): case, r_driver, r_driven, omega_driver, omega_driven_steady, ratio_radii,
speed_ratio, creep, creep_elastic, T_tight, T_slack, tension_ratio, capstan_limit, torque, torque_from_tensions,
status. Figure belt_drive.png: speed ratio against r_driver / r_driven (creep), creep against the elastic creep,
span tensions in time.

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
from ancf_sym.scene.closed import belt_path  # noqa: E402
from ancf_sym.model.assembly import Assembly  # noqa: E402
from ancf_sym.dynamics import run_dynamics  # noqa: E402
from ancf_sym.statics import solve_static  # noqa: E402

D, R1 = 0.5, 0.1
EA, RHO_A, PRESTRAIN = 1e5, 0.1, 5e-3  # [N], [kg/m]
AREA = 1e-4
MU, EPS, K_H = 0.4, 1e-2, 1e9  # Hertz law k_h delta^1.5 [N/m^2.5]: C2 energy, no Hessian jump at touch-down
T_RAMP = 0.2


def wrap_angle(r_small: float, r_big: float) -> float:
    """Wrap of an open belt on its smaller pulley: pi - 2 asin((r_big - r_small) / D)."""
    return math.pi - 2 * math.asin((r_big - r_small) / D)


def _delta(r: float, k_n: float | None = None) -> float:
    """Penetration that carries the prestress T0 round a pulley of radius r: k_h delta^1.5 = T0 / r (Hertz), or
    k_n delta = T0 / r (linear penalty k_n)."""
    p = EA * PRESTRAIN / r
    return p / k_n if k_n else (p / K_H) ** (2 / 3)


def _law(k_n: float | None) -> dict:
    """The normal law: Hertz K_H, or a linear penalty k_n [N/m^2] (the law of Exudyn's cable-circle contact)."""
    return {"stiffness": k_n} if k_n else {"hertz": K_H}


def _path(r_driven: float, k_n: float | None = None) -> list:
    """The belt's path: lies inside each pulley by the penetration that carries the prestress round the arcs."""
    return belt_path([((0.0, 0.0), R1 - _delta(R1, k_n)), ((D, 0.0), r_driven - _delta(r_driven, k_n))])


def settled_belt(r_driven: float, elements: int, k_n: float | None = None) -> np.ndarray:
    """Belt coordinates in static equilibrium on the pulleys (frictionless fixed drums at their centres): the
    dynamic run starts from rest without the impact of a belt whose discretised arcs do not press evenly on the
    pulleys. The loop's sliding round the pulleys is held by a pin on the node nearest the middle of the lower
    span, where the belt touches nothing: the pin's reaction there is tangential (about 1 % of the prestress),
    where a pin on an arc would hold the node against the normal law (about 20 % of it, a violent start)."""
    s = Scene(dim=2, gravity=(0.0, 0.0), name="belt_drive_statics")
    path = _path(r_driven, k_n)
    s.loop("belt", path, elements, *_belt_material(), axial="biot", prestrain=PRESTRAIN)
    for c, r in (((0.0, 0.0), R1), ((D, 0.0), r_driven)):
        s.contact_drum("belt", c, r, thickness=0.0, **_law(k_n))
    free = Assembly(s)
    nodes = free.member_coordinates(free.x0, "belt")[:, :2]
    (_, a, b) = path[0]  # the lower span, from the driver to the driven pulley
    s.pin("belt", int(np.argmin(np.linalg.norm(nodes - (np.add(a, b) / 2), axis=1))))
    res = solve_static(s)
    if not res.success:
        raise RuntimeError(f"belt statics failed: {res.status}")
    return np.asarray(res.x)


def _belt_material():
    return Material(E=EA / AREA, density=RHO_A / AREA), Section(area=AREA, I=AREA * 1e-6)


def scene(r_driven: float, omega: float, torque: float, elements: int, k_n: float | None = None) -> Scene:
    """The belt drive (Hertz law, or a linear penalty k_n [N/m^2])."""
    s = Scene(dim=2, gravity=(0.0, 0.0), name="belt_drive")
    s.body("driver", 1.0, 0.5 * 1.0 * R1**2, position=(0.0, 0.0))
    s.body("driven", 1.0, 0.5 * 1.0 * r_driven**2, position=(D, 0.0))
    s.revolute("driver")
    s.revolute("driven")
    # the belt turns counter-clockwise: along the bottom from the driver to the driven pulley, back along the top;
    # its path lies inside each pulley by the penetration delta = T0 / (k r) that carries the prestress T0 round
    # the arcs (k delta = T0 / r): the run starts near equilibrium instead of with the belt slamming onto them
    path = _path(r_driven, k_n)
    # a thin belt: bending stiffness EA 1e-6 m^2 = 0.1 N m^2 (regularises the mesh only)
    s.loop("belt", path, elements, *_belt_material(), axial="biot", prestrain=PRESTRAIN)
    for b, r in (("driver", R1), ("driven", r_driven)):
        s.contact_drum("belt", radius=r, body=b, mu=MU, eps=EPS, damping=1e2, thickness=0.0, **_law(k_n))
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


def start(asm: Assembly, r_driven: float, elements: int, k_n: float | None = None) -> np.ndarray:
    """The scene's start coordinates: the settled belt on the pulleys at rest (the belt's coordinates come first,
    the bodies' after them)."""
    q0 = asm.x0.copy()
    xb = settled_belt(r_driven, elements, k_n)
    q0[:len(xb)] = xb
    return q0


def run_case(name: str, r_driven: float, omega: float, torque: float, elements: int, t_end: float, dt: float):
    asm = Assembly(scene(r_driven, omega, torque, elements))
    q0 = start(asm, r_driven, elements)
    sensors = [{"name": f"n{k}", "kind": "coordinates", "member": "belt", "at": k} for k in range(elements)]
    sensors += [{"name": b, "kind": "body", "member": b} for b in ("driver", "driven")]
    res = run_dynamics(asm, {"integrator": "generalized_alpha", "rho_inf": 0.6, "dt": dt, "t_end": t_end,
                             "output_dt": 5 * dt, "sensors": sensors, "energies": False, "q0": q0,
                             "newton": {"line_search": True}})
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
            "status": res.status, "steps": res.steps, "rejected": len(res.rejected),
            "newton_per_step": res.counters["newton_iterations"] / max(res.steps, 1),
            "wall_s": res.wall_s}, (t, series, res)


# (name, r_driven, omega_driver, torque): three radius ratios at one torque, and the torque raised towards the
# capstan limit on the 0.15 m pulley (T_tight / T_slack from 1.3 to 2.3 of the limit 3.24)
CASES = [("r0.15_M20", 0.15, 20.0, 20.0), ("r0.1_M20", 0.1, 20.0, 20.0), ("r0.2_M20", 0.2, 20.0, 20.0),
         ("r0.15_M40", 0.15, 20.0, 40.0), ("r0.15_M60", 0.15, 20.0, 60.0)]


def main(argv=None):
    a = C.parser("belt_drive", __doc__).parse_args(argv)
    cases = CASES[:1] if a.quick else CASES
    elements, t_end, dt = (48, 0.6, 1e-3) if a.quick else (64, 0.8, 1e-3)
    runs = [run_case(n, r2, w, M, elements, t_end, dt) for n, r2, w, M in cases]
    records = [r for r, _ in runs]
    C.table(records, ["case", "r_driven", "omega_driven_steady", "speed_ratio", "ratio_radii", "creep",
                      "creep_elastic", "T_tight", "T_slack", "tension_ratio", "capstan_limit", "torque",
                      "torque_from_tensions", "status"])

    def plots(out):
        plt = C.pyplot()
        fig, axs = plt.subplots(1, 3, figsize=(15, 4.2))
        ok = [r for r in records if r["success"]]
        x = np.linspace(0.45, 1.05, 2)
        axs[0].plot(x, x, "k:", lw=0.8, label="no creep: r_driver / r_driven")
        for r in ok:
            axs[0].plot(r["ratio_radii"], r["speed_ratio"], "o",
                        label=f"{r['case']} (creep {100 * r['creep']:.2f} %)")
        axs[0].set_xlabel("r_driver / r_driven"), axs[0].set_ylabel("omega_driven / omega_driver (steady)")
        axs[0].set_title("speed ratio"), axs[0].legend(fontsize=7)
        e = np.array([r["creep_elastic"] for r in ok])
        axs[1].plot(100 * e, [100 * r["creep"] for r in ok], "o")
        for r in ok:
            axs[1].annotate(r["case"], (100 * r["creep_elastic"], 100 * r["creep"]), fontsize=7)
        ee = np.linspace(0, max(e.max(), 1e-3) * 1.1, 2) if len(e) else np.zeros(2)
        axs[1].plot(100 * ee, 100 * ee, "k:", lw=0.8, label="elastic creep (T_tight - T_slack) / (EA + T_tight)")
        axs[1].plot(100 * ee, 100 * (ee + EPS / (20.0 * R1)), "k--", lw=0.6,
                    label="elastic + eps / (omega r_driver)")
        axs[1].set_xlabel("elastic creep [%]"), axs[1].set_ylabel("measured creep [%]"), axs[1].legend(fontsize=7)
        axs[1].set_title("creep")
        for r, (t, series, res) in runs:
            if series is None:
                continue
            line, = axs[2].plot(t, series[:, 0], lw=0.8, label=f"{r['case']} top span")
            axs[2].plot(t, series[:, 1], "--", lw=0.8, color=line.get_color(), label="bottom span")
        axs[2].set_xlabel("t [s]"), axs[2].set_ylabel("span tension [N]"), axs[2].legend(fontsize=6, ncol=2)
        axs[2].set_title("tight (top) and slack (bottom) span tensions")
        fig.tight_layout()
        C.save(fig, out, "belt_drive.png")

    return C.finish(records, a, plots)


if __name__ == "__main__":
    main()
