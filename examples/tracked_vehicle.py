"""Tracked vehicle of paper 001 (sec. 4.2): a closed steel track chain of 64 beam3d elements around a sprocket, an
idler and five road wheels, on a rigid ground with Hertz contact and friction, run with the continuum (CMM) and
the elastic-line (ELM) forces.

Chain (paper 001): 64 elements of l = 0.151624 m, b = 0.381 m, h = 0.02 m, rho = 15.6 Mg/m^3, E = 200 GPa,
nu = 0.3, g = 9.81; the first node is the last (a loop). Wheel layout (the paper gives none; M113 data, whose shoe
mass rho l b h = 18.02 kg and 15 in width the chain has): 10-tooth sprocket of pitch radius l / (2 sin(pi/10)) =
0.2453 m at the front, idler of radius 0.255 m at the rear, five road wheels of radius 0.305 m at 0.66 m spacing
(contact length 2.64 m, the M113's 2.67 m). The chain's centre line runs on the sprocket's pitch circle (drum radius
pitch radius - h/2) and at h/2 outside the idler and road wheels; the idler's fore-aft position is solved so that
the wrapped loop is exactly 64 l long (the track adjuster's job).

Frames: the scene is x forward, y up, z lateral (the chain lies in the plane z = 0); the paper's axes are Y forward,
Z up, X lateral, so paper (X, Y, Z) = scene (z, x, y). Records use the paper's names.

This version holds the wheels fixed in space (fixed drums): the chain rests on the wheels and the ground, started
from its static equilibrium (`static_start`), or, with --speed V, running along its path at V from that shape (the
ground's friction then brakes it: an energy bookkeeping case). What the driven vehicle adds (a chassis body carrying
the wheels, the sprocket turned by the paper's omega(t)) is listed in docs/vehicle.md. "Vehicle" displacement and
speed here are the chain's centre of mass.

The steel band's bending stiffness is the paper's, E b h^3 / 12 = 5.08e4 N m^2: wrapped on the sprocket's pitch
circle it carries a bending moment of EI / R = 2.1e5 N m, so the band wants to straighten and is held on the wheels
only by its own tension (the loop is exactly as long as the wheels' convex hull); that tension, of order EI / R^2 =
0.8 MN, presses it on the wheels with MN forces. The contact laws are therefore much stiffer than the chain's weight
alone would need. Before the dynamics, `relax_sections` removes the spurious thickness strain of the curved
elements and `static_start` finds the equilibrium (docs/vehicle.md says why both are needed).

Records (one per output time, every 0.05 s): method, t, x, y, z (paper axes, centre of mass displacement from the
start [m]), vy (forward speed [m/s]), wall_s (the run's wall time), contact gaps and forces, the largest distance
of a node from the wrapped path and from its start, the mean stretch, the energies (kinetic, potential,
damping_work, external_work, algorithmic), the run's steps, Newton iterations, CPU time and the static start's
cost, and shape_diff_vs_other (CMM vs ELM: largest distance between the chains' nodes).

Run: python examples/tracked_vehicle.py [--quick] [--methods continuum,elastic_line] [--t-end 5] [--json PATH]
     [--out DIR] [--dt 2e-4] [--speed V]
"""
from __future__ import annotations

import math
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common as C  # noqa: E402  (first: it limits BLAS threads before numpy loads)

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import scipy.sparse.linalg as spla  # noqa: E402
from scipy.optimize import brentq  # noqa: E402

from ancf_sym import Material, Scene, Section, closed, contact  # noqa: E402
from ancf_sym.assembly import Assembly  # noqa: E402
from ancf_sym.dynamics import DynamicOptions, Sensor, simulate  # noqa: E402
from ancf_sym.dynamics_output import frame_sensors, write_series  # noqa: E402
from ancf_sym.statics import solve_static  # noqa: E402

