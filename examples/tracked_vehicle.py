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

The driven half vehicle (the default run): a chassis (half of the M113's ~7.8 t hull) held in the chain's plane by
two light slides (forward, vertical, pitch), the sprocket, the idler and the five road wheels as spatial bodies on
revolute joints to the chassis (axles rigidly mounted: no torsion bars; the band and the Hertz contacts give the
vertical compliance), each carrying its drum; the sprocket turned relative to the chassis by paper 001's omega(t)
(0 until 1 s, ramp to 10 rad/s at 2 s); it drives the chain by friction (mu = 0.3, no tooth model), the idler and
road wheels spin freely and are frictionless. The run starts from the vehicle's static equilibrium
(`vehicle_start`). "Vehicle" displacement and speed are the chassis' centre of mass; the no-slip estimates are the
sprocket's angle and rate times its pitch radius (35 rad x 0.2453 m = 8.59 m at 5 s, 2.453 m/s on the plateau).
The full vehicle (--vehicle full): a free spatial chassis (position and rotation; twice the half's mass and
inertia) carrying one such track on each side (`add_track`, planes z = -+1.155 m), both sprockets turned by the same
omega(t), started from the half vehicle's statics with the right chain the left one's mirror image (an exactly
symmetric start); its records add the lateral speed, roll and yaw, each side's drive torque and ground force and the
chains' mirror asymmetry.
With --fixed-wheels, the first stage: the chain on wheels held in space, at rest from its static equilibrium
(`static_start`) or, with --speed V, running along its path at V (the ground's friction then brakes it: an energy
bookkeeping case); its "vehicle" displacement and speed are the chain's centre of mass.

The steel band's bending stiffness is the paper's, E b h^3 / 12 = 5.08e4 N m^2: wrapped on the sprocket's pitch
circle it carries a bending moment of EI / R = 2.1e5 N m, so the band wants to straighten and is held on the wheels
only by its own tension (the loop is exactly as long as the wheels' convex hull); that tension, of order EI / R^2 =
0.8 MN, presses it on the wheels with MN forces. The contact laws are therefore much stiffer than the chain's weight
alone would need. Before the dynamics, `relax_sections` removes the spurious thickness strain of the curved
elements and `static_start` finds the equilibrium (docs/vehicle.md says why both are needed).

Records (one per output time, every 0.05 s): case ("driven", "full", "rest", "running"), method, t, x, y, z (paper
axes, centre of mass displacement from the start [m]), vy (forward speed [m/s]), wall_s (the run's wall time),
contact gaps and forces, the mean stretch, the energies (kinetic, potential, damping_work: contact damping and
friction, external_work: the drive's work, algorithmic), the run's steps, Newton iterations, CPU time and the static
start's cost, and shape_diff_vs_other (CMM vs ELM: largest distance between the chains' nodes); driven: the chassis'
pitch, the sprocket's angle and rate, the no-slip y and speed, the drive's torque; fixed wheels: the largest
distance of a node from the wrapped path and from its start.

Run: python examples/tracked_vehicle.py [--quick] [--vehicle half|full] [--methods continuum,elastic_line]
     [--t-end 5] [--json PATH] [--out DIR] [--dt 2e-4] [--drive-start 1] [--fixed-wheels [--speed V]] [--ground-mu MU]
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

from ancf_sym import Material, Scene, Section, contact  # noqa: E402
from ancf_sym.scene import closed  # noqa: E402
from ancf_sym.bodies import drives  # noqa: E402
from ancf_sym.model.assembly import Assembly  # noqa: E402
from ancf_sym.dynamics import DynamicOptions, Sensor, simulate  # noqa: E402
from ancf_sym.dynamics.newton import NewtonOptions  # noqa: E402
from ancf_sym.io.dynamics_output import write_series  # noqa: E402
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
QUICK_T = 0.02  # [s] the test's runs of the chain on fixed wheels
QUICK_DRIVEN_T = 0.3  # [s] the test's run of the driven vehicle (drive started at t = 0: the sprocket turns 0.24 rad)
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
# modified Newton: the exact tangent's factorisation kept across iterations and steps while Newton contracts (the
# step matrix changes little from step to step); 2.9x less CPU per step than a factorisation per step here (the
# ground's friction makes it unsymmetric: a sparse QR in the step graph; bench/VEHICLE_RESULTS.md)
NEWTON = NewtonOptions(modified=True)


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


_STATIC: dict = {}  # beam form -> (x, data) of its static start


def static_start(method: str) -> tuple[np.ndarray, dict]:
    """The chain at rest on the wheels and the ground: statics (penalty contact, IPOPT) from the wrapped shape
    with relaxed sections, one bottom node pinned for the solve only (frictionless statics leaves the loop free to
    slide around the wheels; in the dynamic run the ground's friction holds it). Returns x and the solve's data
    (solved once per beam form and process: the runs of one command share it)."""
    if method in _STATIC:
        x, st = _STATIC[method]
        return x.copy(), dict(st)
    sc = build_scene(method)
    sc.pin("chain", at=PIN_NODE)
    asm = Assembly(sc)
    t0 = time.perf_counter()
    r = solve_static(asm, warm_start=relax_sections(asm, asm.x0), print_level=0)
    if not r.success:
        raise RuntimeError(f"static start ({method}): {r.status}")
    pin = np.asarray(r.constraint_forces.get(f"pin chain@{PIN_NODE}", [np.nan] * 3), float)
    _STATIC[method] = (np.array(r.x, float), {"static_s": time.perf_counter() - t0,
                                              "static_iterations": r.iterations, "pin_force": float(np.linalg.norm(pin))})
    return static_start(method)


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


# -- the driven half vehicle ----------------------------------------------------------------------------------------
# M113 data (the paper gives none): half of the ~7.8 t hull per side; the hull's inertia as a uniform box of its
# length, height and width; wheels as discs (M113 dual road wheel ~50 kg). Total per side with the chain: 5.4 t.
CHASSIS_MASS = 3900.0  # [kg]
CHASSIS_BOX = (4.9, 1.8, 2.7)  # [m] length (x), height (y), width (z)
CHASSIS_POS = (0.2, 1.1)  # centre of mass (scene x, y) [m]: between the sprocket and the idler, 1.1 m up
WHEEL_MASS = {"road": 50.0, "sprocket": 80.0, "idler": 60.0}  # [kg]
WHEEL_WIDTH = 0.3  # [m] (the discs' inertia across their axle)
# the two slides that hold the chassis in the chain's plane (x slide on the ground, y slide on it, the chassis
# pitching on the y slide): light next to the 5.4 t they carry (4e-4 of the mass), so they change nothing physical
SLIDE_MASS = 1.0
# the sprocket drives the chain by friction (no tooth model): by the capstan law the band's ~0.8 MN tension over half
# the sprocket (mu = 0.3) can pass ~0.8 MN (e^(0.3 pi) - 1) = 1.3 MN, far above the ~18 kN the peak acceleration
# (3.3 m/s^2 on 5.4 t) needs; idler and road wheels spin freely on their axles and stay frictionless (docs/vehicle.md)
SPROCKET_LAW = dict(hertz=1e11, mu=0.3, eps=0.01)
DRIVE_START = 1.0  # [s] the paper's omega(t) is 0 until 1 s
# paper 001's sprocket angular velocity [rad/s] from the drive's start t_s: pieces (t - t_s, polynomial in (t - t_k))
OMEGA_PIECES = ((0.0, (0.0, 0.0, 80 / 3)), (0.25, (5 / 3, 40 / 3)), (0.75, (25 / 3, 40 / 3, -80 / 3)), (1.0, (10.0,)))
# the full vehicle: the two tracks' centre planes at z = -+GAUGE/2 (scene z points to the vehicle's right), the
# M113's 2.69 m overall width less one track width; the chassis box (2.7 m wide) spans them
GAUGE = 2.69 - B  # [m]
SIDES = {"left": -GAUGE / 2, "right": GAUGE / 2}
QUICK_FULL_T = 0.2  # [s] the test's run of the full vehicle (drive started at t = 0: the sprocket turns 0.07 rad)
# [s] its time step: y(0.2 s), the drive's work and the dissipation agree with dt = 2e-4 s to 4 digits (measured),
# at 0.4x the CPU time
QUICK_FULL_DT = 4e-4
NO_SLIP_Y = 35 * R_PITCH  # [m] forward travel without slip at 5 s: 35 rad of sprocket rotation on the pitch circle


def omega_spec(start: float = DRIVE_START) -> list:
    """Paper 001's omega(t) as a piecewise polynomial [[t_k, [a0, a1, ...]], ...] (0 before `start`)."""
    pieces = [[start + t, list(c)] for t, c in OMEGA_PIECES]
    return ([[0.0, [0.0]]] if start > 0 else []) + pieces


def sprocket_angle(t: np.ndarray, start: float = DRIVE_START) -> tuple[np.ndarray, np.ndarray]:
    """(angle [rad], omega [rad/s]) of the sprocket relative to the chassis at times t (exact integral)."""
    m = drives.motion("omega", omega_spec(start), integral_of=0.0)
    v = np.array([m(float(tk))[:2] for tk in np.atleast_1d(t)])
    return v[:, 0], v[:, 1]


def box_inertia(m: float, a: float, b: float, c: float) -> tuple[float, float, float]:
    return m * (b * b + c * c) / 12, m * (a * a + c * c) / 12, m * (a * a + b * b) / 12


def disc_inertia(m: float, R: float, w: float = WHEEL_WIDTH) -> tuple[float, float, float]:
    """A disc of radius R and width w turning about z."""
    across = m * (3 * R * R + w * w) / 12
    return across, across, m * R * R / 2


def wheel_bodies(x_idler: float) -> list[tuple[str, tuple[float, float], float, float, tuple]]:
    """(name, centre, drum radius, mass, inertia) of every wheel body."""
    out = []
    for name, c, R in wheels(x_idler):
        m = WHEEL_MASS[name.rstrip("0123456789")]
        out.append((name, c, R, m, disc_inertia(m, R + T)))
    return out


def build_vehicle(method: str, ground_mu: float | None = None, drive_start: float = DRIVE_START,
                  static: bool = False, full: bool = False) -> Scene:
    """The half vehicle: the chain, a chassis held in the chain's plane (forward, vertical, pitch), the sprocket,
    idler and road wheels on revolute joints to the chassis (axles rigidly mounted: free-spinning wheels, no
    suspension; the band's stiffness and the Hertz contacts give the vertical compliance), each carrying its drum,
    and the sprocket turned by paper 001's omega(t) relative to the chassis.

    full: the full vehicle instead: a free spatial chassis (position and rotation, twice the half's mass) and one
    such track (`add_track`) on each side, at z = -+GAUGE/2 (`SIDES`), both sprockets turned by the same omega(t).

    static: the scene of the half vehicle's static start instead. Frictionless statics leaves the wheels' spins
    free (the normal law's force passes through the axle), which makes the equilibrium singular; the drums are then
    all carried by the chassis, whose mass and centre are those of chassis and wheels together: the same contact
    geometry and the same weight and moment, hence the same equilibrium. No drive either (the statics take no
    time-dependent rows)."""
    if static and full:
        raise ValueError("build_vehicle: the full vehicle starts from the half vehicle's statics (vehicle_start)")
    sc = Scene(dim=3, gravity=(0.0, -G, 0.0), name=f"tracked_vehicle_{'full' if full else 'driven'}_{method}")
    xi = idler_x()
    wb = wheel_bodies(xi)
    mass, centre = CHASSIS_MASS, np.array([*CHASSIS_POS, 0.0])
    if static:
        mass = CHASSIS_MASS + sum(w[3] for w in wb)
        centre = (CHASSIS_MASS * centre + sum(w[3] * np.array([*w[1], 0.0]) for w in wb)) / mass
    p = tuple(centre)
    if full:  # free in space: its position and rotation are the vehicle's
        sc.body("chassis", 2 * mass, box_inertia(2 * mass, *CHASSIS_BOX), p)
    else:
        sc.body("slide_x", SLIDE_MASS, (0.1, 0.1, 0.1), p)
        sc.prismatic("slide_x", axis=(1.0, 0.0, 0.0))
        sc.body("slide_y", SLIDE_MASS, (0.1, 0.1, 0.1), p)
        sc.prismatic("slide_y", axis=(0.0, 1.0, 0.0), other="slide_x")
        sc.body("chassis", mass, box_inertia(mass, *CHASSIS_BOX), p)
        sc.revolute("chassis", axis=(0.0, 0.0, 1.0), other="slide_y")
    for side, z in (SIDES if full else {"": 0.0}).items():
        add_track(sc, method, side, z, ground_mu, drive_start, static)
    return sc


def add_track(sc: Scene, method: str, side: str, z: float, ground_mu: float | None, drive_start: float,
              static: bool) -> None:
    """One side's running gear on the scene's "chassis": the chain (member "chain" + suffix) in the plane at z on
    the Hertz ground, the sprocket, idler and road wheels on revolute joints to the chassis carrying their drums
    (static: drums on the chassis, no wheel bodies, no drive), the sprocket turned by omega(t). Names carry the
    suffix "_<side>" (none for the half vehicle's side "")."""
    sfx = f"_{side}" if side else ""
    chain = f"chain{sfx}"
    xi = idler_x()
    sc.loop(chain, chain_path(xi), N_EL, STEEL, Section.rectangle(b=B, h=H), element="beam3d", beam_method=method,
            y_axis=(0.0, 0.0, 1.0), offset=(0.0, 0.0, z))
    sc.contact_ground(chain, normal=(0.0, 1.0, 0.0), level=0.0,
                      **{**GROUND, **({} if ground_mu is None else {"mu": ground_mu})})
    for name, c, R, m, inertia in wheel_bodies(xi):
        law = SPROCKET_LAW if name == "sprocket" else WHEEL
        if static:
            sc.contact_drum(chain, centre=(c[0], c[1], z), radius=R, body="chassis", **law)
            continue
        sc.body(name + sfx, m, inertia, (c[0], c[1], z))
        # the sprocket's axis is -z: its positive angle turns it clockwise seen from +z, top forward (+x), which
        # runs the chain backward along the ground and the vehicle forward
        sc.revolute(name + sfx, axis=(0.0, 0.0, -1.0 if name == "sprocket" else 1.0), other="chassis")
        sc.contact_drum(chain, radius=R, body=name + sfx, **law)
    if not static:
        sc.drive(f"sprocket{sfx}", omega=omega_spec(drive_start), relative_to="chassis")


_VEHICLE_STATIC: dict = {}  # beam form -> the half vehicle's static start (chain coordinates, chassis pose, data)


def vehicle_static(method: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict]:
    """The half vehicle at rest: statics of `build_vehicle(static=True)` (chassis free to settle on the chain,
    penalty contacts, IPOPT), warm-started from the chain's equilibrium on the wheels held in place
    (`static_start`), one bottom node of the chain pinned for the solve only (as there). Without it the band's
    push on the wheels (0.8 MN on the ground with the wheels held, 20 times the vehicle's weight) would throw the
    chassis up at the release. Returns the chain's coordinates, the static chassis' reference centre, its centre and
    axes (rows) at the equilibrium, and the solves' data (solved once per beam form and process)."""
    if method not in _VEHICLE_STATIC:
        xc, st = static_start(method)
        fixed = Assembly(build_scene(method)).mesh.members["chain"]
        sc = build_vehicle(method, static=True)
        sc.pin("chain", at=PIN_NODE)
        asm_s = Assembly(sc)
        mm = asm_s.mesh.members["chain"]
        n_chain = mm.n_nodes * 12
        x0 = np.array(asm_s.x0, float)
        x0[mm.offset:mm.offset + n_chain] = xc[fixed.offset:fixed.offset + n_chain]
        t0 = time.perf_counter()
        r = solve_static(asm_s, warm_start=x0, print_level=0)
        if not r.success:
            raise RuntimeError(f"static start of the vehicle ({method}): {r.status}")
        st.update(vehicle_static_s=time.perf_counter() - t0, vehicle_static_iterations=r.iterations)
        o = asm_s.mesh.bodies["chassis"]
        _VEHICLE_STATIC[method] = (np.array(r.x[mm.offset:mm.offset + n_chain], float),
                                   sc.bodies["chassis"].position.copy(), np.array(r.x[o:o + 3], float),
                                   np.array(r.x[o + 3:o + 12], float).reshape(3, 3), st)
    xc, cg, rc, E, st = _VEHICLE_STATIC[method]
    return xc.copy(), cg.copy(), rc.copy(), E.copy(), dict(st)


def vehicle_start(method: str, ground_mu: float | None = None, drive_start: float = DRIVE_START,
                  full: bool = False) -> tuple[Assembly, np.ndarray, dict]:
    """The driven vehicle at rest: the half vehicle's statics (`vehicle_static`), its chassis' rigid motion placing
    the chassis, the wheels (spin 0) and the slides of the dynamic scene. The full vehicle, symmetric, is two such
    halves on one chassis (twice the mass, the same centre): its equilibrium is the half's, the chain copied into
    each side's plane. Returns the dynamic run's assembly, q0 and the solves' data."""
    xc, cg, rc, E, st = vehicle_static(method)
    asm = Assembly(build_vehicle(method, ground_mu, drive_start, full=full))
    q0 = np.array(asm.x0, float)
    chain = xc.reshape(-1, 12).copy()
    for name, mm in asm.mesh.members.items():
        side = chain.copy()
        side[:, 2] += q0[mm.offset + 2]  # into the side's plane (node 0's reference z: the loop's offset)
        if name == "chain_right":  # the left chain's mirror image: an exactly symmetric start
            side = mirrored(chain.copy() + np.r_[0.0, 0.0, SIDES["left"], np.zeros(9)])
        q0[mm.offset:mm.offset + side.size] = side.ravel()
    for name, b in asm.scene.bodies.items():
        ob = asm.mesh.bodies[name]
        centre = rc + E.T @ (b.position - cg)
        if name == "slide_x":  # slides along x only, at its reference height (slide_y: on the chassis' centre)
            q0[ob:ob + 3] = (centre[0], b.position[1], b.position[2])
            continue
        q0[ob:ob + 3] = centre
        if name != "slide_y":  # (the slides do not turn)
            q0[ob + 3:ob + 12] = E.ravel()
    return asm, q0, st


def mirrored(nodes: np.ndarray) -> np.ndarray:
    """beam3d nodes (n, 12: r, r_x, r_y, r_z) mirrored in the plane z = 0: r, r_x and r_z mirrored, r_y mirrored
    and reversed so that the frame stays right-handed (the section's y axis turned over: for a section symmetric
    about its z axis and an isotropic material the same strain energy, the shears that involve y changing sign)."""
    out = np.array(nodes, float)
    out[:, [2, 5, 6, 7, 11]] *= -1.0
    return out


def chassis_angles(ch: np.ndarray) -> dict[str, np.ndarray]:
    """Pitch (nose up), roll (about the forward axis) and yaw (about the up axis) [deg] of the chassis from its
    "body" sensor rows (centre, omega, axes e1, e2, e3): e1 forward, e2 up in the reference state."""
    e1, e2 = ch[:, 6:9], ch[:, 9:12]
    return {"pitch_deg": np.degrees(np.arctan2(e1[:, 1], e1[:, 0])),
            "roll_deg": np.degrees(np.arctan2(e2[:, 2], e2[:, 1])),
            "yaw_deg": np.degrees(np.arctan2(-e1[:, 2], e1[:, 0]))}


def member_states(res, mm) -> np.ndarray:
    """(n_outputs, n_nodes, node_size) coordinates of one member at the output times (the run's recorded states)."""
    return res.states[:, mm.offset:mm.offset + mm.x0.size].reshape(len(res.t), mm.n_nodes, -1)


def run_vehicle(method: str, t_end: float, dt: float, drive_start: float = DRIVE_START, rho_inf: float = 0.5,
                output_dt: float = 0.05, ground_mu: float | None = None,
                full: bool = False) -> tuple[list[dict], dict]:
    """The driven vehicle (half, or full) from rest: records of the chassis' motion (paper axes), the no-slip
    estimate, the drives' torque and work, the energies and contacts at every output time."""
    asm, q0, st = vehicle_start(method, ground_mu, drive_start, full)
    sc = asm.scene
    sensors = [Sensor(b, "body", b) for b in sc.bodies]
    opts = DynamicOptions(dt=dt, t_end=t_end, rho_inf=rho_inf, output_dt=output_dt, sensors=sensors, q0=q0,
                          newton=NEWTON, record_states=True)
    t0 = time.perf_counter()
    res = simulate(asm, opts)
    wall = time.perf_counter() - t0
    chains = {c: member_states(res, mm) for c, mm in asm.mesh.members.items()}
    states = np.concatenate(list(chains.values()), axis=1)
    t = np.asarray(res.t)
    ch = np.asarray(res.sensors["chassis"])  # centre (3), omega (3), axes (9)
    d = ch[:, :3] - ch[0, :3]
    vel = np.gradient(ch[:, :3], t, axis=0, edge_order=2) if len(t) > 2 else np.zeros_like(d)
    ang = chassis_angles(ch)
    angle, omega = sprocket_angle(t, drive_start)
    torques = [np.asarray(res.drive_reactions.get(f"angle {b}", np.full(len(t), np.nan)), float).ravel()
               for b in sc.bodies if b.startswith("sprocket")]
    torque = np.sum(torques, axis=0)
    mirror = None
    if full:  # symmetry: the left chain against the right one mirrored in the vehicle's middle plane z = 0
        right = chains["chain_right"][:, :, :3] * np.array([1.0, 1.0, -1.0])
        mirror = np.linalg.norm(chains["chain_left"][:, :, :3] - right, axis=2).max(axis=1)
    en = res.energies
    records = []
    for k in range(len(t)):
        x = np.array(res.x, float)
        for c, S in chains.items():
            o = asm.mesh.members[c].offset
            x[o:o + S[k].size] = S[k].ravel()
        for b, o in asm.mesh.bodies.items():  # bodies' centre and axes, for the contact report
            x[o:o + 3], x[o + 3:o + 12] = res.sensors[b][k][:3], res.sensors[b][k][6:15]
        reps = contact.report(asm, x)
        ground = [rp for rp in reps if rp["type"] == "ground"]
        drums = [rp for rp in reps if rp["type"] != "ground"]
        rec = {"case": "full" if full else "driven", "method": method, "t": float(t[k]), "x": float(d[k, 2]),
               "y": float(d[k, 0]), "z": float(d[k, 1]), "vy": float(vel[k, 0]), "wall_s": wall,
               "status": res.status, **{a: float(v[k]) for a, v in ang.items()},
               "sprocket_angle": float(angle[k]), "sprocket_omega": float(omega[k]),
               "y_no_slip": float(R_PITCH * angle[k]), "v_no_slip": float(R_PITCH * omega[k]),
               "drive_torque": float(torque[k]) if k < len(torque) else float("nan"),
               "ground_gap_min": min(rp["min_gap"] for rp in ground),
               "ground_force": sum(rp["normal_force"] for rp in ground),
               "wheel_gap_min": min(rp["min_gap"] for rp in drums),
               "wheel_force": sum(rp["normal_force"] for rp in drums),
               "stretch_mean": float(np.linalg.norm(states[k, :, 3:6], axis=1).mean() - 1.0),
               "chain_bottom": float(states[k, :, 1].min()),
               **{e: float(en[e][k]) for e in ("kinetic", "potential", "damping_work", "external_work",
                                               "algorithmic")}}
        if full:
            rec.update(vx=float(vel[k, 2]), chain_asymmetry=float(mirror[k]),
                       **{f"drive_torque_{s}": float(tq[k]) for s, tq in zip(SIDES, torques) if k < len(tq)},
                       **{f"ground_force_{s}": sum(rp["normal_force"] for rp in ground if rp["member"].endswith(s))
                          for s in SIDES})
        records.append(rec)
    summary = {"case": "full" if full else "driven", "method": method, "status": res.status,
               "success": res.success, "t_reached": res.t_reached, "steps": res.steps, "rejected": len(res.rejected),
               "newton": res.newton_iterations, "factorizations": res.factorizations, "wall_s": wall,
               "setup_s": res.setup_s, "cpu_s": res.cpu_s, "ms_per_step": 1e3 * res.wall_s / max(res.steps, 1),
               "cpu_ms_per_step": 1e3 * res.cpu_s / max(res.steps, 1), "energy_error": res.energy_error(),
               "n_coordinates": asm.n, **st}
    for r in records:
        r.update({k: summary[k] for k in ("steps", "rejected", "newton", "factorizations", "cpu_s",
                                          "cpu_ms_per_step", "static_s", "vehicle_static_s", "n_coordinates")})
    return records, {"summary": summary, "t": t, "states": states, "chains": chains, "result": res, "chassis": ch}


def run(method: str, t_end: float, dt: float, integrator: str = "generalized_alpha", rho_inf: float = 0.5,
        output_dt: float = 0.05, speed: float = 0.0, ground_mu: float | None = None,
        case: str = "rest") -> tuple[list[dict], dict]:
    sc = build_scene(method, ground_mu)
    asm = Assembly(sc)
    q0, st = static_start(method)
    v0 = circulating(asm, speed) if speed else None
    opts = DynamicOptions(dt=dt, t_end=t_end, integrator=integrator, rho_inf=rho_inf, output_dt=output_dt,
                          q0=q0, v0=v0, newton=NEWTON, record_states=True)
    t0 = time.perf_counter()
    res = simulate(asm, opts)
    wall = time.perf_counter() - t0
    mm = asm.mesh.members["chain"]
    states = member_states(res, mm)
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


def _pair_diff(runs: list[dict], records: list[dict]) -> None:
    """CMM vs ELM: the largest distance between the chains' nodes at each output time, into the records of each
    case run with both forms (shape_diff_vs_other)."""
    for c in {r["case"] for r in records}:
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


def _case_records(records, d):
    return [r for r in records if r["method"] == d["summary"]["method"] and r["case"] == d["summary"]["case"]]


def plot_motion(runs, records, out):
    """X, Y, Z and the forward speed over time (paper 001's Figs. 11-12), with the no-slip estimates."""
    plt = C.pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(11, 7))
    for d in runs:
        m, c = d["summary"]["method"], d["summary"]["case"]
        rs = _case_records(records, d)
        t = [r["t"] for r in rs]
        for ax, k in zip(axes.ravel(), ("x", "y", "z", "vy")):
            ax.plot(t, [r[k] for r in rs], label=f"{c}, {m}")
            ax.set_xlabel("t [s]"), ax.set_ylabel(AXIS_LABELS[k])
        if c == "running":  # the chain runs round the wheels: its rms speed sqrt(2 T / m)
            axes[1, 1].plot(t, [r["chain_speed"] for r in rs], "--", label=f"{c}, {m}: chain rms speed")
    drv = [d for d in runs if d["summary"]["case"] in ("driven", "full")]
    if drv:
        rs = _case_records(records, drv[0])
        t = [r["t"] for r in rs]
        axes[0, 1].plot(t, [r["y_no_slip"] for r in rs], "k:", label="no slip: sprocket angle x pitch radius")
        axes[1, 1].plot(t, [r["v_no_slip"] for r in rs], "k:", label="no slip: omega x pitch radius")
    for ax in axes.ravel():
        ax.legend(fontsize=7)
    C.save(fig, out, "displacement_speed.png")


def plot_energy(runs, records, out):
    """Energy bookkeeping per run: E(0) + drive work = kinetic + potential + dissipated + integrator's share."""
    plt = C.pyplot()
    fig, axes = plt.subplots(1, len(runs), figsize=(5 * len(runs), 3.6), squeeze=False)
    for ax, d in zip(axes[0], runs):
        m, c = d["summary"]["method"], d["summary"]["case"]
        rs = _case_records(records, d)
        t = [r["t"] for r in rs]
        for k, lab in (("kinetic", "kinetic"), ("potential", "potential - potential(0)"),
                       ("damping_work", "contact damping + friction work"), ("external_work", "drive work"),
                       ("algorithmic", "integrator")):
            ax.plot(t, [r[k] - (rs[0][k] if k == "potential" else 0.0) for r in rs], label=lab)
        ax.set_title(f"{c}, {m}", fontsize=9), ax.set_xlabel("t [s]"), ax.set_ylabel("energy [J]")
    axes[0, 0].legend(fontsize=7)
    C.save(fig, out, "energy.png")


def plot_shapes(runs, out):
    """The chain (and the wheels where they are) at a few instants, side view: a panel per run (the full
    vehicle: its left track; the right one is its mirror image)."""
    plt = C.pyplot()
    fig, axes = plt.subplots(len(runs), 1, figsize=(12, 3.2 * len(runs)), squeeze=False)
    for ax, d in zip(axes[:, 0], runs):
        S, t = next(iter(d.get("chains", {"chain": d["states"]}).values())), d["t"]
        sfx = "_left" if d["summary"]["case"] == "full" else ""
        ks = sorted({0, len(S) // 4, len(S) // 2, 3 * len(S) // 4, len(S) - 1})
        for k in ks:
            r = S[k, :, :3]
            line, = ax.plot(np.r_[r[:, 0], r[:1, 0]], np.r_[r[:, 1], r[:1, 1]], ".-", ms=2, lw=0.8,
                            label=f"t = {t[k]:.2f} s")
            res = d["result"]
            for name, _, R in wheels(idler_x()):
                if name + sfx in res.sensors:  # a wheel carried by the chassis: where it is now
                    c = np.asarray(res.sensors[name + sfx])[k, :2]
                    ax.add_patch(plt.Circle(c, R, fill=False, color=line.get_color(), lw=0.6))
        if "chassis" not in d["result"].sensors:
            for name, c, R in wheels(idler_x()):
                ax.add_patch(plt.Circle(c, R, fill=False, color="0.5"))
        ax.axhline(0.0, color="k", lw=0.8)
        ax.set_title(f"{d['summary']['case']}, {d['summary']['method']}", fontsize=9)
        ax.set_aspect("equal"), ax.legend(fontsize=7, ncol=len(ks)), ax.set_xlabel("forward [m]")
        ax.set_ylabel("up [m]")
    C.save(fig, out, "chain_shape.png")


def plot_full(runs, records, out):
    """The full vehicle's symmetry over time: lateral X, roll, yaw and the chains' mirror asymmetry (log scale: the
    symmetric vehicle keeps them at round-off), and both tracks seen from behind at the last output."""
    full = [d for d in runs if d["summary"]["case"] == "full"]
    if not full:
        return
    plt = C.pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(14, 3.8))
    for d in full:
        m = d["summary"]["method"]
        rs = _case_records(records, d)
        t = [r["t"] for r in rs]
        for k, lab in (("x", "|X| [m]"), ("chain_asymmetry", "chain asymmetry [m]")):
            axes[0].semilogy(t, [max(abs(r[k]), 1e-300) for r in rs], label=f"{m}: {lab}")
        for k in ("roll_deg", "yaw_deg"):
            axes[1].semilogy(t, [max(abs(r[k]), 1e-300) for r in rs], label=f"{m}: |{k[:-4]}| [deg]")
        for c, S in d["chains"].items():
            axes[2].plot(S[-1, :, 2], S[-1, :, 1], ".", ms=2, label=f"{m}: {c}, t = {d['t'][-1]:.2f} s")
    for ax in axes[:2]:
        ax.set_xlabel("t [s]"), ax.legend(fontsize=7)
    axes[2].axhline(0.0, color="k", lw=0.8)
    axes[2].set_xlabel("lateral (paper X) [m]"), axes[2].set_ylabel("up [m]"), axes[2].set_aspect("equal")
    axes[2].legend(fontsize=7)
    C.save(fig, out, "full_vehicle_symmetry.png")


def write_vtk(runs, out):
    for d in runs:
        dest = Path(out) / f"vtk_{d['summary']['case']}_{d['summary']['method']}"
        Path(out).mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(dir=out))
        write_series(d["result"], tmp)
        if dest.exists():
            shutil.rmtree(dest)
        tmp.rename(dest)
        print(f"VTK series: {dest / 'series.pvd'}")


def main(argv=None):
    p = C.parser("tracked_vehicle", __doc__)
    p.add_argument("--methods", default="continuum,elastic_line", help="comma-separated beam forms")
    p.add_argument("--t-end", type=float, default=None, help="end time [s] (default 5; --quick: fixed wheels 0.02, driven 0.3, full 0.2)")
    p.add_argument("--dt", type=float, default=None,
                   help=f"time step [s] (default 2e-4; --quick --vehicle full: {QUICK_FULL_DT})")
    p.add_argument("--vehicle", choices=("half", "full"), default="half",
                   help="the driven half vehicle (planar chassis, one chain) or the full vehicle (spatial chassis, "
                        "two chains)")
    p.add_argument("--fixed-wheels", action="store_true",
                   help="the first stage: the chain on wheels held in space (at rest, or running with --speed)")
    p.add_argument("--drive-start", type=float, default=DRIVE_START,
                   help=f"time [s] at which omega(t) starts its ramp (paper: {DRIVE_START}; --quick: 0)")
    p.add_argument("--integrator", default="generalized_alpha")
    p.add_argument("--speed", type=float, default=0.0,
                   help="fixed wheels: start the chain running along its path at this speed [m/s] instead of at rest")
    p.add_argument("--ground-mu", type=float, default=None, help=f"ground friction (default {GROUND['mu']})")
    a = p.parse_args(argv)
    methods = a.methods.split(",")
    for m in methods:
        if m not in ("continuum", "elastic_line"):
            raise SystemExit(f"--methods: {m!r} is not a beam form (continuum, elastic_line)")
    if a.dt is None:
        a.dt = QUICK_FULL_DT if a.quick and a.vehicle == "full" else 2e-4
    if a.dt <= 0 or not math.isfinite(a.dt):
        raise SystemExit(f"--dt must be a positive time step [s], got {a.dt!r}")
    if a.vehicle == "full" and a.fixed_wheels:
        raise SystemExit("--fixed-wheels is the half vehicle's first stage: leave out --vehicle full")
    full = a.vehicle == "full"
    records, runs = [], []
    if a.fixed_wheels or (a.quick and not full):
        t_end = a.t_end if a.t_end is not None else (QUICK_T if a.quick else 5.0)
        case = "running" if a.speed else "rest"
        cases = [(case, m, a.speed, a.ground_mu) for m in methods]
        if a.quick:  # and the chain running at the speed plateau's 2.45 m/s on a frictionless ground (a belt on a stand)
            cases.append(("running", "elastic_line", RUN_SPEED, 0.0))
        for case, method, speed, mu in cases:
            recs, data = run(method, t_end, a.dt, a.integrator, speed=speed, ground_mu=mu, case=case)
            records += recs
            runs.append(data)
    if not a.fixed_wheels:
        drive_start = 0.0 if a.quick else a.drive_start
        quick_t = QUICK_FULL_T if full else QUICK_DRIVEN_T
        t_end = quick_t if a.quick else (a.t_end if a.t_end is not None else 5.0)
        for method in (["elastic_line"] if a.quick else methods):
            recs, data = run_vehicle(method, t_end, a.dt, drive_start, ground_mu=a.ground_mu, full=full)
            records += recs
            runs.append(data)
    _pair_diff(runs, records)
    C.table([d["summary"] for d in runs], ["case", "method", "status", "steps", "rejected", "newton",
                                          "factorizations", "ms_per_step", "cpu_ms_per_step", "wall_s",
                                          "energy_error"])
    for d in runs:
        if d["summary"]["case"] in ("driven", "full"):
            r = _case_records(records, d)[-1]
            print(f"{d['summary']['case']}, {d['summary']['method']}: t = {r['t']:.2f} s, y = {r['y']:.4f} m (no slip "
                  f"{r['y_no_slip']:.4f} m), vy = {r['vy']:.4f} m/s (no slip {r['v_no_slip']:.4f}), drive work "
                  f"{r['external_work']:.1f} J, dissipated {r['damping_work']:.1f} J, integrator {r['algorithmic']:.1f} J")

    def plots(out):
        plot_motion(runs, records, out)
        plot_energy(runs, records, out)
        plot_shapes(runs, out)
        plot_full(runs, records, out)
        write_vtk(runs, out)

    return C.finish(records, a, plots)


if __name__ == "__main__":
    main()