# -- paper 001's chain ------------------------------------------------------------------------------------------
G = 9.81
N_EL, L_EL, B, H = 64, 0.151624, 0.381, 0.02
STEEL = Material(E=200e9, density=15.6e3, poisson=0.3)
T = H / 2  # contact thickness: the band's half thickness
CHAIN_MASS = N_EL * L_EL * B * H * STEEL.density  # 1153 kg
# -- M113 wheel layout (scene frame: x forward, y up) -----------------------------------------------------------
R_PITCH = L_EL / (2 * math.sin(math.pi / 10))  # 10-tooth sprocket: pins on the pitch circle
R_SPROCKET = R_PITCH - T  # drum radius: the chain's centre line runs on the pitch circle
R_IDLER, R_ROAD = 0.255, 0.305
ROAD_X = (-1.32, -0.66, 0.0, 0.66, 1.32)
Y_ROAD = 2 * T + R_ROAD  # road wheels resting on the chain resting on the ground y = 0
SPROCKET = (2.0, 0.62)
Y_IDLER = 0.52
QUICK_T = 0.02  # [s] the test's runs
RUN_SPEED = 10 * R_PITCH  # [m/s] the paper's speed plateau without slip, omega = 10 rad/s on the pitch circle
AXIS_LABELS = {"x": "X (lateral) [m]", "y": "Y (forward) [m]", "z": "Z (up) [m]", "vy": "forward speed [m/s]"}
PIN_NODE = 8  # a node of the bottom span, under the middle road wheel (held for the static start only)
# -- contact laws ------------------------------------------------------------------------------------------------
# ground: Hertz; the band's bending presses it on the ground with ~0.3 MN near the end road wheels (measured at the
# static start), which sinks it ~2 mm; its own weight per length w = 1166 N/m alone would sink it 0.02 mm
GROUND = dict(hertz=1e10, damping=1e9, mu=0.5, eps=0.01)
# wheels: Hertz, stiff enough that the band's ~3 MN/m wrap pressure sinks it ~1 mm: kh = 3e6 / 1e-3^1.5
# wheels held in space: frictionless and undamped (friction there only matters once the sprocket drives; with
# mu = 0.3 and the MN/m wrap pressure the regularised friction (eps = 0.01 m/s) made Newton reject most steps, and
# the damping/friction kernels of 7 drums x 64 elements quadrupled the cost per step, measured)
WHEEL = dict(hertz=1e11)


def idler_x() -> float:
    """Fore-aft idler position for which the chain wrapped around the wheels' convex hull is 64 l long."""
    return brentq(lambda x: closed.check_path(chain_path(x)) - N_EL * L_EL, ROAD_X[0] - 1.5, ROAD_X[0] - 0.3,
                  xtol=1e-12)


def wheels(x_idler: float) -> list[tuple[str, tuple[float, float], float]]:
    """(name, centre, drum radius) of every wheel."""
    out = [(f"road{i + 1}", (x, Y_ROAD), R_ROAD) for i, x in enumerate(ROAD_X)]
    return out + [("sprocket", SPROCKET, R_SPROCKET), ("idler", (x_idler, Y_IDLER), R_IDLER)]


def chain_path(x_idler: float) -> list:
    """The chain's centre line: convex hull of the rear and front road wheels, the sprocket and the idler (the
    middle road wheels touch the bottom span), counter-clockwise from the rear road wheel's bottom."""
    hull = [((ROAD_X[0], Y_ROAD), R_ROAD + T), ((ROAD_X[-1], Y_ROAD), R_ROAD + T), (SPROCKET, R_SPROCKET + T),
            ((x_idler, Y_IDLER), R_IDLER + T)]
    return closed.belt_path(hull)


def build_scene(method: str, ground_mu: float | None = None) -> Scene:
    sc = Scene(dim=3, gravity=(0.0, -G, 0.0), name=f"tracked_vehicle_{method}")
    xi = idler_x()
    # section y axis lateral (b = 0.381 m across the track), z in the chain's plane (h = 0.02 m thick)
    sc.loop("chain", chain_path(xi), N_EL, STEEL, Section.rectangle(b=B, h=H), element="beam3d",
            beam_method=method, y_axis=(0.0, 0.0, 1.0))
    sc.contact_ground("chain", normal=(0.0, 1.0, 0.0), level=0.0,
                      **{**GROUND, **({} if ground_mu is None else {"mu": ground_mu})})
    for _, c, R in wheels(xi):
        sc.contact_drum("chain", (c[0], c[1], 0.0), R, **WHEEL)
    return sc


def chain_com(asm: Assembly, states: np.ndarray) -> np.ndarray:
    """Centre of mass of the chain (node average: equal elements, so the nodes' mean is the centre of mass to the
    interpolation order) for node states (n_times, n_nodes, 12)."""
    return states[:, :, :3].mean(axis=1)


def relax_sections(asm: Assembly, x: np.ndarray, member: str = "chain", tol: float = 1e-12) -> np.ndarray:
    """x with the section gradients r_y, r_z of every node of `member` at their energy minimum, the positions and
    slopes held (Newton on that block of the exact Hessian).

    The loop's nodes carry unit, orthogonal r_y, r_z; the element interpolates them linearly, so over an element
    that spans an arc of angle a (34 deg on the sprocket) the interpolated r_z is shortened by up to
    1 - cos(a/2) and the thickness strain E_zz ~ -a^2/8 = -4.4 % is a spurious stress of ~9 GPa. Released as it is,
    that energy rings the section modes (mass rho A h^2/12 per length, stiffness ~EA) at ~1e6 rad/s and the run
    blows up; relaxing it first leaves only the band's real bending and stretch."""
    mm = asm.mesh.members[member]
    idx = np.concatenate([mm.node_dofs(k)[6:12] for k in range(mm.n_nodes)])
    x = np.array(x, float)
    for _ in range(20):
        ev = asm.evaluate(x, hessian=True)
        dx = spla.spsolve(sp.csc_matrix(ev.hessian)[idx][:, idx], -np.asarray(ev.gradient)[idx])
        x[idx] += dx
        if np.abs(dx).max() < tol:
            return x
    raise RuntimeError("section relaxation did not converge in 20 Newton iterations")


def static_start(method: str) -> tuple[np.ndarray, dict]:
    """The chain at rest on the wheels and the ground: statics (penalty contact, IPOPT) from the wrapped shape
    with relaxed sections, one bottom node pinned for the solve only (frictionless statics leaves the loop free to
    slide around the wheels; in the dynamic run the ground's friction holds it). Returns x and the solve's data."""
    sc = build_scene(method)
    sc.pin("chain", at=PIN_NODE)
    asm = Assembly(sc)
    t0 = time.perf_counter()
    r = solve_static(asm, warm_start=relax_sections(asm, asm.x0), print_level=0)
    if not r.success:
        raise RuntimeError(f"static start ({method}): {r.status}")
    pin = np.asarray(r.constraint_forces.get(f"pin chain@{PIN_NODE}", [np.nan] * 3), float)
    return r.x, {"static_s": time.perf_counter() - t0, "static_iterations": r.iterations,
                 "pin_force": float(np.linalg.norm(pin))}


def circulating(asm: Assembly, speed: float, refine: int = 200) -> np.ndarray:
    """v0 of the chain running along its wrapped path at `speed` [m/s] (counter-clockwise: forward on top, backward
    on the ground; the sense of a vehicle driving backwards): r' = V t, r_x' = V dt/ds, r_y' = 0 (lateral),
    r_z' = V dt/ds x y at each node. dt/ds (curvature vector) from the path sampled `refine` times finer than the
    nodes (a central difference of the path's exact tangents across one fine interval: an initial condition, not a
    solver derivative)."""
    mm = asm.mesh.members["chain"]
    pts, tans, total = closed.sample(chain_path(idler_x()), N_EL * refine, 3)
    ds = total / (N_EL * refine)
    v = np.zeros(asm.n)
    y = np.array([0.0, 0.0, 1.0])
    for k in range(mm.n_nodes):
        i = k * refine
        dtds = (tans[(i + 1) % len(tans)] - tans[i - 1]) / (2 * ds)
        v[mm.node_dofs(k)] = speed * np.concatenate([tans[i], dtds, np.zeros(3), np.cross(dtds, y)])
    return v


def run(method: str, t_end: float, dt: float, integrator: str = "generalized_alpha", rho_inf: float = 0.5,
        output_dt: float = 0.05, speed: float = 0.0, ground_mu: float | None = None,
        case: str = "rest") -> tuple[list[dict], dict]:
    sc = build_scene(method, ground_mu)
    asm = Assembly(sc)
    q0, st = static_start(method)
    v0 = circulating(asm, speed) if speed else None
    sensors = [Sensor(**s) for s in frame_sensors(sc)]
    opts = DynamicOptions(dt=dt, t_end=t_end, integrator=integrator, rho_inf=rho_inf, output_dt=output_dt,
                          sensors=sensors, q0=q0, v0=v0)
    t0 = time.perf_counter()
    res = simulate(asm, opts)
    wall = time.perf_counter() - t0
    mm = asm.mesh.members["chain"]
    states = np.stack([np.asarray(res.sensors[f"__node:chain:{j}"]) for j in range(mm.n_nodes)], axis=1)
    com = chain_com(asm, states)
    t = np.asarray(res.t)
    vel = np.gradient(com, t, axis=0) if len(t) > 1 else np.zeros_like(com)
    d = com - com[0]
    path = closed.sample(chain_path(idler_x()), 20000, 3)[0]
    en = res.energies
    records = []
    for k in range(len(t)):
        x = np.array(res.x, float)
        x[mm.offset:mm.offset + states[k].size] = states[k].ravel()
        reps = contact.report(asm, x)
        r = states[k, :, :3]
        offset = np.sqrt(((r[:, None, :] - path[None, :, :]) ** 2).sum(axis=2).min(axis=1))
        records.append({"case": case, "method": method, "t": float(t[k]), "x": float(d[k, 2]), "y": float(d[k, 0]),
                        "z": float(d[k, 1]), "vy": float(vel[k, 0]), "wall_s": wall, "status": res.status,
                        "ground_gap_min": reps[0]["min_gap"], "ground_force": reps[0]["normal_force"],
                        "wheel_gap_min": min(rp["min_gap"] for rp in reps[1:]),
                        "wheel_force": sum(rp["normal_force"] for rp in reps[1:]),
                        "path_offset_max": float(offset.max()),
                        "stretch_mean": float(np.linalg.norm(states[k, :, 3:6], axis=1).mean() - 1.0),
                        "chain_speed": float(np.sqrt(2 * max(en["kinetic"][k], 0.0) / CHAIN_MASS)),
                        **{e: float(en[e][k]) for e in ("kinetic", "potential", "damping_work", "external_work",
                                                        "algorithmic")}})
    summary = {"case": case, "method": method, "status": res.status, "success": res.success, "t_reached": res.t_reached,
               "steps": res.steps, "rejected": len(res.rejected), "newton": res.newton_iterations,
               "factorizations": res.factorizations, "wall_s": wall, "setup_s": res.setup_s, "cpu_s": res.cpu_s,
               "ms_per_step": 1e3 * res.wall_s / max(res.steps, 1),
               "cpu_ms_per_step": 1e3 * res.cpu_s / max(res.steps, 1),
               "ground_gap_min": min(r["ground_gap_min"] for r in records),
               "wheel_gap_min": min(r["wheel_gap_min"] for r in records),
               "chain_weight": CHAIN_MASS * G,
               "energy_error": res.energy_error(), **st}
    for k, r in enumerate(records):  # run-level figures in every record (flat records, as wall_s)
        r.update({k: summary[k] for k in ("steps", "rejected", "newton", "factorizations", "cpu_s",
                                          "cpu_ms_per_step", "static_s", "pin_force")})
        r["drift_max"] = float(np.linalg.norm(states[k, :, :3] - states[0, :, :3], axis=1).max())
    return records, {"summary": summary, "t": t, "states": states, "result": res}


def main(argv=None):
    p = C.parser("tracked_vehicle", __doc__)
    p.add_argument("--methods", default="continuum,elastic_line", help="comma-separated beam forms")
    p.add_argument("--t-end", type=float, default=None, help="end time [s] (default 5, --quick 0.02)")
    p.add_argument("--dt", type=float, default=2e-4, help="time step [s]")
    p.add_argument("--integrator", default="generalized_alpha")
    p.add_argument("--speed", type=float, default=0.0,
                   help="start the chain running along its path at this speed [m/s] instead of at rest")
    p.add_argument("--ground-mu", type=float, default=None, help=f"ground friction (default {GROUND['mu']})")
    a = p.parse_args(argv)
    t_end = a.t_end if a.t_end is not None else (QUICK_T if a.quick else 5.0)
    case = "running" if a.speed else "rest"
    cases = [(case, m, a.speed, a.ground_mu) for m in a.methods.split(",")]
    if a.quick:  # and the chain running at the speed plateau's 2.45 m/s on a frictionless ground (a belt on a stand)
        cases.append(("running", "elastic_line", RUN_SPEED, 0.0))
    records, runs = [], []
    for case, method, speed, mu in cases:
        recs, data = run(method, t_end, a.dt, a.integrator, speed=speed, ground_mu=mu, case=case)
        records += recs
        runs.append(data)
    for c in {r["case"] for r in records}:  # CMM vs ELM: largest distance between the chains' nodes at each time
        pair = [d for d in runs if d["summary"]["case"] == c]
        if len(pair) != 2:
            continue
        A, B = pair[0]["states"], pair[1]["states"]
        n = min(len(A), len(B))
        diff = np.linalg.norm(A[:n, :, :3] - B[:n, :, :3], axis=2).max(axis=1)
        for d in pair:
            rs = [r for r in records if r["method"] == d["summary"]["method"] and r["case"] == c]
            for k, r in enumerate(rs[:n]):
                r["shape_diff_vs_other"] = float(diff[k])
    C.table([d["summary"] for d in runs], ["case", "method", "status", "steps", "rejected", "newton",
                                          "factorizations", "ms_per_step", "cpu_ms_per_step", "wall_s",
                                          "ground_gap_min", "wheel_gap_min", "energy_error"])

    def plots(out):
        plt = C.pyplot()
        fig, axes = plt.subplots(2, 2, figsize=(11, 7))
        for d in runs:
            m, c = d["summary"]["method"], d["summary"]["case"]
            rs = [r for r in records if r["method"] == m and r["case"] == c]
            t = [r["t"] for r in rs]
            for ax, k in zip(axes.ravel(), ("x", "y", "z", "vy")):
                ax.plot(t, [r[k] for r in rs], label=f"{c}, {m}")
            if c == "running":  # the chain runs round the wheels: its rms speed sqrt(2 T / m)
                axes[1, 1].plot(t, [r["chain_speed"] for r in rs], "--", label=f"{c}, {m}: chain rms speed")
                axes[1, 1].legend(fontsize=7)
                ax.set_xlabel("t [s]"), ax.set_ylabel(AXIS_LABELS[k])
        axes[0, 0].legend()
        C.save(fig, out, "displacement_speed.png")
        fig, axes = plt.subplots(1, len(runs), figsize=(5 * len(runs), 3.6), squeeze=False)
        for ax, d in zip(axes[0], runs):  # energy bookkeeping: E(0) = kinetic + potential + damping work + alg.
            m, c = d["summary"]["method"], d["summary"]["case"]
            rs = [r for r in records if r["method"] == m and r["case"] == c]
            t = [r["t"] for r in rs]
            for k, lab in (("kinetic", "kinetic"), ("potential", "potential - potential(0)"),
                           ("damping_work", "contact damping + friction work"), ("algorithmic", "integrator")):
                ax.plot(t, [r[k] - (rs[0][k] if k == "potential" else 0.0) for r in rs], label=lab)
            ax.set_title(f"{c}, {m}", fontsize=9), ax.set_xlabel("t [s]"), ax.set_ylabel("energy [J]")
        axes[0, 0].legend(fontsize=7)
        C.save(fig, out, "energy.png")
        fig, ax = plt.subplots(figsize=(11, 3.5))
        for d in runs:
            S = d["states"]
            for k in sorted({0, len(S) // 2, len(S) - 1}):
                r = S[k, :, :3]
                ax.plot(np.r_[r[:, 0], r[:1, 0]], np.r_[r[:, 1], r[:1, 1]], ".-", ms=3,
                        label=f"{d['summary']['case']}, {d['summary']['method']}, t = {d['t'][k]:.2f} s")
        for name, c, R in wheels(idler_x()):
            ax.add_patch(plt.Circle(c, R, fill=False, color="0.5"))
        ax.axhline(0.0, color="k", lw=0.8)
        ax.set_aspect("equal"), ax.legend(fontsize=7), ax.set_xlabel("forward [m]"), ax.set_ylabel("up [m]")
        C.save(fig, out, "chain_shape.png")
        for d in runs:
            dest = Path(out) / f"vtk_{d['summary']['case']}_{d['summary']['method']}"
            tmp = Path(tempfile.mkdtemp(dir=out))
            write_series(d["result"], tmp)
            if dest.exists():
                shutil.rmtree(dest)
            tmp.rename(dest)
            print(f"VTK series: {dest / 'series.pvd'}")

    return C.finish(records, a, plots)


if __name__ == "__main__":
    main()
